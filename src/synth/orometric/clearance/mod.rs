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

mod segments;

use super::assign::owners;
use super::minimax::{PassHeights, RidgeAnchor};
use super::tree_synth::SynthTree;
use segments::between_its_peaks;
use segments::closest;
use segments::ends;
use segments::seg_seg;
use segments::touch;
use segments::SegGrid;

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
mod tests;
