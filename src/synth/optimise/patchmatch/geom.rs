//! The grid of synthesis patches over the target ([`Geom`]): patch corners
//! covering every cell and each cell's covering patches.

/// Patch layout of one synthesis level: patch corners on a grid with the
/// given spacing (the last row/column clamped to the edge so every cell is
/// covered), and per row/column the patches covering each cell.
pub(crate) struct Geom {
    pub w: usize,
    pub n: usize,
    /// Centre offset inside a patch: offsets run from `-h0` to `n-1-h0`.
    pub h0: usize,
    pub spacing: usize,
    pub cx: Vec<usize>,
    pub cy: Vec<usize>,
    pub(super) cover_x: (Vec<usize>, Vec<(u32, u32)>),
    pub(super) cover_y: (Vec<usize>, Vec<(u32, u32)>),
}

pub(super) fn corners(len: usize, n: usize, s: usize) -> Vec<usize> {
    let count = if len <= n {
        1
    } else {
        (len - n).div_ceil(s) + 1
    };
    (0..count).map(|i| (i * s).min(len - n)).collect()
}

pub(super) fn cover(len: usize, n: usize, c: &[usize]) -> (Vec<usize>, Vec<(u32, u32)>) {
    let mut start = Vec::with_capacity(len + 1);
    let mut list = Vec::new();
    for x in 0..len {
        start.push(list.len());
        for (i, &ci) in c.iter().enumerate() {
            if ci <= x && x < ci + n {
                list.push((i as u32, (x - ci) as u32));
            }
        }
    }
    start.push(list.len());
    (start, list)
}

impl Geom {
    pub fn new(w: usize, h: usize, n: usize, spacing: usize) -> Geom {
        let cx = corners(w, n, spacing);
        let cy = corners(h, n, spacing);
        let cover_x = cover(w, n, &cx);
        let cover_y = cover(h, n, &cy);
        Geom {
            w,
            n,
            h0: (n - 1) / 2,
            spacing,
            cx,
            cy,
            cover_x,
            cover_y,
        }
    }
    pub fn nx(&self) -> usize {
        self.cx.len()
    }
    pub fn count(&self) -> usize {
        self.cx.len() * self.cy.len()
    }
    /// Centre of patch (i, j) in cells.
    #[inline]
    pub(super) fn centre(&self, i: usize, j: usize) -> (f32, f32) {
        ((self.cx[i] + self.h0) as f32, (self.cy[j] + self.h0) as f32)
    }
}
