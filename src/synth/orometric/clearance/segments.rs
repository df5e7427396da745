//! The geometry of ridge clearance: half-ridge segments and their bucket
//! grid, closest points, segment distances and touching, and whether a
//! saddle lies between its peaks.

use super::super::tree_synth::SynthTree;

/// Half-ridge segment `id`: from peak `saddles[id / 2].peaks[id % 2]` to
/// saddle `id / 2`.
pub(super) fn ends(tree: &SynthTree, id: u32) -> (usize, usize) {
    let k = (id / 2) as usize;
    (tree.saddles[k].peaks[(id % 2) as usize], k)
}

/// Segments bucketed by their bounding boxes (a segment sits in every bucket
/// its box overlaps; moved segments are added again where they now lie, and
/// their geometry is always read from the tree).
pub(super) struct SegGrid {
    pub(super) side: f64,
    pub(super) nx: usize,
    pub(super) ny: usize,
    pub(super) buckets: Vec<Vec<u32>>,
    pub(super) stamp: Vec<u32>,
    pub(super) epoch: u32,
}

impl SegGrid {
    pub(super) fn new(tree: &SynthTree, clear: f64) -> SegGrid {
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

    pub(super) fn range(&self, x0: f64, y0: f64, x1: f64, y1: f64) -> (usize, usize, usize, usize) {
        let ix = |v: f64| ((v / self.side).floor().max(0.0) as usize).min(self.nx - 1);
        let iy = |v: f64| ((v / self.side).floor().max(0.0) as usize).min(self.ny - 1);
        (ix(x0), iy(y0), ix(x1), iy(y1))
    }

    pub(super) fn insert(&mut self, tree: &SynthTree, id: u32) {
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
    pub(super) fn visit(&mut self, x0: f64, y0: f64, x1: f64, y1: f64, mut f: impl FnMut(u32)) {
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
pub(super) fn closest(px: f64, py: f64, ax: f64, ay: f64, bx: f64, by: f64) -> (f64, f64) {
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
pub(super) fn seg_seg(
    a: (f64, f64),
    b: (f64, f64),
    c: (f64, f64),
    d: (f64, f64),
) -> (f64, f64, f64) {
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

pub(super) fn orient(ax: f64, ay: f64, bx: f64, by: f64, cx: f64, cy: f64) -> f64 {
    (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
}

/// Whether closed segments p–q and r–s share a point.
pub(super) fn touch(p: (f64, f64), q: (f64, f64), r: (f64, f64), s: (f64, f64)) -> bool {
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
pub(super) fn between_its_peaks(tree: &SynthTree, j: usize, x: f64, y: f64) -> bool {
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
