//! The spatial indices of the terrain model: points in a uniform bucket
//! grid (nearest point, any point within a radius, points in a rectangle)
//! and items at cells listed per bucket of the raster's line index.

/// Points in a uniform bucket grid, for nearest-point queries.
pub(super) struct PointGrid {
    pub(super) g: f64,
    pub(super) nx: usize,
    pub(super) ny: usize,
    pub(super) start: Vec<u32>,
    pub(super) ids: Vec<u32>,
    pub(super) pts: Vec<[f64; 2]>,
}

impl PointGrid {
    pub(super) fn new(pts: Vec<[f64; 2]>, g: f64, wm: f64, hm: f64) -> PointGrid {
        let nx = ((wm / g).ceil() as usize).max(1);
        let ny = ((hm / g).ceil() as usize).max(1);
        let cell = |p: &[f64; 2]| {
            let cx = ((p[0] / g).floor().max(0.0) as usize).min(nx - 1);
            let cy = ((p[1] / g).floor().max(0.0) as usize).min(ny - 1);
            cy * nx + cx
        };
        let mut start = vec![0u32; nx * ny + 1];
        for p in &pts {
            start[cell(p) + 1] += 1;
        }
        for i in 1..start.len() {
            start[i] += start[i - 1];
        }
        let mut fill = start.clone();
        let mut ids = vec![0u32; pts.len()];
        for (i, p) in pts.iter().enumerate() {
            let c = cell(p);
            ids[fill[c] as usize] = i as u32;
            fill[c] += 1;
        }
        PointGrid {
            g,
            nx,
            ny,
            start,
            ids,
            pts,
        }
    }

    /// Nearest point within `max_r` of (x, y): (index, distance).
    pub(super) fn nearest(&self, x: f64, y: f64, max_r: f64) -> Option<(usize, f64)> {
        let cx = ((x / self.g).floor().max(0.0) as usize).min(self.nx - 1) as isize;
        let cy = ((y / self.g).floor().max(0.0) as usize).min(self.ny - 1) as isize;
        let mut best: Option<(usize, f64)> = None;
        let kmax = (max_r / self.g).ceil() as isize + 1;
        for k in 0..=kmax {
            for yy in cy - k..=cy + k {
                if yy < 0 || yy >= self.ny as isize {
                    continue;
                }
                let edge_row = yy == cy - k || yy == cy + k;
                let mut xx = cx - k;
                while xx <= cx + k {
                    if xx >= 0 && xx < self.nx as isize {
                        let b = yy as usize * self.nx + xx as usize;
                        for &i in &self.ids[self.start[b] as usize..self.start[b + 1] as usize] {
                            let p = self.pts[i as usize];
                            let d = (p[0] - x).hypot(p[1] - y);
                            if d <= max_r
                                && best
                                    .is_none_or(|(bi, bd)| d < bd || (d == bd && (i as usize) < bi))
                            {
                                best = Some((i as usize, d));
                            }
                        }
                    }
                    xx += if edge_row || k == 0 { 1 } else { 2 * k };
                }
            }
            if let Some((_, bd)) = best {
                if bd <= k as f64 * self.g {
                    break;
                }
            }
        }
        best
    }

    /// Whether any point lies within `r` of (x, y).
    pub(super) fn any_within(&self, x: f64, y: f64, r: f64) -> bool {
        let k = (r / self.g).ceil() as isize;
        let cx = ((x / self.g).floor().max(0.0) as usize).min(self.nx - 1) as isize;
        let cy = ((y / self.g).floor().max(0.0) as usize).min(self.ny - 1) as isize;
        for yy in (cy - k).max(0)..=(cy + k).min(self.ny as isize - 1) {
            for xx in (cx - k).max(0)..=(cx + k).min(self.nx as isize - 1) {
                let b = yy as usize * self.nx + xx as usize;
                for &i in &self.ids[self.start[b] as usize..self.start[b + 1] as usize] {
                    let p = self.pts[i as usize];
                    if (p[0] - x).hypot(p[1] - y) < r {
                        return true;
                    }
                }
            }
        }
        false
    }

    /// Indices of the points in [x0, x1) x [y0, y1), ascending.
    pub(super) fn in_rect(&self, x0: f64, y0: f64, x1: f64, y1: f64) -> Vec<u32> {
        let b = |v: f64, n: usize| ((v / self.g).floor().max(0.0) as usize).min(n - 1);
        let mut out = Vec::new();
        for by in b(y0, self.ny)..=b(y1, self.ny) {
            for bx in b(x0, self.nx)..=b(x1, self.nx) {
                let k = by * self.nx + bx;
                for &i in &self.ids[self.start[k] as usize..self.start[k + 1] as usize] {
                    let p = self.pts[i as usize];
                    if p[0] >= x0 && p[0] < x1 && p[1] >= y0 && p[1] < y1 {
                        out.push(i);
                    }
                }
            }
        }
        out.sort_unstable();
        out
    }
}

/// Items at cells (`pos`), listed per bucket (side `b` cells, `lnx` x `lny`
/// buckets) for every bucket within Chebyshev distance `radius` of their
/// cell: (start per bucket, items).
pub(super) fn bucket_cells<T: Copy>(
    items: &[T],
    pos: impl Fn(&T) -> (u32, u32),
    radius: u32,
    b: usize,
    lnx: usize,
    lny: usize,
) -> (Vec<u32>, Vec<T>) {
    let span = |v: u32, n: usize| {
        let lo = (v.saturating_sub(radius) as usize / b).min(n - 1);
        (lo, ((v + radius) as usize / b).min(n - 1))
    };
    let mut start = vec![0u32; lnx * lny + 1];
    for it in items {
        let (c, r) = pos(it);
        let ((x0, x1), (y0, y1)) = (span(c, lnx), span(r, lny));
        for by in y0..=y1 {
            for bx in x0..=x1 {
                start[by * lnx + bx + 1] += 1;
            }
        }
    }
    for i in 1..start.len() {
        start[i] += start[i - 1];
    }
    let mut fill = start.clone();
    let mut out = Vec::with_capacity(start[lnx * lny] as usize);
    // Placed by bucket: fill positions in a second pass.
    let mut slots: Vec<Option<T>> = vec![None; start[lnx * lny] as usize];
    for it in items {
        let (c, r) = pos(it);
        let ((x0, x1), (y0, y1)) = (span(c, lnx), span(r, lny));
        for by in y0..=y1 {
            for bx in x0..=x1 {
                let k = by * lnx + bx;
                slots[fill[k] as usize] = Some(*it);
                fill[k] += 1;
            }
        }
    }
    out.extend(slots.into_iter().flatten());
    (start, out)
}
