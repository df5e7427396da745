//! The 3x3 neighbourhood of a cell: the D8 neighbour order every routing
//! and labelling pass uses, the neighbours' distances and indices, and Horn's 3x3
//! gradient (shared by terrain metrics and hydrological indices).

/// Column offsets of the 8 neighbours in the order E, SE, S, SW, W, NW, N, NE.
pub const DX: [i64; 8] = [1, 1, 0, -1, -1, -1, 0, 1];
/// Row offsets of the 8 neighbours (y grows southwards).
pub const DY: [i64; 8] = [0, 1, 1, 1, 0, -1, -1, -1];
/// The 8 neighbours' `(dx, dy)` in the same order (`DX`, `DY` zipped); the
/// opposite of neighbour `k` is `k ^ 4`.
pub const OFFSETS: [(i64, i64); 8] = {
    let mut o = [(0, 0); 8];
    let mut k = 0;
    while k < 8 {
        o[k] = (DX[k], DY[k]);
        k += 1;
    }
    o
};

/// Distance to each neighbour in cell sizes, order E..NE.
pub const DIST: [f64; 8] = [
    1.0,
    std::f64::consts::SQRT_2,
    1.0,
    std::f64::consts::SQRT_2,
    1.0,
    std::f64::consts::SQRT_2,
    1.0,
    std::f64::consts::SQRT_2,
];

/// Index of neighbour `d` (order E..NE) of cell (x, y) in a row-major
/// `w x h` grid, or `None` beyond the grid.
#[inline]
pub fn neighbour(x: usize, y: usize, d: usize, w: usize, h: usize) -> Option<usize> {
    let nx = x as i64 + DX[d];
    let ny = y as i64 + DY[d];
    if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
        None
    } else {
        Some(ny as usize * w + nx as usize)
    }
}

/// Horn's gradient (dz/dx east, dz/dy north) of a 3x3 window (row-major,
/// north row first), in z units per metre for cell sizes `ew` x `ns` metres.
///
/// Source: Horn, B.K.P. (1981), "Hill shading and the reflectance map",
/// Proc. IEEE 69(1), 14-47, eq. for the 3x3 weighted gradient:
/// `dz/dx = ((c + 2f + i) - (a + 2d + g)) / (8 Δx)`,
/// `dz/dy = ((a + 2b + c) - (g + 2h + i)) / (8 Δy)` (y pointing north).
#[inline]
pub fn horn_gradient(w: &[f64; 9], ew: f64, ns: f64) -> (f64, f64) {
    let dzdx = ((w[2] + 2.0 * w[5] + w[8]) - (w[0] + 2.0 * w[3] + w[6])) / (8.0 * ew);
    let dzdy = ((w[0] + 2.0 * w[1] + w[2]) - (w[6] + 2.0 * w[7] + w[8])) / (8.0 * ns);
    (dzdx, dzdy)
}
