//! Stream extraction, the stream network as links split at confluences, its
//! orders and its statistics (in memory; see [`NETWORK_BYTES_PER_CELL`]).
//!
//! - **Channel cells**: drainage area `A` ≥ a threshold (cells or m²), or the
//!   slope–area channel-initiation rule `A·s² > C` of Montgomery, D.R. &
//!   Dietrich, W.E. (1988, "Where do channels begin?", Nature 336, 232–234;
//!   1992, "Channel initiation and the problem of landscape scale",
//!   Science 255, 826–830), with `A` in m² and `s` the D8 downslope tangent
//!   (drop to the receiver / distance to it). Everything downstream of a
//!   channel cell is channel (a channel, once begun, continues to the outlet).
//! - **Links** run from a *node* (channel head, confluence) down to the next
//!   node (confluence or outlet), both included, so lines meet at confluences.
//! - **Strahler order** (Strahler, A.N. 1957, "Quantitative analysis of
//!   watershed geomorphology", Trans. AGU 38, 913–920): heads are 1; below a
//!   confluence the order is the largest incoming order, plus one when two or
//!   more incoming links carry it. **Shreve magnitude** (Shreve, R.L. 1966,
//!   "Statistical law of stream numbers", J. Geology 74, 17–37): heads are 1,
//!   magnitudes add at confluences.
//! - **Length** is metric: every D8 step is measured with
//!   [`GeoRef::cell_size_m`] of the row it starts on (true lengths on
//!   geographic CRSs). **Drainage area** of a link is the area (m², each cell
//!   counted with its own metric area) draining through its last cell above
//!   the downstream node (through the outlet cell for a link ending at an
//!   outlet it alone feeds).
//!
//! Network statistics ([`horton`], [`tokunaga`], sinuosity):
//! - A *Horton–Strahler stream* of order ω is a maximal chain of links of
//!   order ω. Horton's laws (Horton, R.E. 1945, "Erosional development of
//!   streams and their drainage basins", GSA Bull. 56, 275–370; Strahler
//!   1957): bifurcation ratio `R_B`, length ratio `R_L` and area ratio `R_A`
//!   are `10^|b|` for the least-squares slope `b` of log10(count), log10(mean
//!   stream length) and log10(mean stream area) against ω.
//! - Tokunaga numbers (Tokunaga, E. 1978, "Consideration on the composition
//!   of drainage networks and their evolution", Geogr. Rep. Tokyo Metrop.
//!   Univ. 13; Peckham, S.D. 1995, "New results for self-similar trees with
//!   applications to river networks", Water Resour. Res. 31, 1023–1029):
//!   `T_{i,j}` = number of order-i streams joining order-j streams from the
//!   side (i < j; the two order-(j−1) streams that create an order-j stream
//!   are not side tributaries) divided by the number of order-j streams.
//!   `T_k` pools all `T_{i,i+k}`; the parameters `a`, `c` fit
//!   `T_k = a·c^{k−1}` by least squares in log10.
//! - Sinuosity of a link: channel length / straight distance between its end
//!   cells. For each Horton–Strahler stream, Mueller's indices (Mueller, J.E.
//!   1968, "An introduction to the hydraulic and topographic sinuosity
//!   indexes", Annals AAG 58, 371–385): channel index `CI = CL/Air`, valley
//!   index `VI = VL/Air`, standard sinuosity `SSI = CI/VI`, hydraulic
//!   sinuosity `HSI = 100 (CI − VI)/(CI − 1)` and topographic sinuosity
//!   `TSI = 100 (VI − 1)/(CI − 1)` (%; undefined for straight streams), with
//!   `CL` the channel length, `Air` the straight source–mouth distance and
//!   `VL` the valley length. orogen has no valley centreline, so `VL` is the
//!   length of the channel's cell-centre polyline smoothed by a moving
//!   average over ±`valley_window` vertices (ends fixed), clamped into
//!   `[Air, CL]` — a documented proxy for the valley axis, not Mueller's
//!   map-measured valley length.

use super::accum::{accumulate_core, fixed_to_f64, weight_to_fixed};
use super::{code_to_dir, DX, DY, NODATA_DIR, NO_FLOW};
use crate::error::{Error, Result};
use crate::io::geojson::GeoJsonCoords;
use crate::raster::{GeoRef, Grid};
use serde::Serialize;
use std::io::Write;
use std::path::Path;

/// Bytes per cell the in-memory network extraction needs (directions,
/// counts, areas, receivers, orders, topological order, DEM).
pub const NETWORK_BYTES_PER_CELL: u64 = 64;

/// Which cells are channels.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum ChannelRule {
    /// Accumulation in cells ≥ the threshold.
    Cells(f64),
    /// Drainage area in m² ≥ the threshold.
    Area(f64),
    /// Montgomery & Dietrich: `A·s² > c` (A in m², s the D8 downslope
    /// tangent); needs the DEM.
    SlopeArea(f64),
}

/// A node of the network: a channel head, a confluence or an outlet.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Node {
    pub id: u32,
    pub x: usize,
    pub y: usize,
    /// "head", "confluence" or "outlet".
    pub kind: &'static str,
}

/// A link: the channel between two nodes.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Link {
    pub id: u32,
    pub from: u32,
    pub to: u32,
    /// Cells (row-major indices) from the upstream node to the downstream node.
    #[serde(skip)]
    pub cells: Vec<u32>,
    pub strahler: u32,
    pub shreve: u64,
    /// Index of the Horton–Strahler stream the link belongs to.
    pub stream: u32,
    pub length_m: f64,
    /// Straight distance between the end cells (m).
    pub straight_m: f64,
    pub area_m2: f64,
    pub area_cells: u64,
}

impl Link {
    /// Channel length / straight distance (NaN for a zero straight distance).
    pub fn sinuosity(&self) -> f64 {
        if self.straight_m > 0.0 {
            self.length_m / self.straight_m
        } else {
            f64::NAN
        }
    }
}

/// A Horton–Strahler stream: a maximal chain of links of one order.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Stream {
    pub id: u32,
    pub order: u32,
    /// Links from upstream to downstream.
    pub links: Vec<u32>,
    pub length_m: f64,
    pub straight_m: f64,
    pub valley_m: f64,
    /// Area draining through the stream's mouth (its last link's area).
    pub area_m2: f64,
}

impl Stream {
    /// Mueller (1968) indices `(CI, VI, SSI, HSI %, TSI %)`; NaN where undefined.
    pub fn mueller(&self) -> (f64, f64, f64, f64, f64) {
        let ci = self.length_m / self.straight_m;
        let vi = self.valley_m / self.straight_m;
        let ssi = ci / vi;
        let (hsi, tsi) = if ci > 1.0 {
            (
                100.0 * (ci - vi) / (ci - 1.0),
                100.0 * (vi - 1.0) / (ci - 1.0),
            )
        } else {
            (f64::NAN, f64::NAN)
        };
        (ci, vi, ssi, hsi, tsi)
    }
}

/// An extracted network with its stream raster.
#[derive(Debug, Clone)]
pub struct Network {
    pub nodes: Vec<Node>,
    pub links: Vec<Link>,
    pub streams: Vec<Stream>,
    /// Strahler order of every channel cell, 0 elsewhere, 255 for nodata.
    pub order: Grid<u8>,
    /// The georeference the lengths were measured with.
    pub georef: GeoRef,
}

/// Options of [`extract_network`].
#[derive(Debug, Clone, Copy)]
pub struct NetworkOptions {
    pub rule: ChannelRule,
    /// Moving-average half window (vertices) for Mueller's valley length.
    pub valley_window: usize,
}

/// Metric (east-west, north-south) cell size of every row.
pub(crate) fn row_sizes(georef: &GeoRef, h: usize) -> Vec<(f64, f64)> {
    (0..h).map(|y| georef.cell_size_m(y as i64)).collect()
}

/// Metric length of a D8 step from (x, y) by (dx, dy).
#[inline]
fn step_len(sizes: &[(f64, f64)], y: usize, dx: i64, dy: i64) -> f64 {
    let (ew, ns) = sizes[y];
    ((dx as f64 * ew).powi(2) + (dy as f64 * ns).powi(2)).sqrt()
}

/// Straight metric distance between two cells (row sizes at the mean row).
fn straight(sizes: &[(f64, f64)], w: usize, a: usize, b: usize) -> f64 {
    let (xa, ya) = ((a % w) as f64, (a / w) as f64);
    let (xb, yb) = ((b % w) as f64, (b / w) as f64);
    let (ew, ns) = sizes[((ya + yb) / 2.0).round() as usize];
    (((xa - xb) * ew).powi(2) + ((ya - yb) * ns).powi(2)).sqrt()
}

/// Receivers (u32::MAX for none: no flow, off the raster, into nodata).
pub(crate) fn receivers(dirs: &Grid<u8>) -> Result<Vec<u32>> {
    let (w, h) = (dirs.width(), dirs.height());
    let d = dirs.data();
    let mut recv = vec![u32::MAX; d.len()];
    for (c, r) in recv.iter_mut().enumerate() {
        let code = d[c];
        if code == NODATA_DIR || code == NO_FLOW {
            continue;
        }
        let k = code_to_dir(code).ok_or_else(|| super::accum::bad_code(code, c % w, c / w))?;
        let nx = (c % w) as i64 + DX[k];
        let ny = (c / w) as i64 + DY[k];
        if nx >= 0 && ny >= 0 && nx < w as i64 && ny < h as i64 {
            let n = ny as usize * w + nx as usize;
            if d[n] != NODATA_DIR {
                *r = n as u32;
            }
        }
    }
    Ok(recv)
}

/// Per-cell drainage in cells and in m² (exact sums, see [`super::accum`]),
/// and a topological order (upstream first).
pub(crate) fn drainage(dirs: &Grid<u8>, georef: &GeoRef) -> Result<(Vec<u64>, Vec<f64>, Vec<u32>)> {
    let (w, h) = (dirs.width(), dirs.height());
    let sizes = row_sizes(georef, h);
    let mut cnt: Vec<u64> = dirs
        .data()
        .iter()
        .map(|&c| u64::from(c != NODATA_DIR))
        .collect();
    let order = accumulate_core(dirs.data(), w, h, &mut cnt)?;
    let mut area = Vec::with_capacity(w * h);
    for (c, &code) in dirs.data().iter().enumerate() {
        let (ew, ns) = sizes[c / w];
        area.push(if code == NODATA_DIR {
            0
        } else {
            weight_to_fixed((ew * ns) as f32)?
        });
    }
    accumulate_core(dirs.data(), w, h, &mut area)?;
    Ok((cnt, area.into_iter().map(fixed_to_f64).collect(), order))
}

/// Extract the channel network of D8 `dirs` (ESRI codes). `dem` is needed
/// by [`ChannelRule::SlopeArea`] only.
pub fn extract_network(
    dirs: &Grid<u8>,
    dem: Option<&Grid<f32>>,
    georef: &GeoRef,
    opts: &NetworkOptions,
) -> Result<Network> {
    let (w, h) = (dirs.width(), dirs.height());
    let n = w * h;
    if n >= u32::MAX as usize {
        return Err(Error::invalid(
            "stream networks are limited to 2^32 cells in memory",
        ));
    }
    let sizes = row_sizes(georef, h);
    let (cnt, area, topo) = drainage(dirs, georef)?;
    let recv = receivers(dirs)?;
    let d = dirs.data();
    let mut chan = vec![false; n];
    match opts.rule {
        ChannelRule::Cells(t) => {
            for c in 0..n {
                chan[c] = d[c] != NODATA_DIR && cnt[c] as f64 >= t;
            }
        }
        ChannelRule::Area(t) => {
            for c in 0..n {
                chan[c] = d[c] != NODATA_DIR && area[c] >= t;
            }
        }
        ChannelRule::SlopeArea(k) => {
            let z = dem.ok_or_else(|| {
                Error::invalid("the slope-area channel rule needs the (filled) DEM")
            })?;
            if (z.width(), z.height()) != (w, h) {
                return Err(Error::invalid("the DEM and the directions differ in size"));
            }
            let z = z.data();
            for c in 0..n {
                let r = recv[c];
                if d[c] == NODATA_DIR || r == u32::MAX {
                    continue;
                }
                let r = r as usize;
                let dist = step_len(
                    &sizes,
                    c / w,
                    (r % w) as i64 - (c % w) as i64,
                    (r / w) as i64 - (c / w) as i64,
                );
                let s = (z[c] as f64 - z[r] as f64) / dist;
                chan[c] = s.is_finite() && area[c] * s * s > k;
            }
        }
    }
    // channels continue downstream
    for &c in &topo {
        let c = c as usize;
        if chan[c] && recv[c] != u32::MAX {
            chan[recv[c] as usize] = true;
        }
    }
    let mut pos = vec![0u32; n];
    for (i, &c) in topo.iter().enumerate() {
        pos[c as usize] = i as u32;
    }
    let mut indeg = vec![0u8; n];
    for c in 0..n {
        if chan[c] && recv[c] != u32::MAX {
            indeg[recv[c] as usize] += 1;
        }
    }
    // nodes, row-major
    const NONODE: u32 = u32::MAX;
    let mut node_of = vec![NONODE; n];
    let mut nodes = Vec::new();
    for c in 0..n {
        if !chan[c] {
            continue;
        }
        let kind = if recv[c] == u32::MAX {
            "outlet"
        } else if indeg[c] == 0 {
            "head"
        } else if indeg[c] >= 2 {
            "confluence"
        } else {
            continue;
        };
        node_of[c] = nodes.len() as u32;
        nodes.push(Node {
            id: nodes.len() as u32,
            x: c % w,
            y: c / w,
            kind,
        });
    }
    // links, from every node with a receiver, in topological order
    let mut starts: Vec<usize> = (0..n)
        .filter(|&c| node_of[c] != NONODE && recv[c] != u32::MAX)
        .collect();
    starts.sort_by_key(|&c| pos[c]);
    let mut links: Vec<Link> = Vec::with_capacity(starts.len());
    // incoming links of each node: (max order, count at max, shreve sum, stream of the max)
    let mut inc: Vec<(u32, u32, u64, u32)> = vec![(0, 0, 0, u32::MAX); nodes.len()];
    let mut streams: Vec<Stream> = Vec::new();
    for &s in &starts {
        let mut cells = vec![s as u32];
        let mut c = recv[s] as usize;
        let mut len = step_len(
            &sizes,
            s / w,
            (c % w) as i64 - (s % w) as i64,
            (c / w) as i64 - (s / w) as i64,
        );
        while node_of[c] == NONODE {
            cells.push(c as u32);
            let r = recv[c] as usize;
            len += step_len(
                &sizes,
                c / w,
                (r % w) as i64 - (c % w) as i64,
                (r / w) as i64 - (c / w) as i64,
            );
            c = r;
        }
        cells.push(c as u32);
        let from = node_of[s];
        let to = node_of[c];
        let (m, k, sh, st) = inc[from as usize];
        let (strahler, shreve, cont) = if k == 0 {
            (1, 1, None)
        } else if k >= 2 {
            (m + 1, sh, None)
        } else {
            (m, sh, Some(st))
        };
        // the area leaving the link: through its last cell above `to`,
        // or through `to` when `to` is an outlet fed by this link alone
        let last = if recv[c] == u32::MAX && indeg[c] == 1 {
            c
        } else {
            cells[cells.len() - 2] as usize
        };
        let id = links.len() as u32;
        let stream = match cont {
            Some(st) => st,
            None => {
                streams.push(Stream {
                    id: streams.len() as u32,
                    order: strahler,
                    links: Vec::new(),
                    length_m: 0.0,
                    straight_m: 0.0,
                    valley_m: 0.0,
                    area_m2: 0.0,
                });
                (streams.len() - 1) as u32
            }
        };
        streams[stream as usize].links.push(id);
        let e = &mut inc[to as usize];
        if strahler > e.0 {
            *e = (strahler, 1, e.2 + shreve, stream);
        } else if strahler == e.0 {
            e.1 += 1;
            e.2 += shreve;
        } else {
            e.2 += shreve;
        }
        links.push(Link {
            id,
            from,
            to,
            straight_m: straight(&sizes, w, s, c),
            cells,
            strahler,
            shreve,
            stream,
            length_m: len,
            area_m2: area[last],
            area_cells: cnt[last],
        });
    }
    // Horton–Strahler stream geometry
    for st in streams.iter_mut() {
        let mut pts: Vec<usize> = Vec::new();
        for &l in &st.links {
            let lk = &links[l as usize];
            let skip = usize::from(!pts.is_empty());
            pts.extend(lk.cells[skip..].iter().map(|&c| c as usize));
            st.length_m += lk.length_m;
            st.area_m2 = lk.area_m2;
        }
        let (a, b) = (pts[0], pts[pts.len() - 1]);
        st.straight_m = straight(&sizes, w, a, b);
        st.valley_m = valley_length(&pts, w, &sizes, opts.valley_window)
            .clamp(st.straight_m, st.length_m.max(st.straight_m));
    }
    // stream raster
    let mut order = Grid::from_vec(
        w,
        h,
        d.iter()
            .map(|&c| if c == NODATA_DIR { NODATA_DIR } else { 0 })
            .collect(),
    )?;
    let o = order.data_mut();
    for lk in &links {
        let v = lk.strahler.min(254) as u8;
        for &c in &lk.cells[..lk.cells.len() - 1] {
            o[c as usize] = v;
        }
    }
    for (i, nd) in nodes.iter().enumerate() {
        if nd.kind == "outlet" {
            let (m, k, _, _) = inc[i];
            let v = if k == 0 {
                1
            } else if k >= 2 {
                m + 1
            } else {
                m
            };
            o[nd.y * w + nd.x] = v.min(254) as u8;
        }
    }
    Ok(Network {
        nodes,
        links,
        streams,
        order,
        georef: georef.clone(),
    })
}

/// Length of the cell-centre polyline `pts` smoothed by a moving average over
/// ±`r` vertices (window shrunk near the ends, which stay fixed).
fn valley_length(pts: &[usize], w: usize, sizes: &[(f64, f64)], r: usize) -> f64 {
    let m = pts.len();
    let xy: Vec<(f64, f64)> = pts
        .iter()
        .map(|&c| ((c % w) as f64, (c / w) as f64))
        .collect();
    let mut sm = Vec::with_capacity(m);
    for i in 0..m {
        let k = r.min(i).min(m - 1 - i);
        let (mut sx, mut sy) = (0.0, 0.0);
        for p in &xy[i - k..=i + k] {
            sx += p.0;
            sy += p.1;
        }
        let q = (2 * k + 1) as f64;
        sm.push((sx / q, sy / q));
    }
    let mut len = 0.0;
    for p in sm.windows(2) {
        let (ew, ns) = sizes[((p[0].1 + p[1].1) / 2.0).round() as usize];
        len += (((p[1].0 - p[0].0) * ew).powi(2) + ((p[1].1 - p[0].1) * ns).powi(2)).sqrt();
    }
    len
}

/// Horton's ratios over the Horton–Strahler streams of a network.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Horton {
    /// Highest order.
    pub max_order: u32,
    /// Per order 1..=max: number of streams, mean length (m), mean area (m²).
    pub count: Vec<u64>,
    pub mean_length_m: Vec<f64>,
    pub mean_area_m2: Vec<f64>,
    /// Ratios (NaN with fewer than two orders).
    pub bifurcation_ratio: f64,
    pub length_ratio: f64,
    pub area_ratio: f64,
}

/// Least-squares slope of `y` against `x`.
fn ls_slope(x: &[f64], y: &[f64]) -> f64 {
    let n = x.len() as f64;
    if x.len() < 2 {
        return f64::NAN;
    }
    let mx = x.iter().sum::<f64>() / n;
    let my = y.iter().sum::<f64>() / n;
    let mut sxy = 0.0;
    let mut sxx = 0.0;
    for (a, b) in x.iter().zip(y) {
        sxy += (a - mx) * (b - my);
        sxx += (a - mx) * (a - mx);
    }
    sxy / sxx
}

/// Horton's bifurcation, length and area ratios (log-linear regressions over
/// the orders; see the module docs).
pub fn horton(net: &Network) -> Horton {
    let max = net.streams.iter().map(|s| s.order).max().unwrap_or(0);
    let mut count = vec![0u64; max as usize];
    let mut len = vec![0f64; max as usize];
    let mut area = vec![0f64; max as usize];
    for s in &net.streams {
        let i = (s.order - 1) as usize;
        count[i] += 1;
        len[i] += s.length_m;
        area[i] += s.area_m2;
    }
    let mean_length_m: Vec<f64> = len.iter().zip(&count).map(|(l, &c)| l / c as f64).collect();
    let mean_area_m2: Vec<f64> = area
        .iter()
        .zip(&count)
        .map(|(a, &c)| a / c as f64)
        .collect();
    let om: Vec<f64> = (1..=max).map(|o| o as f64).collect();
    let lg = |v: &[f64]| -> Vec<f64> { v.iter().map(|x| x.log10()).collect() };
    let cf: Vec<f64> = count.iter().map(|&c| c as f64).collect();
    Horton {
        max_order: max,
        bifurcation_ratio: 10f64.powf(-ls_slope(&om, &lg(&cf))),
        length_ratio: 10f64.powf(ls_slope(&om, &lg(&mean_length_m))),
        area_ratio: 10f64.powf(ls_slope(&om, &lg(&mean_area_m2))),
        count,
        mean_length_m,
        mean_area_m2,
    }
}

/// Tokunaga numbers of a network.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Tokunaga {
    /// `(i, j, T_ij)` for every pair of orders i < j ≤ max.
    pub t: Vec<(u32, u32, f64)>,
    /// `T_k` for k = 1..max−1 (pooled over i).
    pub t_k: Vec<f64>,
    /// Fit `T_k = a·c^{k−1}` (NaN when fewer than two positive `T_k`).
    pub a: f64,
    pub c: f64,
}

/// Side-tributary counts and Tokunaga numbers (see the module docs).
pub fn tokunaga(net: &Network) -> Tokunaga {
    let max = net.streams.iter().map(|s| s.order).max().unwrap_or(0) as usize;
    let mut n_j = vec![0u64; max + 1];
    for s in &net.streams {
        n_j[s.order as usize] += 1;
    }
    // the link leaving each node
    let mut out_link = vec![u32::MAX; net.nodes.len()];
    for l in &net.links {
        out_link[l.from as usize] = l.id;
    }
    let mut side = vec![vec![0u64; max + 1]; max + 1];
    for s in &net.streams {
        let last = &net.links[*s.links.last().expect("streams have links") as usize];
        let down = out_link[last.to as usize];
        if down == u32::MAX {
            continue;
        }
        let dl = &net.links[down as usize];
        let j = dl.strahler as usize;
        let i = s.order as usize;
        if j <= i {
            continue;
        }
        let created_here = net.streams[dl.stream as usize].links[0] == dl.id;
        if created_here && i + 1 == j {
            continue;
        }
        side[i][j] += 1;
    }
    let mut t = Vec::new();
    let mut t_k = Vec::new();
    for k in 1..max {
        let (mut num, mut den) = (0u64, 0u64);
        for (i, row) in side.iter().enumerate().take(max - k + 1).skip(1) {
            num += row[i + k];
            den += n_j[i + k];
        }
        t_k.push(num as f64 / den as f64);
    }
    for (i, row) in side.iter().enumerate().skip(1) {
        for j in i + 1..=max {
            t.push((i as u32, j as u32, row[j] as f64 / n_j[j] as f64));
        }
    }
    let (ks, ls): (Vec<f64>, Vec<f64>) = t_k
        .iter()
        .enumerate()
        .filter(|(_, &v)| v > 0.0)
        .map(|(k, &v)| (k as f64, v.log10()))
        .unzip();
    let (a, c) = if ks.len() >= 2 {
        let b = ls_slope(&ks, &ls);
        let mk = ks.iter().sum::<f64>() / ks.len() as f64;
        let ml = ls.iter().sum::<f64>() / ls.len() as f64;
        (10f64.powf(ml - b * mk), 10f64.powf(b))
    } else {
        (f64::NAN, f64::NAN)
    };
    Tokunaga { t, t_k, a, c }
}

/// Write a file through `body` into `<path>.partial`, then rename it into
/// place, so that a failed write never leaves a complete-looking output.
pub(crate) fn write_atomic(
    path: &Path,
    body: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<()> {
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".partial");
    let tmp = std::path::PathBuf::from(tmp);
    let run = || -> std::io::Result<()> {
        let f = std::fs::File::create(&tmp)?;
        let mut f = std::io::BufWriter::new(f);
        body(&mut f)?;
        f.flush()?;
        f.into_inner().map_err(|e| e.into_error())?.sync_all()?;
        std::fs::rename(&tmp, path)
    };
    run().map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        Error::io(path, e)
    })
}

fn num(v: f64) -> serde_json::Value {
    if v.is_finite() {
        serde_json::json!(v)
    } else {
        serde_json::Value::Null
    }
}

impl Network {
    fn centre(&self, coords: &GeoJsonCoords, c: usize) -> [f64; 2] {
        let w = self.order.width();
        coords.pixel((c % w) as f64 + 0.5, (c / w) as f64 + 0.5)
    }

    /// Write the links as a GeoJSON FeatureCollection of LineStrings (cell
    /// centres, in the coordinates `coords` says: WGS 84 lon/lat by default,
    /// RFC 7946; see [`crate::io::geojson`]) with their properties (lengths
    /// and areas metric).
    pub fn write_geojson(&self, path: &Path, coords: &GeoJsonCoords) -> Result<()> {
        write_atomic(path, |f| {
            write!(f, "{}", coords.collection_head())?;
            for (i, l) in self.links.iter().enumerate() {
                let line: Vec<[f64; 2]> = l
                    .cells
                    .iter()
                    .map(|&c| self.centre(coords, c as usize))
                    .collect();
                let feat = serde_json::json!({
                    "type": "Feature",
                    "geometry": {"type": "LineString", "coordinates": line},
                    "properties": {
                        "id": l.id, "from_node": l.from, "to_node": l.to,
                        "strahler": l.strahler, "shreve": l.shreve, "stream": l.stream,
                        "length_m": num(l.length_m), "straight_m": num(l.straight_m),
                        "sinuosity": num(l.sinuosity()),
                        "area_m2": num(l.area_m2), "area_cells": l.area_cells,
                    }
                });
                if i > 0 {
                    write!(f, ",")?;
                }
                writeln!(f, "{feat}")?;
            }
            write!(f, "]}}")
        })
    }

    /// Write nodes as a GeoJSON FeatureCollection of Points (coordinates as
    /// in [`Network::write_geojson`]).
    pub fn write_nodes_geojson(&self, path: &Path, coords: &GeoJsonCoords) -> Result<()> {
        let w = self.order.width();
        let feats: Vec<serde_json::Value> = self
            .nodes
            .iter()
            .map(|nd| {
                serde_json::json!({
                    "type": "Feature",
                    "geometry": {"type": "Point", "coordinates": self.centre(coords, nd.y * w + nd.x)},
                    "properties": {"id": nd.id, "kind": nd.kind, "col": nd.x, "row": nd.y}
                })
            })
            .collect();
        let v = coords.collection(feats);
        write_atomic(path, |f| f.write_all(v.to_string().as_bytes()))
    }

    /// Write one CSV row per link.
    pub fn write_links_csv(&self, path: &Path) -> Result<()> {
        write_atomic(path, |f| {
            writeln!(
            f,
            "id,from_node,to_node,strahler,shreve,stream,length_m,straight_m,sinuosity,area_m2,area_cells"
        )?;
            for l in &self.links {
                writeln!(
                    f,
                    "{},{},{},{},{},{},{},{},{},{},{}",
                    l.id,
                    l.from,
                    l.to,
                    l.strahler,
                    l.shreve,
                    l.stream,
                    l.length_m,
                    l.straight_m,
                    l.sinuosity(),
                    l.area_m2,
                    l.area_cells
                )?;
            }
            Ok(())
        })
    }

    /// Network statistics as JSON: Horton ratios, Tokunaga numbers and, per
    /// Horton–Strahler stream, Mueller's sinuosity indices.
    pub fn stats_json(&self) -> serde_json::Value {
        let ho = horton(self);
        let tk = tokunaga(self);
        let streams: Vec<serde_json::Value> = self
            .streams
            .iter()
            .map(|s| {
                let (ci, vi, ssi, hsi, tsi) = s.mueller();
                serde_json::json!({
                    "id": s.id, "order": s.order, "links": s.links,
                    "length_m": num(s.length_m), "straight_m": num(s.straight_m),
                    "valley_m": num(s.valley_m), "area_m2": num(s.area_m2),
                    "channel_index": num(ci), "valley_index": num(vi),
                    "standard_sinuosity": num(ssi),
                    "hydraulic_sinuosity_pct": num(hsi), "topographic_sinuosity_pct": num(tsi),
                })
            })
            .collect();
        serde_json::json!({
            "links": self.links.len(),
            "nodes": self.nodes.len(),
            "horton": {
                "max_order": ho.max_order,
                "count": ho.count,
                "mean_length_m": ho.mean_length_m.iter().map(|&v| num(v)).collect::<Vec<_>>(),
                "mean_area_m2": ho.mean_area_m2.iter().map(|&v| num(v)).collect::<Vec<_>>(),
                "bifurcation_ratio": num(ho.bifurcation_ratio),
                "length_ratio": num(ho.length_ratio),
                "area_ratio": num(ho.area_ratio),
            },
            "tokunaga": {
                "t_ij": tk.t.iter().map(|&(i, j, v)| serde_json::json!({"i": i, "j": j, "t": num(v)})).collect::<Vec<_>>(),
                "t_k": tk.t_k.iter().map(|&v| num(v)).collect::<Vec<_>>(),
                "a": num(tk.a), "c": num(tk.c),
            },
            "streams": streams,
        })
    }
}
