//! Horizon-based descriptors with a radius cutoff: positive and negative
//! openness (Yokoyama, Shirasawa & Pike 2002, "Visualizing topography by
//! openness", PE&RS 68(3), 257-265), zenith and nadir angles (the same
//! paper's per-direction angles φ_D, ψ_D), the horizon angle per direction,
//! the sky-view factor (Zakšek, Oštir & Kokalj 2011, "Sky-view factor as a
//! relief visualization technique", Remote Sensing 3(2), 398-415) and the
//! cosine-weighted sky view or accessibility (Dozier & Frew 1990, "Rapid
//! calculation of terrain parameters for radiation modeling from digital
//! elevation data", IEEE TGRS 28(5), 963-969, the horizontal-surface case).
//!
//! Rays leave the cell along 8 directions (the grid axes and diagonals) or
//! 16 (plus the knight-move directions (±1, ±2), (±2, ±1)). Each ray visits
//! exactly the cells at integer multiples of its step, so no interpolation
//! is involved and the result within the cutoff is exact: every cell whose
//! centre lies within `cutoff_m` metres along the ray is examined (the halo,
//! `ceil(cutoff / smallest cell size)`, covers all of them). Distances use
//! the centre row's true cell sizes. Nodata cells and cells beyond the raster
//! are skipped; a direction without any valid cell within the cutoff is left
//! out of the mean; a cell without any is nodata.
//!
//! Per direction D with elevation angles `θ_k = atan((z_k − z_0)/d_k)`:
//! positive openness `φ_D = 90° − max θ_k`, negative openness
//! `ψ_D = 90° + min θ_k` (Yokoyama et al. 2002; means over D);
//! sky-view factor `1 − mean_D sin(max(max θ_k, 0))` (Zakšek et al. 2011,
//! with the horizon clamped at the horizontal: terrain below it hides
//! no sky).
//!
//! ## Two ways to find the horizon, one answer
//! [`HorizonMethod::Rays`] walks every ray (O(r) per cell and direction).
//! [`HorizonMethod::Sweep`] walks each grid line of a direction once and keeps
//! the upper convex hull of the elevations ahead (the horizon idea of
//! Cabral, Max & Springmeyer 1987, "Bidirectional reflection functions from
//! surface bump maps", SIGGRAPH, and Stewart 1998, "Fast horizon computation
//! at all points of a terrain with visibility and shading applications",
//! IEEE TVCG 4(1)): the highest point seen from a cell is the tangent point
//! of that hull. The cutoff is honoured exactly by cutting each line into
//! blocks of `k` steps (the number of steps within the cutoff): the cells
//! seen from a cell are the rest of its block (a hull built right to left
//! with a monotone stack, amortised O(1)) plus a prefix of the next block
//! (a hull built left to right, queried by binary search, O(log k)). Cost
//! O(log r) per cell and direction instead of O(r).
//!
//! Both methods pick the same cell: the exact maximiser of the slope
//! `(z_j − z_0)/s_j` (`s_j` steps), compared by cross-multiplication, which
//! is exact in f64 for f32 elevations (differences of f32 values and their
//! products with step counts below 2^12 are representable), ties going to the
//! nearest cell. The tangent is then evaluated by the same expression
//! `(z_j − z_0)/(s_j·d)`, so the two methods agree bit for bit and tiled
//! runs equal untiled ones. The sweep needs the same `k` on every row of the
//! tile; where a geographic raster's cell sizes change `k` across a tile,
//! that direction falls back to the rays (same result, slower).

#![allow(clippy::needless_range_loop)] // index loops over parallel per-cell arrays

use crate::raster::{Grid, TileView};

/// The 16 ray steps (dx east, dy south in rows); the first 8 are the axes and diagonals.
pub const DIRS: [(i64, i64); 16] = [
    (0, -1),
    (1, -1),
    (1, 0),
    (1, 1),
    (0, 1),
    (-1, 1),
    (-1, 0),
    (-1, -1),
    (1, -2),
    (2, -1),
    (2, 1),
    (1, 2),
    (-1, 2),
    (-2, 1),
    (-2, -1),
    (-1, -2),
];

/// How the horizon of each cell is found (same values either way).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HorizonMethod {
    /// Walk every ray: O(r) per cell and direction (the reference).
    Rays,
    /// Line sweeps with convex hulls: O(log r) per cell and direction.
    Sweep,
}

/// Which horizon outputs to fill.
pub struct HorizonOut<'a> {
    pub positive: Option<&'a mut Grid<f32>>,
    pub negative: Option<&'a mut Grid<f32>>,
    pub sky_view: Option<&'a mut Grid<f32>>,
}

/// Azimuth of lattice step `(dx, dy)` (clockwise from north, degrees in
/// `[0, 360)`) for cells of `ew` x `ns` metres on a north-up raster.
pub fn step_azimuth(dx: i64, dy: i64, ew: f64, ns: f64) -> f64 {
    let a = (dx as f64 * ew).atan2(-(dy as f64) * ns).to_degrees();
    if a < 0.0 {
        a + 360.0
    } else {
        a
    }
}

/// Step length (metres) and number of steps within the cutoff of direction
/// `dir` for cells of `ew` x `ns` metres, with at most `steps` cells per axis.
pub(crate) fn plan(dir: usize, ew: f64, ns: f64, steps: usize, cutoff_m: f64) -> (f64, usize) {
    let (dx, dy) = DIRS[dir];
    let limit = cutoff_m * (1.0 + 1e-12);
    let d = ((dx as f64 * ew).powi(2) + (dy as f64 * ns).powi(2)).sqrt();
    let axis = dx.unsigned_abs().max(dy.unsigned_abs()) as usize;
    let mut k = steps / axis;
    while k > 0 && k as f64 * d > limit {
        k -= 1;
    }
    (d, k)
}

/// The valid cells of a lattice ray from the grid index `c`, `off` per
/// step, steps `1..=k`: (step, z), nodata skipped (the visibility index's
/// walk; the reference scan [`tangents`] keeps its explicit loop).
#[inline(always)]
pub(crate) fn ray_cells(
    data: &[f32],
    c: usize,
    off: isize,
    k: usize,
) -> impl Iterator<Item = (usize, f64)> + '_ {
    let mut i = c as isize;
    (1..=k).filter_map(move |s| {
        i += off;
        let z = data[i as usize] as f64;
        (!z.is_nan()).then_some((s, z))
    })
}

/// True if the slope from `(0, z0)` to `(sa, za)` is strictly below the
/// slope to `(sb, zb)` (`sa, sb > 0`), exactly (cross-multiplied).
#[inline]
fn below(z0: f64, sa: usize, za: f64, sb: usize, zb: f64) -> bool {
    (za - z0) * (sb as f64) < (zb - z0) * (sa as f64)
}

/// Horizon tangents of one direction for every core cell of `view`.
///
/// `out[y * core.w + x]` receives `(z_t − z_0)/(s_t·d)` for the cell `t` on
/// the ray of direction `DIRS[dir]` (within `cutoff_m` metres and at most
/// `steps` cells per axis, `steps ≤ view.halo`) with the largest slope, or
/// the smallest with `lower`; `−∞` (`+∞` with `lower`) if no valid cell is
/// within the cutoff; NaN where the centre is nodata.
pub fn tangents(
    view: &TileView<f32>,
    steps: usize,
    cutoff_m: f64,
    dir: usize,
    lower: bool,
    method: HorizonMethod,
    out: &mut [f64],
) {
    assert!(steps <= view.halo, "horizon rays must stay inside the halo");
    let (cw, ch) = (view.core.w, view.core.h);
    assert_eq!(out.len(), cw * ch);
    // Per core row: step length and steps within the cutoff.
    let rows: Vec<(f64, usize)> = (0..ch)
        .map(|y| {
            let (ew, ns) = view.georef.cell_size_m(view.core.y + y as i64);
            plan(dir, ew, ns, steps, cutoff_m)
        })
        .collect();
    let constant_k = rows.windows(2).all(|w| w[0].1 == w[1].1);
    if method == HorizonMethod::Sweep && constant_k && ch > 0 {
        sweep(view, dir, lower, &rows, out);
    } else {
        rays(view, dir, lower, &rows, out);
    }
}

/// The reference: walk each ray.
fn rays(view: &TileView<f32>, dir: usize, lower: bool, rows: &[(f64, usize)], out: &mut [f64]) {
    let h = view.halo;
    let gw = view.grid.width();
    let data = view.grid.data();
    let (dx, dy) = DIRS[dir];
    let off = dy as isize * gw as isize + dx as isize;
    let sign = if lower { -1.0 } else { 1.0 };
    let none = if lower {
        f64::INFINITY
    } else {
        f64::NEG_INFINITY
    };
    for (y, &(d, k)) in rows.iter().enumerate() {
        for x in 0..view.core.w {
            let c = (y + h) * gw + x + h;
            let z0 = data[c] as f64;
            if z0.is_nan() {
                out[y * view.core.w + x] = f64::NAN;
                continue;
            }
            let (mut bs, mut bz) = (0usize, 0.0f64);
            // The explicit walk: through `ray_cells` this loop measured
            // about a fifth slower (bench openness_pos_neg_8dir_r50c_rays).
            let mut i = c as isize;
            for s in 1..=k {
                i += off;
                let z = data[i as usize] as f64;
                if z.is_nan() {
                    continue;
                }
                if bs == 0 || below(sign * z0, bs, sign * bz, s, sign * z) {
                    bs = s;
                    bz = z;
                }
            }
            out[y * view.core.w + x] = if bs == 0 {
                none
            } else {
                (bz - z0) / (bs as f64 * d)
            };
        }
    }
}

/// Line sweeps with hulls (see the module doc); `rows` all have the same `k`.
fn sweep(view: &TileView<f32>, dir: usize, lower: bool, rows: &[(f64, usize)], out: &mut [f64]) {
    let h = view.halo as i64;
    let gw = view.grid.width() as i64;
    let gh = view.grid.height() as i64;
    let data = view.grid.data();
    let (cw, ch) = (view.core.w as i64, view.core.h as i64);
    let (dx, dy) = DIRS[dir];
    let k = rows[0].1;
    let sign = if lower { -1.0 } else { 1.0 };
    let none = if lower {
        f64::INFINITY
    } else {
        f64::NEG_INFINITY
    };
    let inside = |x: i64, y: i64| x >= 0 && y >= 0 && x < gw && y < gh;
    let is_core = |x: i64, y: i64| x >= h && y >= h && x < h + cw && y < h + ch;
    // Line buffers: signed elevations and view coordinates of the cells.
    let mut zs: Vec<f64> = Vec::new();
    let mut cells: Vec<(i64, i64)> = Vec::new();
    let mut best_a: Vec<usize> = Vec::new();
    let mut stack: Vec<usize> = Vec::new();
    let mut hull: Vec<usize> = Vec::new();
    for sy in 0..gh {
        for sx in 0..gw {
            // A line starts where the previous cell would leave the view.
            if inside(sx - dx, sy - dy) {
                continue;
            }
            zs.clear();
            cells.clear();
            let (mut x, mut y) = (sx, sy);
            let mut any_core = false;
            while inside(x, y) {
                zs.push(sign * data[(y * gw + x) as usize] as f64);
                cells.push((x, y));
                any_core |= is_core(x, y);
                x += dx;
                y += dy;
            }
            if !any_core {
                continue;
            }
            let n = zs.len();
            let query = |p: usize| {
                let (x, y) = cells[p];
                is_core(x, y) && !zs[p].is_nan()
            };
            if k == 0 {
                for p in 0..n {
                    let (x, y) = cells[p];
                    if is_core(x, y) {
                        let o = ((y - h) * cw + x - h) as usize;
                        out[o] = if zs[p].is_nan() { f64::NAN } else { none };
                    }
                }
                continue;
            }
            // Part A: best cell in the rest of each block (right to left).
            best_a.clear();
            best_a.resize(n, usize::MAX);
            let mut bs = 0;
            while bs < n {
                let be = (bs + k).min(n);
                stack.clear();
                for p in (bs..be).rev() {
                    let z0 = zs[p];
                    if z0.is_nan() {
                        continue;
                    }
                    while stack.len() >= 2 {
                        let (t1, t2) = (stack[stack.len() - 1], stack[stack.len() - 2]);
                        if below(z0, t1 - p, zs[t1], t2 - p, zs[t2]) {
                            stack.pop();
                        } else {
                            break;
                        }
                    }
                    if let Some(&t) = stack.last() {
                        best_a[p] = t;
                    }
                    stack.push(p);
                }
                bs = be;
            }
            // Part B: best cell in the next block's prefix (left to right),
            // then the combination and the tangent.
            let mut bs = 0;
            while bs < n {
                let be = (bs + k).min(n);
                hull.clear();
                let mut added = be; // next position of the next block to add
                for p in bs..be {
                    if !query(p) {
                        continue;
                    }
                    let end = (p + k).min(n - 1);
                    while added <= end {
                        let q = added;
                        added += 1;
                        if zs[q].is_nan() {
                            continue;
                        }
                        // Pop v while v is on or below the segment u-q.
                        while hull.len() >= 2 {
                            let (u, v) = (hull[hull.len() - 2], hull[hull.len() - 1]);
                            let lhs = (zs[v] - zs[u]) * (q - u) as f64;
                            let rhs = (zs[q] - zs[u]) * (v - u) as f64;
                            if lhs <= rhs {
                                hull.pop();
                            } else {
                                break;
                            }
                        }
                        hull.push(q);
                    }
                    let z0 = zs[p];
                    // First vertex whose slope from p is not below the next one's.
                    let mut best_b = usize::MAX;
                    if !hull.is_empty() {
                        let (mut lo, mut hi) = (0usize, hull.len() - 1);
                        while lo < hi {
                            let m = (lo + hi) / 2;
                            let (a, b) = (hull[m], hull[m + 1]);
                            if below(z0, a - p, zs[a], b - p, zs[b]) {
                                lo = m + 1;
                            } else {
                                hi = m;
                            }
                        }
                        best_b = hull[lo];
                    }
                    let a = best_a[p];
                    let t = match (a != usize::MAX, best_b != usize::MAX) {
                        (false, false) => usize::MAX,
                        (true, false) => a,
                        (false, true) => best_b,
                        (true, true) => {
                            if below(z0, a - p, zs[a], best_b - p, zs[best_b]) {
                                best_b
                            } else {
                                a
                            }
                        }
                    };
                    let (x, y) = cells[p];
                    let row = (y - h) as usize;
                    let o = (row as i64 * cw + x - h) as usize;
                    out[o] = if t == usize::MAX {
                        none
                    } else {
                        let s = (t - p) as f64;
                        (sign * zs[t] - sign * z0) / (s * rows[row].0)
                    };
                }
                bs = be;
            }
            // Nodata centres on this line.
            for p in 0..n {
                let (x, y) = cells[p];
                if is_core(x, y) && zs[p].is_nan() {
                    out[((y - h) * cw + x - h) as usize] = f64::NAN;
                }
            }
        }
    }
}

/// Call `f(dir, upper, lower)` for each of the first `directions` lattice
/// directions in order, with the core cells' horizon tangents (`upper`: the
/// largest, `lower`: the smallest, computed only if `need_lower`).
pub fn scan(
    view: &TileView<f32>,
    steps: usize,
    cutoff_m: f64,
    directions: usize,
    need_lower: bool,
    method: HorizonMethod,
    f: impl FnMut(usize, &[f64], &[f64]),
) {
    scan_sides(
        view, steps, cutoff_m, directions, true, need_lower, method, f,
    )
}

/// [`scan`] that can leave out the upper tangents (`up` is then empty):
/// negative openness alone needs only the lower ones.
#[allow(clippy::too_many_arguments)]
pub fn scan_sides(
    view: &TileView<f32>,
    steps: usize,
    cutoff_m: f64,
    directions: usize,
    need_upper: bool,
    need_lower: bool,
    method: HorizonMethod,
    mut f: impl FnMut(usize, &[f64], &[f64]),
) {
    let n = view.core.w * view.core.h;
    let mut up = if need_upper { vec![0.0; n] } else { Vec::new() };
    let mut down = if need_lower { vec![0.0; n] } else { Vec::new() };
    for dir in 0..directions.min(16) {
        if need_upper {
            tangents(view, steps, cutoff_m, dir, false, method, &mut up);
        }
        if need_lower {
            tangents(view, steps, cutoff_m, dir, true, method, &mut down);
        }
        f(dir, &up, &down);
    }
}

/// Compute the requested horizon descriptors for every core cell of `view`
/// with rays of at most `steps` cells per axis (≤ the view's halo) and a
/// cutoff of `cutoff_m` metres; `directions` is 8 or 16. Uses the sweep.
pub fn horizon(
    view: &TileView<f32>,
    steps: usize,
    cutoff_m: f64,
    directions: usize,
    out: HorizonOut<'_>,
) {
    horizon_with(view, steps, cutoff_m, directions, HorizonMethod::Sweep, out)
}

/// [`horizon`] with a chosen method (the rays are the reference in tests and benches).
pub fn horizon_with(
    view: &TileView<f32>,
    steps: usize,
    cutoff_m: f64,
    directions: usize,
    method: HorizonMethod,
    mut out: HorizonOut<'_>,
) {
    let n = view.core.w * view.core.h;
    let (mut pos, mut neg, mut svf) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let mut nd = vec![0u32; n];
    let need_lower = out.negative.is_some();
    let need_upper = out.positive.is_some() || out.sky_view.is_some() || !need_lower;
    scan_sides(
        view,
        steps,
        cutoff_m,
        directions,
        need_upper,
        need_lower,
        method,
        |_, up, down| {
            if !need_upper {
                // Negative openness alone: a direction counts where it has
                // a valid cell (+∞: none; NaN: nodata centre), as for `up`.
                for i in 0..n {
                    let lo = down[i];
                    if lo.is_nan() || lo == f64::INFINITY {
                        continue;
                    }
                    neg[i] += 90.0 + lo.atan().to_degrees();
                    nd[i] += 1;
                }
                return;
            }
            for i in 0..n {
                let hi = up[i];
                if hi.is_nan() || hi == f64::NEG_INFINITY {
                    continue;
                }
                let a = hi.atan();
                pos[i] += 90.0 - a.to_degrees();
                if need_lower {
                    neg[i] += 90.0 + down[i].atan().to_degrees();
                }
                svf[i] += a.max(0.0).sin();
                nd[i] += 1;
            }
        },
    );
    for i in 0..n {
        let (x, y) = (i % view.core.w, i / view.core.w);
        let k = nd[i] as f64;
        let (p, q, s) = if nd[i] == 0 {
            (f32::NAN, f32::NAN, f32::NAN)
        } else {
            (
                (pos[i] / k) as f32,
                (neg[i] / k) as f32,
                (1.0 - svf[i] / k) as f32,
            )
        };
        if let Some(g) = out.positive.as_deref_mut() {
            g.set(x, y, p);
        }
        if let Some(g) = out.negative.as_deref_mut() {
            g.set(x, y, q);
        }
        if let Some(g) = out.sky_view.as_deref_mut() {
            g.set(x, y, s);
        }
    }
}

/// Outputs of [`horizon_extra`]: the zenith and nadir angles, accessibility
/// and the horizon angle of one direction.
#[derive(Default)]
pub struct HorizonExtra<'a> {
    /// `min_D φ_D = 90° − max_D max_k θ_k`: the smallest angle between the
    /// zenith and the terrain (Yokoyama et al. 2002's zenith angle, taken over
    /// all directions), degrees.
    pub zenith: Option<&'a mut Grid<f32>>,
    /// `min_D ψ_D = 90° + min_D min_k θ_k`: the smallest angle between the
    /// nadir and the terrain, degrees.
    pub nadir: Option<&'a mut Grid<f32>>,
    /// `mean_D cos²(max(γ_D, 0))`, γ_D the horizon elevation angle: the
    /// cosine-weighted visible fraction of the upper hemisphere above a
    /// horizontal surface (Dozier & Frew 1990, `V = (1/2π)∫ sin² H_φ dφ` with
    /// `H_φ` the horizon's zenith angle), 0..1.
    pub accessibility: Option<&'a mut Grid<f32>>,
    /// Horizon elevation angle `max_k θ_k` (degrees) along `DIRS[.0]`.
    pub angle: Option<(usize, &'a mut Grid<f32>)>,
}

/// Compute the [`HorizonExtra`] outputs (nodata where the centre is nodata
/// or no direction has a valid cell within the cutoff; the direction's angle
/// is nodata where that direction has none).
pub fn horizon_extra(
    view: &TileView<f32>,
    steps: usize,
    cutoff_m: f64,
    directions: usize,
    method: HorizonMethod,
    mut out: HorizonExtra<'_>,
) {
    let n = view.core.w * view.core.h;
    let cw = view.core.w;
    let mut hi_max = vec![f64::NEG_INFINITY; n];
    let mut lo_min = vec![f64::INFINITY; n];
    let mut acc = vec![0.0; n];
    let mut nd = vec![0u32; n];
    let need_lower = out.nadir.is_some();
    let want_dir = out.angle.as_ref().map(|a| a.0);
    // The direction of `angle` alone, or the first `directions` ones.
    let list: Vec<usize> = match want_dir {
        Some(d) if directions == 0 => vec![d],
        _ => (0..directions.min(16)).collect(),
    };
    let mut up = vec![0.0; n];
    let mut down = if need_lower { vec![0.0; n] } else { Vec::new() };
    for &dir in &list {
        tangents(view, steps, cutoff_m, dir, false, method, &mut up);
        if need_lower {
            tangents(view, steps, cutoff_m, dir, true, method, &mut down);
        }
        if Some(dir) == want_dir {
            if let Some((_, g)) = out.angle.as_mut() {
                for i in 0..n {
                    let t = up[i];
                    let v = if t.is_nan() || t == f64::NEG_INFINITY {
                        f32::NAN
                    } else {
                        t.atan().to_degrees() as f32
                    };
                    g.set(i % cw, i / cw, v);
                }
            }
        }
        if directions == 0 {
            continue;
        }
        for i in 0..n {
            let hi = up[i];
            if hi.is_nan() || hi == f64::NEG_INFINITY {
                continue;
            }
            hi_max[i] = hi_max[i].max(hi);
            if need_lower {
                lo_min[i] = lo_min[i].min(down[i]);
            }
            let c = hi.atan().max(0.0).cos();
            acc[i] += c * c;
            nd[i] += 1;
        }
    }
    for i in 0..n {
        let (x, y) = (i % cw, i / cw);
        let ok = nd[i] > 0;
        if let Some(g) = out.zenith.as_deref_mut() {
            let v = if ok {
                (90.0 - hi_max[i].atan().to_degrees()) as f32
            } else {
                f32::NAN
            };
            g.set(x, y, v);
        }
        if let Some(g) = out.nadir.as_deref_mut() {
            let v = if ok {
                (90.0 + lo_min[i].atan().to_degrees()) as f32
            } else {
                f32::NAN
            };
            g.set(x, y, v);
        }
        if let Some(g) = out.accessibility.as_deref_mut() {
            let v = if ok {
                (acc[i] / nd[i] as f64) as f32
            } else {
                f32::NAN
            };
            g.set(x, y, v);
        }
    }
}
