//! Hydrological indices.
//!
//! Local indices from a (filled) DEM and a D8 accumulation in cells, tile by
//! tile ([`HydroIndex`], a [`LocalStep`] with a halo of 1):
//! - `tan β`: Horn's (1981) slope
//!   ([`crate::raster::neighbours::horn_gradient`]), metric cell sizes per
//!   row. Nodata neighbours of a valid cell are replaced by the cell's own
//!   elevation (so edge cells get a one-sided slope).
//! - Specific catchment area `a = A·Δx·Δy / b` (m²/m) with `A` the
//!   accumulation in cells and the contour width `b = √(Δx·Δy)` (one cell
//!   width; Moore, Grayson & Ladson 1991).
//! - **TWI** `ln(a / tan β)` (Beven, K.J. & Kirkby, M.J. 1979, "A physically
//!   based, variable contributing area model of basin hydrology", Hydrol.
//!   Sci. Bull. 24, 43–69), with `tan β` floored at `min_slope` so flats stay
//!   finite.
//! - **SPI** `a·tan β` (Moore, I.D., Grayson, R.B. & Ladson, A.R. 1991,
//!   "Digital terrain modelling: a review of hydrological, geomorphological,
//!   and biological applications", Hydrol. Processes 5, 3–30).
//! - **STI** `(a/22.13)^0.6 · (sin β/0.0896)^1.3` (Moore, I.D. & Burch, G.J.
//!   1986, "Sediment transport capacity of sheet and rill flow: application
//!   of unit stream power theory", Water Resour. Res. 22, 1350–1360).
//! - **LS** `(m+1)·(a/22.13)^m · (sin β/0.0896)^n` with m = 0.4, n = 1.3
//!   (Moore & Burch 1986, in the form of Moore, I.D. & Wilson, J.P. 1992,
//!   "Length-slope factors for the Revised Universal Soil Loss Equation:
//!   simplified method of estimation", J. Soil Water Conserv. 47, 423–428).
//!
//! Global indices (in memory, guarded by the CLI's `--memory`):
//! - **HAND** is in [`super::basins`] (exact across tiles).
//! - **Depth to water** (Murphy, P.N.C., Ogilvie, J. & Arp, P. 2009,
//!   "Topographic modelling of soil moisture conditions: a comparison and
//!   verification of two models", Eur. J. Soil Sci. 60, 94–109): the least
//!   accumulated `Σ tan β · step length` from each cell to a stream cell
//!   (Dijkstra 1959 from all stream cells at once, 8 neighbours, each step
//!   costing the mean of its two cells' `tan β` times its metric length).
//! - **Maximum branch length** (Lindsay, J.B. & Seibert, J. 2013, "Measuring
//!   the significance of a divide to local drainage patterns", Hydrological
//!   Processes 27; definition in [`max_branch_length`]). The per-pair branch
//!   length `B(i, j)` is not written as a raster; `B_max` is.

use super::streams::{receivers, row_sizes};
use super::NODATA_DIR;
use crate::error::{Error, Result};
use crate::exec::output::OutputSpec;
use crate::exec::LocalStep;
use crate::raster::neighbours::{horn_gradient, neighbour};
use crate::raster::{DType, GeoRef, Grid, TileView};
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// Which local index [`HydroIndex`] computes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum IndexKind {
    Twi,
    Spi,
    Sti,
    Ls,
}

/// Local hydrological index from DEM (input 0) and D8 accumulation in cells
/// (input 1), both read as f32 (NaN = nodata). Output f32, NaN = nodata.
#[derive(Debug, Clone, Copy)]
pub struct HydroIndex {
    pub kind: IndexKind,
    /// Floor of `tan β` in TWI (default 1e-4).
    pub min_slope: f64,
}

impl HydroIndex {
    pub fn new(kind: IndexKind) -> Self {
        HydroIndex {
            kind,
            min_slope: 1e-4,
        }
    }

    /// The index of one cell from its specific catchment area and `tan β`.
    #[inline]
    pub fn value(&self, a: f64, tanb: f64) -> f64 {
        let sinb = tanb / (1.0 + tanb * tanb).sqrt();
        match self.kind {
            IndexKind::Twi => (a / tanb.max(self.min_slope)).ln(),
            IndexKind::Spi => a * tanb,
            IndexKind::Sti => (a / 22.13).powf(0.6) * (sinb / 0.0896).powf(1.3),
            IndexKind::Ls => 1.4 * (a / 22.13).powf(0.4) * (sinb / 0.0896).powf(1.3),
        }
    }
}

/// `tan β` (Horn) of the 3x3 window around core cell (x, y) of a view, NaN
/// for a nodata centre.
#[inline]
fn tan_beta(v: &TileView<f32>, x: i64, y: i64, ew: f64, ns: f64) -> f64 {
    let zc = v.at(x, y);
    if !zc.is_finite() {
        return f64::NAN;
    }
    let mut win = [0f64; 9];
    for (k, cell) in win.iter_mut().enumerate() {
        let z = v.at(x + (k % 3) as i64 - 1, y + (k / 3) as i64 - 1);
        *cell = if z.is_finite() { z as f64 } else { zc as f64 };
    }
    let (gx, gy) = horn_gradient(&win, ew, ns);
    gx.hypot(gy)
}

impl LocalStep for HydroIndex {
    type In = f32;
    type Out = f32;
    fn name(&self) -> String {
        match self.kind {
            IndexKind::Twi => "twi",
            IndexKind::Spi => "spi",
            IndexKind::Sti => "sti",
            IndexKind::Ls => "ls",
        }
        .into()
    }
    fn params(&self) -> serde_json::Value {
        serde_json::json!({"min_slope": self.min_slope, "inputs": ["dem", "accumulation (cells)"]})
    }
    fn halo(&self) -> usize {
        1
    }
    fn outputs(&self) -> Vec<OutputSpec> {
        vec![OutputSpec::continuous(DType::F32, INDEX_NODATA)]
    }
    fn run(&self, inputs: &[TileView<f32>], out: &mut [Grid<f32>]) -> Result<()> {
        let (Some(dem), Some(acc)) = (inputs.first(), inputs.get(1)) else {
            return Err(Error::invalid(
                "hydrological indices need the DEM and the flow accumulation",
            ));
        };
        let o = out
            .first_mut()
            .ok_or_else(|| Error::invalid("index: no output grid"))?;
        let (w, h) = (dem.core.w, dem.core.h);
        for y in 0..h {
            let (ew, ns) = dem.georef.cell_size_m(dem.core.y + y as i64);
            let b = (ew * ns).sqrt();
            for x in 0..w {
                let (xi, yi) = (x as i64, y as i64);
                let a_cells = acc.at(xi, yi) as f64;
                let tanb = tan_beta(dem, xi, yi, ew, ns);
                let v = if a_cells.is_finite() && tanb.is_finite() {
                    self.value(a_cells * ew * ns / b, tanb) as f32
                } else {
                    f32::NAN
                };
                o.set(x, y, v);
            }
        }
        Ok(())
    }
}

/// Horn `tan β` of every cell of a whole grid (nodata neighbours replaced by
/// the centre's elevation, as in [`HydroIndex`]).
pub fn tan_beta_grid(dem: &Grid<f32>, georef: &GeoRef) -> Grid<f64> {
    let (w, h) = (dem.width(), dem.height());
    let sizes = row_sizes(georef, h);
    Grid::from_fn(w, h, |x, y| {
        let zc = dem.get(x, y);
        if !zc.is_finite() {
            return f64::NAN;
        }
        let mut win = [0f64; 9];
        for (k, cell) in win.iter_mut().enumerate() {
            let nx = x as i64 + (k % 3) as i64 - 1;
            let ny = y as i64 + (k / 3) as i64 - 1;
            let z = if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                f32::NAN
            } else {
                dem.get(nx as usize, ny as usize)
            };
            *cell = if z.is_finite() { z as f64 } else { zc as f64 };
        }
        let (ew, ns) = sizes[y];
        let (gx, gy) = horn_gradient(&win, ew, ns);
        gx.hypot(gy)
    })
}

/// Nodata of the index rasters (f32).
pub const INDEX_NODATA: f64 = -9999.0;

/// Bytes per cell of [`depth_to_water`] (DEM, stream raster, slope, costs,
/// mask, and a heap of about two entries per cell).
pub const DTW_BYTES_PER_CELL: u64 = 64;

/// Depth to water (Murphy et al. 2009; module docs): least accumulated
/// `tan β`-weighted distance (m) from each cell to a cell of `streams`
/// (0 on streams, NaN on nodata and where no stream is reachable).
pub fn depth_to_water(dem: &Grid<f32>, streams: &Grid<bool>, georef: &GeoRef) -> Result<Grid<f32>> {
    let (w, h) = (dem.width(), dem.height());
    if (streams.width(), streams.height()) != (w, h) {
        return Err(Error::invalid("DEM and streams must have the same size"));
    }
    let n = w * h;
    let sizes = row_sizes(georef, h);
    let tb = tan_beta_grid(dem, georef);
    let tb = tb.data();
    let mut cost = vec![f64::INFINITY; n];
    let mut heap: BinaryHeap<Reverse<(u64, usize)>> = BinaryHeap::new();
    for c in 0..n {
        if streams.data()[c] && tb[c].is_finite() {
            cost[c] = 0.0;
            heap.push(Reverse((0, c)));
        }
    }
    // non-negative f64 costs order like their bit patterns
    while let Some(Reverse((bits, c))) = heap.pop() {
        let d = f64::from_bits(bits);
        if d > cost[c] {
            continue;
        }
        let (x, y) = (c % w, c / w);
        for k in 0..8 {
            let Some(m) = neighbour(x, y, k, w, h) else {
                continue;
            };
            if !tb[m].is_finite() {
                continue;
            }
            let (ew, ns) = sizes[y];
            let len =
                ((super::DX[k] as f64 * ew).powi(2) + (super::DY[k] as f64 * ns).powi(2)).sqrt();
            let nd = d + 0.5 * (tb[c] + tb[m]) * len;
            if nd < cost[m] {
                cost[m] = nd;
                heap.push(Reverse((nd.to_bits(), m)));
            }
        }
    }
    Grid::from_vec(
        w,
        h,
        cost.iter()
            .map(|&v| if v.is_finite() { v as f32 } else { f32::NAN })
            .collect(),
    )
}

/// Bytes per cell of [`max_branch_length`].
pub const BRANCH_BYTES_PER_CELL: u64 = 48;

/// Maximum branch length `B_max` (Lindsay & Seibert 2013): for a cell `i`
/// and a neighbour `j`, the branch length `B(i, j)` is the metric D8 flow
/// distance from `i` to the first cell its path shares with `j`'s path
/// (their confluence; the whole remaining path of `i` when the two paths
/// never meet). `B_max(i)` is the largest `B(i, j)` over `i`'s valid
/// neighbours: large on divides that separate long, diverging flow paths,
/// small inside a valley. The confluence is the lowest common ancestor of
/// `i` and `j` in the flow forest, found by walking the deeper one up to the
/// other's depth, then both together. NaN on nodata.
pub fn max_branch_length(dirs: &Grid<u8>, georef: &GeoRef) -> Result<Grid<f32>> {
    let (w, h) = (dirs.width(), dirs.height());
    let n = w * h;
    let sizes = row_sizes(georef, h);
    let recv = receivers(dirs)?;
    let mut cnt: Vec<u64> = vec![0; n];
    let topo = super::accum::accumulate_core(dirs.data(), w, h, &mut cnt)?;
    drop(cnt);
    // distance to the path's end, depth, end cell; downstream first
    let mut dist = vec![0f64; n];
    let mut depth = vec![0u32; n];
    let mut root = vec![u32::MAX; n];
    for &c in topo.iter().rev() {
        let c = c as usize;
        match recv[c] {
            u32::MAX => root[c] = c as u32,
            r => {
                let r = r as usize;
                let dx = (r % w) as f64 - (c % w) as f64;
                let dy = (r / w) as f64 - (c / w) as f64;
                let (ew, ns) = sizes[c / w];
                dist[c] = dist[r] + ((dx * ew).powi(2) + (dy * ns).powi(2)).sqrt();
                depth[c] = depth[r] + 1;
                root[c] = root[r];
            }
        }
    }
    let d = dirs.data();
    let mut best = vec![0f64; n];
    for c in 0..n {
        if d[c] == NODATA_DIR {
            continue;
        }
        let (x, y) = (c % w, c / w);
        // E, SE, S, SW: each unordered pair once
        for k in 0..4 {
            let Some(m) = neighbour(x, y, k, w, h) else {
                continue;
            };
            if d[m] == NODATA_DIR {
                continue;
            }
            let (bc, bm) = if root[c] != root[m] {
                (dist[c], dist[m])
            } else {
                let (mut a, mut b) = (c, m);
                while depth[a] > depth[b] {
                    a = recv[a] as usize;
                }
                while depth[b] > depth[a] {
                    b = recv[b] as usize;
                }
                while a != b {
                    a = recv[a] as usize;
                    b = recv[b] as usize;
                }
                (dist[c] - dist[a], dist[m] - dist[a])
            };
            best[c] = best[c].max(bc);
            best[m] = best[m].max(bm);
        }
    }
    Grid::from_vec(
        w,
        h,
        best.iter()
            .zip(d)
            .map(|(&v, &code)| {
                if code == NODATA_DIR {
                    f32::NAN
                } else {
                    v as f32
                }
            })
            .collect(),
    )
}
