//! Ridge clearance of a synthesised divide tree: no peak or saddle stands
//! within a few cells of a ridge that the tree joins to it only lower down.
//!
//! A raster joins two crest points a cell or two apart at about the lower of
//! their elevations. When that is above the tree's pass height between them
//! ([`PassHeights`]: the lowest saddle on their tree path), the terrain's
//! divide tree is not the synthesised one: a peak's key saddle rises and its
//! prominence falls (docs/design/orometric-synthesis.md#tin-tinterrain: 7 of the 8 tree peaks the session-7
//! render lost stood within 2.6 cells of such a ridge; docs/design/orometric-synthesis.md#ridge-clearance-clearancers).
//! The paper's dart throwing keeps peaks apart from each other (Argudo et
//! al. 2019, §5.1) but not from ridges; this pass adds that, after the
//! saddle elevations are known (they decide which ridges offend).
//!
//! An *offence* of a node against a half-ridge (peak → saddle): the parts of
//! both standing more than a tolerance above their pass height come closer
//! than `clear`. A peak's part is the peak; a saddle's, the half-ridges on
//! either side of it, each with its own pass height. The tolerance is the
//! caller's (the noise bound), at most half the margin by which the peak
//! owning the pass's saddle clears the threshold.
//!
//! Each offending peak that is not fixed, then each offending saddle, moves
//! straight away from the nearest offending ridge point (or, failing that,
//! at ±45° or ±90° to that direction) to `clear` metres from it, snapped to
//! its cell centre. A move is taken only if it brings the node farther from
//! every offending ridge, keeps a peak two cells from every other peak and
//! off every saddle's cell (a saddle off every peak's cell, and between its
//! peaks), is allowed by the caller (type-map region, density map, pasted
//! saddles), and keeps the ridges planar: no moved ridge segment touches
//! another one except at a shared end (crossing ridges make the constrained
//! triangulation of the terrain drop a segment, see `rivers::cdt_dropping`).
//! Elevations and the tree's topology are unchanged, so prominence and
//! dominance are too.
//!
//! Cost: a bucket grid of the ridge segments; each round is O((P + S) · k)
//! with k the segments near a node, a geometric test first and pass heights
//! in O(log P) each.

use super::assign::owners;
use super::minimax::{PassHeights, RidgeAnchor};
use super::tree_synth::SynthTree;

/// Rounds over all peaks (a move shifts the moved peak's own ridges, which
/// may then come near another peak).
const ROUNDS: usize = 6;

/// Directions tried, as rotations (radians) of "straight away".
const TURNS: [f64; 5] = [
    0.0,
    std::f64::consts::FRAC_PI_4,
    -std::f64::consts::FRAC_PI_4,
    std::f64::consts::FRAC_PI_2,
    -std::f64::consts::FRAC_PI_2,
];

/// Half-ridge segment `id`: from peak `saddles[id / 2].peaks[id % 2]` to
/// saddle `id / 2`.
fn ends(tree: &SynthTree, id: u32) -> (usize, usize) {
    let k = (id / 2) as usize;
    (tree.saddles[k].peaks[(id % 2) as usize], k)
}

/// Segments bucketed by their bounding boxes (a segment sits in every bucket
/// its box overlaps; moved segments are added again where they now lie, and
/// their geometry is always read from the tree).
struct SegGrid {
    side: f64,
    nx: usize,
    ny: usize,
    buckets: Vec<Vec<u32>>,
    stamp: Vec<u32>,
    epoch: u32,
}

impl SegGrid {
    fn new(tree: &SynthTree, clear: f64) -> SegGrid {
        let (wm, hm) = (
            tree.width as f64 * tree.cell,
            tree.height as f64 * tree.cell,
        );
        let spacing = (wm * hm / tree.peaks.len().max(1) as f64).sqrt();
        let side = clear.max(spacing).max(tree.cell);
        let nx = ((wm / side).ceil() as usize).max(1);
        let ny = ((hm / side).ceil() as usize).max(1);
        let mut g = SegGrid {
            side,
            nx,
            ny,
            buckets: vec![Vec::new(); nx * ny],
            stamp: vec![0; 2 * tree.saddles.len()],
            epoch: 0,
        };
        for id in 0..2 * tree.saddles.len() as u32 {
            g.insert(tree, id);
        }
        g
    }

    fn range(&self, x0: f64, y0: f64, x1: f64, y1: f64) -> (usize, usize, usize, usize) {
        let ix = |v: f64| ((v / self.side).floor().max(0.0) as usize).min(self.nx - 1);
        let iy = |v: f64| ((v / self.side).floor().max(0.0) as usize).min(self.ny - 1);
        (ix(x0), iy(y0), ix(x1), iy(y1))
    }

    fn insert(&mut self, tree: &SynthTree, id: u32) {
        let (p, k) = ends(tree, id);
        let (a, s) = (&tree.peaks[p], &tree.saddles[k]);
        let (x0, y0, x1, y1) = self.range(a.x.min(s.x), a.y.min(s.y), a.x.max(s.x), a.y.max(s.y));
        for by in y0..=y1 {
            for bx in x0..=x1 {
                let b = &mut self.buckets[by * self.nx + bx];
                if !b.contains(&id) {
                    b.push(id);
                }
            }
        }
    }

    /// Each segment registered in a bucket overlapping the box, once.
    fn visit(&mut self, x0: f64, y0: f64, x1: f64, y1: f64, mut f: impl FnMut(u32)) {
        self.epoch = self.epoch.wrapping_add(1);
        if self.epoch == 0 {
            self.stamp.fill(0);
            self.epoch = 1;
        }
        let (bx0, by0, bx1, by1) = self.range(x0, y0, x1, y1);
        for by in by0..=by1 {
            for bx in bx0..=bx1 {
                for &id in &self.buckets[by * self.nx + bx] {
                    if self.stamp[id as usize] != self.epoch {
                        self.stamp[id as usize] = self.epoch;
                        f(id);
                    }
                }
            }
        }
    }
}

/// Closest point of segment a–b to p: (distance, parameter along a → b).
fn closest(px: f64, py: f64, ax: f64, ay: f64, bx: f64, by: f64) -> (f64, f64) {
    let (dx, dy) = (bx - ax, by - ay);
    let l2 = dx * dx + dy * dy;
    let u = if l2 > 0.0 {
        (((px - ax) * dx + (py - ay) * dy) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    ((px - ax - u * dx).hypot(py - ay - u * dy), u)
}

/// Distance between segments a–b and c–d, with the point of c–d nearest
/// a–b (0 and a shared point when they touch).
fn seg_seg(a: (f64, f64), b: (f64, f64), c: (f64, f64), d: (f64, f64)) -> (f64, f64, f64) {
    if touch(a, b, c, d) {
        // Where they meet: c–d's point nearest a–b's line is on both.
        let o1 = orient(a.0, a.1, b.0, b.1, c.0, c.1);
        let o2 = orient(a.0, a.1, b.0, b.1, d.0, d.1);
        let t = if o1 != o2 { o1 / (o1 - o2) } else { 0.0 };
        return (0.0, c.0 + t * (d.0 - c.0), c.1 + t * (d.1 - c.1));
    }
    let mut best = (f64::INFINITY, c.0, c.1);
    // From a and b to c–d.
    for e in [a, b] {
        let (dd, u) = closest(e.0, e.1, c.0, c.1, d.0, d.1);
        if dd < best.0 {
            best = (dd, c.0 + u * (d.0 - c.0), c.1 + u * (d.1 - c.1));
        }
    }
    // From c and d to a–b.
    for e in [c, d] {
        let (dd, _) = closest(e.0, e.1, a.0, a.1, b.0, b.1);
        if dd < best.0 {
            best = (dd, e.0, e.1);
        }
    }
    best
}

fn orient(ax: f64, ay: f64, bx: f64, by: f64, cx: f64, cy: f64) -> f64 {
    (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
}

/// Whether closed segments p–q and r–s share a point.
fn touch(p: (f64, f64), q: (f64, f64), r: (f64, f64), s: (f64, f64)) -> bool {
    let o1 = orient(p.0, p.1, q.0, q.1, r.0, r.1);
    let o2 = orient(p.0, p.1, q.0, q.1, s.0, s.1);
    let o3 = orient(r.0, r.1, s.0, s.1, p.0, p.1);
    let o4 = orient(r.0, r.1, s.0, s.1, q.0, q.1);
    if o1 == 0.0 && o2 == 0.0 {
        // Collinear: overlapping projections.
        let ov = |a: f64, b: f64, c: f64, d: f64| a.min(b) <= c.max(d) && c.min(d) <= a.max(b);
        return ov(p.0, q.0, r.0, s.0) && ov(p.1, q.1, r.1, s.1);
    }
    o1 * o2 <= 0.0 && o3 * o4 <= 0.0
}

/// Whether (x, y) lies between saddle `j`'s peaks: projected on the line
/// joining them within its middle 70 %, and at most 30 % of their distance
/// off it (the synthesis places saddles within the middle 30 % and 10 %
/// off). Without it, repeated moves walked a saddle past its peak into a
/// hairpin ridge whose two halves the raster then joined (Dallas seed 2 at
/// 600², docs/design/orometric-synthesis.md#ridge-clearance-clearancers).
fn between_its_peaks(tree: &SynthTree, j: usize, x: f64, y: f64) -> bool {
    let [p, q] = tree.saddles[j].peaks;
    let (a, b) = (&tree.peaks[p], &tree.peaks[q]);
    let (dx, dy) = (b.x - a.x, b.y - a.y);
    let l2 = dx * dx + dy * dy;
    if l2 == 0.0 {
        return false;
    }
    let t = ((x - a.x) * dx + (y - a.y) * dy) / l2;
    let off = ((x - a.x) * dy - (y - a.y) * dx).abs() / l2;
    (0.15..=0.85).contains(&t) && off <= 0.3
}

/// A point of the tree that may move: a peak or a saddle (index).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Node {
    Peak(usize),
    Saddle(usize),
}

struct Clearer<'a> {
    pass: PassHeights,
    grid: SegGrid,
    clear: f64,
    tol: f64,
    /// (elevation, prominence margin over the threshold of the peak whose
    /// key saddle it is) of every saddle, by elevation.
    margins: Vec<(f64, f64)>,
    /// Saddles of each peak.
    incident: Vec<Vec<u32>>,
    may_move: &'a mut dyn FnMut(Node, f64, f64) -> bool,
}

impl Clearer<'_> {
    /// Tolerance of a join above pass height `pass`: `tol`, but at most
    /// half the margin by which the peak owning the saddle at that height
    /// clears the threshold (a join that much higher would drop it).
    fn tol_at(&self, pass: f64) -> f64 {
        let i = self.margins.partition_point(|m| m.0 < pass);
        let m = self.margins[i..]
            .iter()
            .take_while(|m| m.0 == pass)
            .map(|m| m.1)
            .fold(f64::INFINITY, f64::min);
        if m >= 0.0 {
            self.tol.min(0.5 * m)
        } else {
            self.tol
        }
    }

    /// The stretches of a node's crest and of half-ridge (p, k) above their
    /// pass height plus tolerance, and the distance between them: (distance,
    /// nearest point of the half-ridge's stretch); None for the node's own
    /// half-ridges or when either stretch is empty. A peak's crest is the
    /// peak; a saddle's is the half-ridge on either side of it, each side
    /// with its own pass height.
    fn offence(
        &self,
        tree: &SynthTree,
        node: Node,
        x: f64,
        y: f64,
        p: usize,
        k: usize,
    ) -> Option<(f64, f64, f64)> {
        let half = RidgeAnchor::Half(p as u32, k as u32);
        let inf = f64::INFINITY;
        let (a, s) = (&tree.peaks[p], &tree.saddles[k]);
        // The part of a half-ridge from its peak end `a` towards its saddle
        // end `b` standing above `level`: its far end.
        let above = |ax: f64, ay: f64, az: f64, bx: f64, by: f64, bz: f64, level: f64| {
            if az <= level {
                return None;
            }
            let u = if az > bz {
                ((az - level) / (az - bz)).min(1.0)
            } else {
                1.0
            };
            Some((ax + u * (bx - ax), ay + u * (by - ay)))
        };
        match node {
            Node::Peak(i) => {
                // Cheap test first: the whole half-ridge out of reach.
                if p == i || closest(x, y, a.x, a.y, s.x, s.y).0 >= self.clear {
                    return None;
                }
                let pass = self
                    .pass
                    .between(RidgeAnchor::Peak(i as u32), inf, half, inf);
                let level = pass + self.tol_at(pass);
                if tree.peaks[i].elevation <= level {
                    return None;
                }
                let (ex, ey) = above(a.x, a.y, a.elevation, s.x, s.y, s.elevation, level)?;
                let (d, u) = closest(x, y, a.x, a.y, ex, ey);
                Some((d, a.x + u * (ex - a.x), a.y + u * (ey - a.y)))
            }
            Node::Saddle(j) => {
                if k == j {
                    return None;
                }
                let sj = &tree.saddles[j];
                let mut best: Option<(f64, f64, f64)> = None;
                for q in sj.peaks {
                    let c = &tree.peaks[q];
                    if seg_seg((c.x, c.y), (x, y), (a.x, a.y), (s.x, s.y)).0 >= self.clear {
                        continue;
                    }
                    let pass =
                        self.pass
                            .between(RidgeAnchor::Half(q as u32, j as u32), inf, half, inf);
                    let level = pass + self.tol_at(pass);
                    // This side's crest from its peak to the saddle at (x, y).
                    let Some((fx, fy)) = above(c.x, c.y, c.elevation, x, y, sj.elevation, level)
                    else {
                        continue;
                    };
                    let Some((ex, ey)) = above(a.x, a.y, a.elevation, s.x, s.y, s.elevation, level)
                    else {
                        continue;
                    };
                    let (d, px, py) = seg_seg((c.x, c.y), (fx, fy), (a.x, a.y), (ex, ey));
                    if best.is_none_or(|b| d < b.0) {
                        best = Some((d, px, py));
                    }
                }
                best
            }
        }
    }

    /// Distance from (x, y), where `node` would stand, to the nearest
    /// offending ridge stretch closer than `clear` (see [`Self::offence`]),
    /// with its nearest point; None if there is none.
    fn nearest_offence(
        &mut self,
        tree: &SynthTree,
        node: Node,
        x: f64,
        y: f64,
    ) -> Option<(f64, f64, f64)> {
        let c = self.clear;
        // A saddle's crest reaches as far as its peaks.
        let (mut x0, mut y0, mut x1, mut y1) = (x - c, y - c, x + c, y + c);
        if let Node::Saddle(j) = node {
            for &q in &tree.saddles[j].peaks {
                let p = &tree.peaks[q];
                (x0, y0) = (x0.min(p.x - c), y0.min(p.y - c));
                (x1, y1) = (x1.max(p.x + c), y1.max(p.y + c));
            }
        }
        let mut found: Vec<u32> = Vec::new();
        self.grid.visit(x0, y0, x1, y1, |id| found.push(id));
        let mut best: Option<(f64, f64, f64)> = None;
        for id in found {
            let (p, k) = ends(tree, id);
            if let Some(o) = self.offence(tree, node, x, y, p, k) {
                if o.0 < c && best.is_none_or(|b| o.0 < b.0) {
                    best = Some(o);
                }
            }
        }
        best
    }

    /// Whether (x, y) has room for `node`: a peak two cells from every
    /// other peak and off every saddle's cell; a saddle off every peak's
    /// cell.
    fn roomy(&mut self, tree: &SynthTree, node: Node, x: f64, y: f64) -> bool {
        let cell = tree.cell;
        let r = 2.0 * cell;
        let cell_of = |v: f64| (v / cell).floor();
        let same_cell = |u: f64, v: f64| cell_of(u) == cell_of(x) && cell_of(v) == cell_of(y);
        let mut ok = true;
        self.grid.visit(x - r, y - r, x + r, y + r, |id| {
            let (p, k) = ends(tree, id);
            let (a, s) = (&tree.peaks[p], &tree.saddles[k]);
            match node {
                Node::Peak(i) => {
                    if (p != i && (a.x - x).hypot(a.y - y) < r - 1e-9) || same_cell(s.x, s.y) {
                        ok = false;
                    }
                }
                Node::Saddle(_) => {
                    if same_cell(a.x, a.y) {
                        ok = false;
                    }
                }
            }
        });
        if let Node::Saddle(j) = node {
            ok &= between_its_peaks(tree, j, x, y);
        }
        ok
    }

    /// The half-ridges that move with `node`: (peak end, saddle).
    fn moving(&self, tree: &SynthTree, node: Node) -> Vec<(usize, usize)> {
        match node {
            Node::Peak(i) => self.incident[i].iter().map(|&k| (i, k as usize)).collect(),
            Node::Saddle(j) => tree.saddles[j].peaks.iter().map(|&p| (p, j)).collect(),
        }
    }

    /// Whether the half-ridges of `node`, moved to (x, y), touch another
    /// segment anywhere but at a shared end.
    fn crosses(&mut self, tree: &SynthTree, node: Node, x: f64, y: f64) -> bool {
        for (p, k) in self.moving(tree, node) {
            let ((px, py), (sx, sy)) = match node {
                Node::Peak(_) => ((x, y), (tree.saddles[k].x, tree.saddles[k].y)),
                Node::Saddle(_) => ((tree.peaks[p].x, tree.peaks[p].y), (x, y)),
            };
            let mut hit = false;
            self.grid
                .visit(px.min(sx), py.min(sy), px.max(sx), py.max(sy), |id| {
                    let (pa, ka) = ends(tree, id);
                    if pa == p || ka == k {
                        return;
                    }
                    let (a, b) = (&tree.peaks[pa], &tree.saddles[ka]);
                    if touch((px, py), (sx, sy), (a.x, a.y), (b.x, b.y)) {
                        hit = true;
                    }
                });
            if hit {
                return true;
            }
        }
        false
    }

    /// Try to move `node`; whether it moved.
    fn relieve(&mut self, tree: &mut SynthTree, node: Node) -> bool {
        let (px, py) = match node {
            Node::Peak(i) => (tree.peaks[i].x, tree.peaks[i].y),
            Node::Saddle(j) => (tree.saddles[j].x, tree.saddles[j].y),
        };
        let Some((d, cx, cy)) = self.nearest_offence(tree, node, px, py) else {
            return false;
        };
        let (ux, uy) = if d > 0.0 {
            ((px - cx) / d, (py - cy) / d)
        } else {
            (1.0, 0.0)
        };
        let cell = tree.cell;
        let snap = |v: f64, n: usize| ((v / cell).floor().clamp(0.0, n as f64 - 1.0) + 0.5) * cell;
        // Past `clear` by half a cell, so that snapping does not fall short.
        let step = self.clear - d + 0.5 * cell;
        for t in TURNS {
            let (vx, vy) = (ux * t.cos() - uy * t.sin(), ux * t.sin() + uy * t.cos());
            let (x, y) = (
                snap(px + vx * step, tree.width),
                snap(py + vy * step, tree.height),
            );
            if (x == px && y == py) || !(self.may_move)(node, x, y) || !self.roomy(tree, node, x, y)
            {
                continue;
            }
            if self
                .nearest_offence(tree, node, x, y)
                .is_some_and(|(nd, _, _)| nd <= d)
            {
                continue;
            }
            if self.crosses(tree, node, x, y) {
                continue;
            }
            match node {
                Node::Peak(i) => (tree.peaks[i].x, tree.peaks[i].y) = (x, y),
                Node::Saddle(j) => (tree.saddles[j].x, tree.saddles[j].y) = (x, y),
            }
            for (p, k) in self.moving(tree, node) {
                let side = u32::from(tree.saddles[k].peaks[0] != p);
                self.grid.insert(tree, 2 * k as u32 + side);
            }
            return true;
        }
        false
    }

    fn offenders(&mut self, tree: &SynthTree) -> Vec<Node> {
        let peaks = (0..tree.peaks.len()).map(Node::Peak);
        let saddles = (0..tree.saddles.len()).map(Node::Saddle);
        peaks
            .chain(saddles)
            .filter(|&n| {
                let (x, y) = match n {
                    Node::Peak(i) => (tree.peaks[i].x, tree.peaks[i].y),
                    Node::Saddle(j) => (tree.saddles[j].x, tree.saddles[j].y),
                };
                self.nearest_offence(tree, n, x, y).is_some()
            })
            .collect()
    }
}

fn clearer<'a>(
    tree: &SynthTree,
    clear: f64,
    tol: f64,
    may_move: &'a mut dyn FnMut(Node, f64, f64) -> bool,
) -> Clearer<'a> {
    let mut incident = vec![Vec::new(); tree.peaks.len()];
    for (k, s) in tree.saddles.iter().enumerate() {
        incident[s.peaks[0]].push(k as u32);
        incident[s.peaks[1]].push(k as u32);
    }
    let h: Vec<f64> = tree.peaks.iter().map(|p| p.elevation).collect();
    let hs: Vec<f64> = tree.saddles.iter().map(|s| s.elevation).collect();
    let prom = tree.prominences();
    let owner = owners(&h, &tree.edges(), &hs);
    let mut margins: Vec<(f64, f64)> = (0..hs.len())
        .map(|k| (hs[k], prom[owner[k]] - tree.min_prominence))
        .collect();
    margins.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    Clearer {
        pass: PassHeights::new(tree),
        grid: SegGrid::new(tree, clear),
        clear,
        tol: tol.max(0.0),
        margins,
        incident,
        may_move,
    }
}

/// Peaks and saddles within `clear` metres of a ridge they are joined to
/// only more than `tol` metres below both (see the module doc): peaks first,
/// in index order.
pub fn offenders(tree: &SynthTree, clear: f64, tol: f64) -> Vec<Node> {
    if tree.saddles.is_empty() || !(clear.is_finite() && clear > 0.0) {
        return Vec::new();
    }
    let mut never = |_: Node, _: f64, _: f64| false;
    clearer(tree, clear, tol, &mut never).offenders(tree)
}

/// What [`clear_ridges`] did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ClearStats {
    /// Moves made (a peak or saddle may move in several rounds).
    pub moves: usize,
}

/// Move peaks that are not fixed, and saddles, away from ridges they are
/// joined to only more than `tol` metres below both (see the module doc),
/// to `clear` metres. `may_move(node, x, y)` vetoes a new position.
/// Deterministic: peaks then saddles in index order, round after round.
pub fn clear_ridges(
    tree: &mut SynthTree,
    clear: f64,
    tol: f64,
    may_move: &mut dyn FnMut(Node, f64, f64) -> bool,
) -> ClearStats {
    let mut stats = ClearStats::default();
    if tree.saddles.is_empty() || !(clear.is_finite() && clear > 0.0) {
        return stats;
    }
    let mut c = clearer(tree, clear, tol, may_move);
    for _ in 0..ROUNDS {
        let mut moved = false;
        let nodes = (0..tree.peaks.len())
            .filter(|&i| !tree.peaks[i].fixed)
            .map(Node::Peak)
            .chain((0..tree.saddles.len()).map(Node::Saddle))
            .collect::<Vec<_>>();
        for n in nodes {
            if c.relieve(tree, n) {
                stats.moves += 1;
                moved = true;
            }
        }
        if !moved {
            break;
        }
    }
    stats
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::oro::stats::SplitMix64;
    use crate::synth::orometric::tree_synth::{ridge_tree, SynthPeak, SynthSaddle};

    /// A free peak at the centre of cell (x, y) of 30 m cells.
    fn pk(x: f64, y: f64, e: f64) -> SynthPeak {
        SynthPeak {
            x: (x + 0.5) * 30.0,
            y: (y + 0.5) * 30.0,
            elevation: e,
            fixed: false,
        }
    }

    /// A saddle at the centre of cell (x, y) of 30 m cells, joining a, b.
    fn sd(x: f64, y: f64, e: f64, a: usize, b: usize) -> SynthSaddle {
        SynthSaddle {
            x: (x + 0.5) * 30.0,
            y: (y + 0.5) * 30.0,
            elevation: e,
            peaks: [a, b],
        }
    }

    /// Random peaks at cell centres two cells apart, ridges the Delaunay
    /// minimum spanning tree, each saddle at its ridge's midpoint below both
    /// ends.
    fn random_tree(n: usize, seed: u64) -> SynthTree {
        let mut r = SplitMix64(seed);
        let (side, cell) = (60usize, 30.0);
        let mut peaks: Vec<SynthPeak> = Vec::new();
        while peaks.len() < n {
            let x = ((r.unit() * side as f64).floor() + 0.5) * cell;
            let y = ((r.unit() * side as f64).floor() + 0.5) * cell;
            if peaks.iter().all(|p| (p.x - x).hypot(p.y - y) >= 2.0 * cell) {
                peaks.push(SynthPeak {
                    x,
                    y,
                    elevation: 1000.0 + 1000.0 * r.unit(),
                    fixed: r.unit() < 0.1,
                });
            }
        }
        let saddles = ridge_tree(&peaks, 0)
            .unwrap()
            .into_iter()
            .map(|(a, b)| {
                let lo = peaks[a].elevation.min(peaks[b].elevation);
                SynthSaddle {
                    x: 0.5 * (peaks[a].x + peaks[b].x),
                    y: 0.5 * (peaks[a].y + peaks[b].y),
                    elevation: lo - 1.0 - 400.0 * r.unit(),
                    peaks: [a, b],
                }
            })
            .collect();
        SynthTree {
            format: "orogen-synthtree".into(),
            version: 1,
            width: side,
            height: side,
            cell,
            seed,
            min_prominence: 20.0,
            peaks,
            saddles,
        }
    }

    /// Oracle pass height: the lowest node on the tree path between two
    /// points, each a peak (`None` half) or a point splitting half-ridge
    /// (p, k) at elevation z, by depth-first search over peaks, saddles and
    /// the split points.
    fn brute_pass(
        t: &SynthTree,
        from: (usize, Option<(usize, f64)>),
        to: (usize, usize, f64),
    ) -> f64 {
        let (np, ns) = (t.peaks.len(), t.saddles.len());
        let mut w: Vec<f64> = t.peaks.iter().map(|p| p.elevation).collect();
        w.extend(t.saddles.iter().map(|s| s.elevation));
        let mut splits = vec![(to.0, to.1, to.2)];
        if let (p, Some((k, z))) = from {
            splits.push((p, k, z));
        }
        let mut adj = vec![Vec::new(); np + ns + splits.len()];
        for (k, s) in t.saddles.iter().enumerate() {
            for &q in &s.peaks {
                let mut chain = vec![q];
                for (m, &(sp, sk, z)) in splits.iter().enumerate() {
                    if sp == q && sk == k {
                        chain.push(np + ns + m);
                        w.push(z);
                    }
                }
                chain.push(np + k);
                for pair in chain.windows(2) {
                    adj[pair[0]].push(pair[1]);
                    adj[pair[1]].push(pair[0]);
                }
            }
        }
        w.resize(np + ns + splits.len(), f64::NAN);
        let start = if from.1.is_some() {
            np + ns + 1
        } else {
            from.0
        };
        let mut low = vec![f64::NAN; w.len()];
        low[start] = w[start];
        let mut stack = vec![start];
        while let Some(u) = stack.pop() {
            for &v in &adj[u] {
                if low[v].is_nan() {
                    low[v] = low[u].min(w[v]);
                    stack.push(v);
                }
            }
        }
        low[np + ns]
    }

    type Point3 = (f64, f64, f64);

    /// Oracle offences of a peak or saddle: the distance between the
    /// nearest offending pair of points sampled along the half-ridges (a
    /// saddle's crest: the half-ridges on either side of it).
    fn brute_offence(t: &SynthTree, node: Node, clear: f64, tol: f64) -> Option<f64> {
        let inf = f64::INFINITY;
        let sample = |p: usize, k: usize, n: usize| -> Vec<Point3> {
            let (a, s) = (&t.peaks[p], &t.saddles[k]);
            (0..=n)
                .map(|j| {
                    let u = j as f64 / n as f64;
                    let z = a.elevation + u * (s.elevation - a.elevation);
                    (a.x + u * (s.x - a.x), a.y + u * (s.y - a.y), z)
                })
                .collect()
        };
        let mut best: Option<f64> = None;
        for (k, s) in t.saddles.iter().enumerate() {
            for &p in &s.peaks {
                if node == Node::Peak(p) || node == Node::Saddle(k) {
                    continue;
                }
                // (this node's crest points, the lowest other node on the
                // path from them to the half-ridge's interior)
                let crests: Vec<(Vec<Point3>, f64)> = match node {
                    Node::Peak(i) => vec![(
                        vec![(t.peaks[i].x, t.peaks[i].y, t.peaks[i].elevation)],
                        brute_pass(t, (i, None), (p, k, inf)),
                    )],
                    Node::Saddle(j) => t.saddles[j]
                        .peaks
                        .iter()
                        .map(|&q| {
                            (
                                sample(q, j, 60),
                                brute_pass(t, (q, Some((j, inf))), (p, k, inf)),
                            )
                        })
                        .collect(),
                };
                let ys = sample(
                    p,
                    k,
                    if matches!(node, Node::Peak(_)) {
                        400
                    } else {
                        60
                    },
                );
                for (xs, other) in &crests {
                    for &(x0, y0, z0) in xs {
                        for &(x, y, z) in &ys[1..ys.len() - 1] {
                            let d = (x - x0).hypot(y - y0);
                            // The pass through both points is the lowest of
                            // them and the path's other nodes.
                            if d < clear && z0.min(z) > z0.min(z).min(*other) + tol {
                                best = Some(best.map_or(d, |b: f64| b.min(d)));
                            }
                        }
                    }
                }
            }
        }
        best
    }

    /// A half-ridge: peak end, saddle end, peak index, saddle index.
    type Half = ((f64, f64), (f64, f64), usize, usize);

    fn segments(t: &SynthTree) -> Vec<Half> {
        let mut v = Vec::new();
        for (k, s) in t.saddles.iter().enumerate() {
            for &p in &s.peaks {
                v.push(((t.peaks[p].x, t.peaks[p].y), (s.x, s.y), p, k));
            }
        }
        v
    }

    /// Pairs of half-ridges that touch without sharing an end, by brute
    /// force (orientation signs written out again).
    fn crossings(t: &SynthTree) -> usize {
        let seg = segments(t);
        let side = |a: (f64, f64), b: (f64, f64), c: (f64, f64)| {
            ((b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0)).signum()
        };
        let mut n = 0;
        for i in 0..seg.len() {
            for j in i + 1..seg.len() {
                let (a, b, pa, ka) = seg[i];
                let (c, d, pb, kb) = seg[j];
                if pa == pb || ka == kb {
                    continue;
                }
                if side(a, b, c) * side(a, b, d) <= 0.0 && side(c, d, a) * side(c, d, b) <= 0.0 {
                    n += 1;
                }
            }
        }
        n
    }

    #[test]
    fn offences_match_a_brute_force_oracle() {
        let (mut flagged, mut saddles) = (0, 0);
        for seed in 1..5 {
            let t = random_tree(30, seed);
            // No tolerance: no margin rule to model in the oracle.
            let (clear, tol) = (75.0, 0.0);
            let found = offenders(&t, clear, tol);
            flagged += found.len();
            saddles += found
                .iter()
                .filter(|n| matches!(n, Node::Saddle(_)))
                .count();
            let nodes = (0..t.peaks.len())
                .map(Node::Peak)
                .chain((0..t.saddles.len()).map(Node::Saddle));
            for n in nodes {
                let f = found.contains(&n);
                // Sampling misses offences that only graze the circle, so
                // the converse allows a sample spacing.
                if let Some(d) = brute_offence(&t, n, clear, tol) {
                    assert!(f, "seed {seed} {n:?}: oracle offence at {d} m missed");
                }
                if f {
                    assert!(
                        brute_offence(&t, n, clear + 15.0, tol - 0.5).is_some(),
                        "seed {seed} {n:?}: flagged without an offence"
                    );
                }
            }
        }
        assert!(
            flagged > saddles && saddles > 0,
            "{flagged} offenders, {saddles} saddles"
        );
    }

    /// The tolerance shrinks to half the margin of the peak a join would
    /// drop: the crest beside a saddle whose peak clears the threshold by
    /// 1.5 m offends at a tolerance of 5 m (its part 0.75 m above the saddle
    /// is within 85 m of a foreign ridge), and not once the margin is 6.4 m
    /// (3.2 m above the saddle, the crest is 4 cells from that ridge).
    #[test]
    fn near_threshold_peaks_shrink_the_tolerance() {
        // Peak 0 (210 m) with two ridges leaving east, 3° apart: to peak 1
        // (a low peak, saddle 0 at 178.5 m) and to peak 2 (saddle 1 at
        // 204 m). Threshold 5 m.
        let tree = |thr: f64| SynthTree {
            format: "orogen-synthtree".into(),
            version: 1,
            width: 60,
            height: 60,
            cell: 30.0,
            seed: 1,
            min_prominence: thr,
            peaks: vec![
                pk(10.0, 10.0, 210.0),
                pk(24.0, 12.0, 185.0),
                pk(28.0, 31.0, 217.0),
            ],
            saddles: vec![sd(15.0, 14.0, 178.5, 0, 1), sd(19.0, 18.0, 204.0, 0, 2)],
        };
        let near = tree(5.0);
        assert_eq!(near.prominences()[1], 6.5);
        assert!(offenders(&near, 85.0, 5.0).contains(&Node::Saddle(0)));
        let far = tree(0.1);
        assert!(!offenders(&far, 85.0, 5.0).contains(&Node::Saddle(0)));
        // Without tolerance, the join offends either way.
        assert!(offenders(&far, 85.0, 0.0).contains(&Node::Saddle(0)));
    }

    #[test]
    fn clearing_moves_free_peaks_keeps_ridges_planar_and_the_tree() {
        let mut cleared = 0;
        for seed in 1..9 {
            let mut t = random_tree(60, seed);
            let before = t.clone();
            assert_eq!(crossings(&t), 0);
            let (clear, tol) = (75.0, 10.0);
            let n0 = offenders(&t, clear, tol).len();
            let st = clear_ridges(&mut t, clear, tol, &mut |_, _, _| true);
            let left = offenders(&t, clear, tol);
            assert!(left.len() <= n0, "seed {seed}: {n0} → {}", left.len());
            cleared += n0 - left.len();
            assert_eq!(crossings(&t), 0, "seed {seed}: ridges cross");
            for (s, q) in t.saddles.iter().zip(&before.saddles) {
                assert_eq!((s.elevation, s.peaks), (q.elevation, q.peaks));
                let on_a_peak = t.peaks.iter().any(|p| {
                    (p.x / t.cell).floor() == (s.x / t.cell).floor()
                        && (p.y / t.cell).floor() == (s.y / t.cell).floor()
                });
                assert!(!on_a_peak, "a saddle moved onto a peak's cell");
            }
            for (i, (p, q)) in t.peaks.iter().zip(&before.peaks).enumerate() {
                assert_eq!(p.elevation, q.elevation);
                if q.fixed {
                    assert_eq!((p.x, p.y), (q.x, q.y), "fixed peak {i} moved");
                }
                // Cell centres inside the domain, two cells from the others.
                for v in [p.x, p.y] {
                    let c = v / t.cell - 0.5;
                    assert!((0.0..60.0).contains(&c) && c.fract() == 0.0, "{v}");
                }
                for p2 in &t.peaks[i + 1..] {
                    assert!((p.x - p2.x).hypot(p.y - p2.y) >= 2.0 * t.cell - 1e-9);
                }
            }
            let moved = st.moves;
            // Deterministic.
            let mut again = before.clone();
            clear_ridges(&mut again, clear, tol, &mut |_, _, _| true);
            assert_eq!(again, t);
            // A veto keeps everything in place.
            let mut kept = before.clone();
            let st2 = clear_ridges(&mut kept, clear, tol, &mut |_, _, _| false);
            assert_eq!((st2.moves, kept), (0, before.clone()));
            assert!(moved == 0 || n0 > 0);
        }
        assert!(cleared > 0, "no offence was cleared on any seed");
    }

    /// A low peak one cell beside the high ridge of a peak it is joined
    /// to only through a deep saddle moves to `clear` from that ridge.
    #[test]
    fn a_peak_beside_a_foreign_ridge_moves_away() {
        // 0: high peak with a ridge east to peak 1 over saddle 0 (1800 m);
        // 2: low peak just south of that ridge, joined to peak 0 from the
        // west through a 900 m saddle.
        let mut t = SynthTree {
            format: "orogen-synthtree".into(),
            version: 1,
            width: 40,
            height: 40,
            cell: 30.0,
            seed: 1,
            min_prominence: 20.0,
            peaks: vec![
                pk(10.0, 20.0, 2000.0),
                pk(30.0, 20.0, 1900.0),
                pk(20.0, 21.0, 1000.0),
            ],
            saddles: vec![sd(24.0, 20.0, 1800.0, 0, 1), sd(12.0, 30.0, 900.0, 0, 2)],
        };
        // Seen from the saddles too: peak 2 is on saddle 1's crest, and
        // saddle 0's crest runs beside it.
        assert_eq!(
            offenders(&t, 75.0, 10.0),
            vec![Node::Peak(2), Node::Saddle(0), Node::Saddle(1)]
        );
        let st = clear_ridges(&mut t, 75.0, 10.0, &mut |n, _, _| n == Node::Peak(2));
        assert_eq!(st, ClearStats { moves: 1 });
        assert!(offenders(&t, 75.0, 10.0).is_empty());
        let p = &t.peaks[2];
        // Straight away (south, +y), past 75 m from the ridge y = 20.5 cells.
        assert_eq!(p.x, 20.5 * 30.0);
        assert!(p.y - 20.5 * 30.0 >= 75.0, "{}", p.y);
    }
}
