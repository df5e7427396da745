//! Detachment-limited stream-power erosion with uplift,
//! `∂h/∂t = u − K A^m s^n (+ K_d ∇²h)`, solved by the implicit O(n) scheme of
//! Braun & Willett (2013), "A very efficient O(n), implicit and parallel method
//! to solve the stream power equation governing fluvial incision and landscape
//! evolution", *Geomorphology* 180–181, 170–179.
//!
//! One time step (the order FastScape uses):
//! 1. **Uplift**: `h* = h + u·dt` on every cell that is not a base level.
//! 2. **Routing** on `h*` into one [`FlowGraph`] (see [`crate::flow`]):
//!    each cell's receiver is its steepest-descent D8 neighbour
//!    ([`route_steepest`]: slope = drop / distance, diagonals at `√2·dx`;
//!    ties broken by the neighbour order E, SE, S, SW, W, NW, N, NE of
//!    [`crate::raster::neighbours`]). Depressions are routed by
//!    [`Depressions`] with the sink resolvers of [`Lakes`]: filling (a
//!    priority flood; receivers by steepest descent on the water surface,
//!    flats of it drained along breadth-first distances to their outlet),
//!    the basin graph of Cordonnier, Bovy & Braun (2019, *Earth Surf.
//!    Dynam.* 7, 549–562: basins of the local minima, minimum spanning tree
//!    of their passes (Kruskal), receivers reversed from each pass down to
//!    the basin's pit — their "carving" variant), or not at all (pits are
//!    local base levels).
//! 3. **Stack**: every cell after its receiver ([`FlowGraph::build_stack`],
//!    O(n) by in-degree counting); the drainage area `A` is the sum of cell
//!    areas accumulated in reverse stack order ([`FlowGraph::accumulate`]).
//! 4. **Implicit erosion** in stack order (receiver already updated):
//!    `n = 1`: `h = (h* + F·h_r)/(1 + F)`, `F = K·dt·A^m/d^n`
//!    (Braun & Willett's implicit update, `d` = distance to the receiver);
//!    `n ≠ 1`: Newton's method on `f(h) = h − h* + K·dt·A^m·((h − h_r)/d)^n`
//!    (closed form for `n = 2`),
//!    which converges monotonically from `h*` for `n > 1` (f convex) and is
//!    safeguarded by bisection towards `h_r` otherwise. A cell under water
//!    (below its depression's fill level; for the basin graph, the highest
//!    pass on its basin's tree path to the root, which is the same level) or
//!    not above its updated receiver is not eroded (no deposition is
//!    modelled). The scheme is unconditionally stable: the new
//!    height always lies between `h_r` and `h*`.
//! 5. **Diffusion** (optional, `K_d > 0`): linear hillslope diffusion by
//!    explicit forward-time centred-space substeps on the 4-neighbour stencil,
//!    `Δt_sub ≤ 0.2·dx²/K_d` (stability needs ≤ 0.25), zero flux across
//!    nodata and non-base borders, base levels fixed.
//!
//! Base levels (fixed heights, never uplifted, eroded or diffused) are the
//! cells of the selected DEM borders ([`Boundary`]) and every valid cell next to
//! nodata (non-finite) cells, which are outside the domain and left unchanged.
//! The solver is sequential and uses no hashing or threads: the result is the
//! same bytes on every run.
//!
//! The tiled (out-of-core) solve with the same result bit for bit is
//! [`super::stream_power_tiled`] (fill and no routing; not the basin graph).

use crate::error::{Error, Result};
use crate::flow::{route_steepest, FlowGraph, Lakes};
use crate::raster::{neighbours, Grid};

pub(crate) use crate::flow::{order_key, BASE, VALID};

/// Column offsets of the 8 neighbours (E, SE, S, SW, W, NW, N, NE) of
/// [`crate::raster::neighbours`], as `isize`.
pub(crate) const DX: [isize; 8] = as_isize(neighbours::DX);
/// Row offsets of the 8 neighbours (y grows southwards).
pub(crate) const DY: [isize; 8] = as_isize(neighbours::DY);

const fn as_isize(v: [i64; 8]) -> [isize; 8] {
    let mut o = [0isize; 8];
    let mut k = 0;
    while k < 8 {
        o[k] = v[k] as isize;
        k += 1;
    }
    o
}
/// Largest number of explicit diffusion substeps one step may need.
pub(crate) const MAX_DIFFUSION_SUBSTEPS: usize = 100_000;

/// How flow crosses closed depressions when receivers are computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Depressions {
    /// Priority-flood filling (Barnes, Lehman & Mulla 2014): steepest descent
    /// on the water surface; its flats drain along breadth-first distances to
    /// their outlet (same definition in the tiled solve).
    Fill,
    /// Cordonnier, Bovy & Braun (2019) basin graph: minimum spanning tree of
    /// basin passes; receivers reversed from each pass to its pit.
    BasinGraph,
    /// No routing: each pit is a local base level (it is uplifted, never eroded).
    None,
}

/// Which DEM borders are base levels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Boundary {
    /// First row.
    pub north: bool,
    /// Last row.
    pub south: bool,
    /// Last column.
    pub east: bool,
    /// First column.
    pub west: bool,
}

impl Boundary {
    /// All four borders are base levels.
    pub const ALL: Boundary = Boundary {
        north: true,
        south: true,
        east: true,
        west: true,
    };
    /// Parse `all`, `none` or a comma list of `north,south,east,west` (or `n,s,e,w`).
    pub fn parse(s: &str) -> Result<Boundary> {
        let mut b = Boundary {
            north: false,
            south: false,
            east: false,
            west: false,
        };
        match s.trim() {
            "all" => return Ok(Boundary::ALL),
            "none" => return Ok(b),
            _ => {}
        }
        for t in s.split(',') {
            match t.trim() {
                "n" | "north" => b.north = true,
                "s" | "south" => b.south = true,
                "e" | "east" => b.east = true,
                "w" | "west" => b.west = true,
                o => {
                    return Err(Error::invalid(format!(
                        "base level side {o:?}: use all, none or a list of north,south,east,west"
                    )))
                }
            }
        }
        Ok(b)
    }
}

/// Height kept at the base levels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BaseHeight {
    /// Their initial elevation.
    Initial,
    /// Zero (set before the first step).
    Zero,
}

/// Parameters of [`stream_power`].
#[derive(Debug, Clone, PartialEq)]
pub struct StreamPowerParams {
    /// Erodibility `K` (units m^(1−2m)/yr for n = 1), ≥ 0.
    pub k: f64,
    /// Area exponent `m`, ≥ 0.
    pub m: f64,
    /// Slope exponent `n`, > 0.
    pub n: f64,
    /// Time step (years), > 0.
    pub dt: f64,
    /// Hillslope diffusivity `K_d` (m²/yr), ≥ 0; 0 = no diffusion.
    pub kd: f64,
    /// Depression routing.
    pub depressions: Depressions,
    /// Base-level borders.
    pub boundary: Boundary,
    /// Base-level height.
    pub base_height: BaseHeight,
}

impl Default for StreamPowerParams {
    /// FastScape-like defaults: K = 1e-5, m = 0.4, n = 1, dt = 1000 yr,
    /// no diffusion, all borders base levels at their initial heights, filling.
    fn default() -> Self {
        StreamPowerParams {
            k: 1e-5,
            m: 0.4,
            n: 1.0,
            dt: 1000.0,
            kd: 0.0,
            depressions: Depressions::Fill,
            boundary: Boundary::ALL,
            base_height: BaseHeight::Initial,
        }
    }
}

impl StreamPowerParams {
    /// Check every parameter; the error says which one and what is allowed.
    pub fn validate(&self) -> Result<()> {
        let bad = |name: &str, v: f64, what: &str| {
            Err(Error::invalid(format!(
                "stream power: {name} = {v} is invalid; it must be {what}"
            )))
        };
        if !(self.k.is_finite() && self.k >= 0.0) {
            return bad("K (erodibility)", self.k, "finite and >= 0 (e.g. 1e-5)");
        }
        if !(self.m.is_finite() && self.m >= 0.0) {
            return bad("m", self.m, "finite and >= 0 (e.g. 0.4)");
        }
        if !(self.n.is_finite() && self.n > 0.0 && self.n <= 10.0) {
            return bad("n", self.n, "in (0, 10] (e.g. 1)");
        }
        if !(self.dt.is_finite() && self.dt > 0.0) {
            return bad("dt", self.dt, "finite and > 0 (years)");
        }
        if !(self.kd.is_finite() && self.kd >= 0.0) {
            return bad("Kd (diffusivity)", self.kd, "finite and >= 0");
        }
        Ok(())
    }
}

/// Uplift rate (m/yr): one value everywhere or one per cell.
#[derive(Debug, Clone, Copy)]
pub enum Uplift<'a> {
    /// The same rate on every cell that is not a base level.
    Uniform(f64),
    /// A rate per cell (same size as the DEM; must be finite on valid cells).
    Map(&'a Grid<f64>),
}

/// Run `steps` steps of stream-power erosion on `h` (metres, square cells of
/// `cell` metres; non-finite cells are nodata). See the module doc for the
/// scheme and its sources.
pub fn stream_power(
    h: &mut Grid<f64>,
    cell: f64,
    p: &StreamPowerParams,
    uplift: &Uplift,
    steps: usize,
) -> Result<()> {
    if steps == 0 {
        return Err(Error::invalid(
            "stream power: steps = 0; give at least one time step",
        ));
    }
    let mut sp = StreamPower::new(h, cell, p)?;
    for _ in 0..steps {
        sp.step(h, uplift)?;
    }
    Ok(())
}

/// The solver with its flow graph and scratch buffers, reused from step to
/// step (after the first step, depression routing allocates only the union-find
/// over its basins).
///
/// After [`step`](Self::step), [`receivers`](Self::receivers),
/// [`stack`](Self::stack) and [`area`](Self::area) describe the flow graph of
/// that step's uplifted surface (the one the erosion used).
pub struct StreamPower {
    w: usize,
    h: usize,
    cell: f64,
    p: StreamPowerParams,
    /// Cell flags: [`VALID`], [`BASE`].
    flags: Vec<u8>,
    /// Receivers, distances (metres) and stack of the uplifted surface.
    graph: FlowGraph<f64>,
    area: Vec<f64>,
    /// Water levels of this step's depressions and the resolvers' scratch.
    lakes: Lakes<f64>,
    /// Diffusion buffer.
    scratch: Vec<f64>,
}

impl StreamPower {
    /// Prepare a solver for `h` (sets base levels to 0 if asked).
    pub fn new(h: &mut Grid<f64>, cell: f64, p: &StreamPowerParams) -> Result<StreamPower> {
        p.validate()?;
        if !(cell.is_finite() && cell > 0.0) {
            return Err(Error::invalid(format!(
                "stream power: cell size {cell} m is invalid; it must be finite and > 0"
            )));
        }
        let (w, ht) = (h.width(), h.height());
        let n = w * ht;
        if n == 0 {
            return Err(Error::invalid("stream power: the DEM has no cells"));
        }
        if n >= u32::MAX as usize {
            return Err(Error::invalid(format!(
                "stream power: {w}x{ht} cells is more than the in-memory solver indexes (2^32 - 1)"
            )));
        }
        let data = h.data();
        let mut flags = vec![0u8; n];
        for (f, v) in flags.iter_mut().zip(data) {
            if v.is_finite() {
                *f = VALID;
            }
        }
        let b = p.boundary;
        let mut nbase = 0usize;
        for y in 0..ht {
            for x in 0..w {
                let i = y * w + x;
                if flags[i] & VALID == 0 {
                    continue;
                }
                if is_base(&b, x, y, w, ht, |_, nx, ny| flags[ny * w + nx] & VALID == 0) {
                    flags[i] |= BASE;
                    nbase += 1;
                }
            }
        }
        if nbase == 0 {
            return Err(Error::invalid(
                "stream power: no base level (no border selected and no nodata cell); \
                 select at least one border (e.g. all)",
            ));
        }
        if p.base_height == BaseHeight::Zero {
            for (v, f) in h.data_mut().iter_mut().zip(&flags) {
                if f & BASE != 0 {
                    *v = 0.0;
                }
            }
        }
        Ok(StreamPower {
            w,
            h: ht,
            cell,
            p: p.clone(),
            flags,
            graph: FlowGraph::new(w, ht)?,
            area: vec![0.0; n],
            lakes: Lakes::new(),
            scratch: Vec::new(),
        })
    }

    /// Receiver of each cell (row-major index; a root is its own receiver).
    pub fn receivers(&self) -> &[u32] {
        self.graph.receivers()
    }
    /// Cells ordered so that every cell comes after its receiver.
    pub fn stack(&self) -> &[u32] {
        self.graph.stack()
    }
    /// Drainage area of each cell (m², the cell itself included; 0 on nodata).
    pub fn area(&self) -> &[f64] {
        &self.area
    }
    /// True for base-level cells.
    pub fn is_base(&self, i: usize) -> bool {
        self.flags[i] & BASE != 0
    }

    /// One time step: uplift, route, erode, diffuse.
    pub fn step(&mut self, h: &mut Grid<f64>, uplift: &Uplift) -> Result<()> {
        if h.width() != self.w || h.height() != self.h {
            return Err(Error::invalid(format!(
                "stream power: grid is {}x{}, the solver was made for {}x{}",
                h.width(),
                h.height(),
                self.w,
                self.h
            )));
        }
        self.uplift(h.data_mut(), uplift)?;
        self.route(h.data());
        let left = self.graph.build_stack();
        debug_assert_eq!(left, 0, "the routers make acyclic graphs");
        self.accumulate();
        self.erode(h.data_mut());
        if self.p.kd > 0.0 {
            self.diffuse(h.data_mut())?;
        }
        Ok(())
    }

    fn uplift(&self, h: &mut [f64], u: &Uplift) -> Result<()> {
        match u {
            Uplift::Uniform(r) if !r.is_finite() => {
                return Err(Error::invalid(format!(
                    "stream power: uplift rate {r} is not finite"
                )));
            }
            Uplift::Map(g) if g.width() != self.w || g.height() != self.h => {
                return Err(Error::invalid(format!(
                    "stream power: the uplift map is {}x{} but the DEM is {}x{}",
                    g.width(),
                    g.height(),
                    self.w,
                    self.h
                )));
            }
            _ => {}
        }
        raise(h, &self.flags, self.p.dt, u).map_err(|i| no_uplift_rate(i % self.w, i / self.w))
    }

    /// Route `h` into the flow graph: steepest descent, then the
    /// depression routing of the parameters when there are pits.
    fn route(&mut self, h: &[f64]) {
        self.lakes.clear();
        let pits = route_steepest(&mut self.graph, h, &self.flags, self.cell);
        if pits == 0 {
            return;
        }
        match self.p.depressions {
            Depressions::None => {}
            Depressions::Fill => self.lakes.fill(&mut self.graph, h, &self.flags, self.cell),
            Depressions::BasinGraph => {
                self.lakes
                    .basin_graph(&mut self.graph, h, &self.flags, self.cell, true)
            }
        }
    }

    /// Drainage area: cell counts summed in reverse stack order, then times the
    /// cell area. Counts are integers below 2^53, so the sums are exact and do
    /// not depend on the summation order (a tiled pass gives the same bits).
    fn accumulate(&mut self) {
        for (a, f) in self.area.iter_mut().zip(&self.flags) {
            *a = if f & VALID != 0 { 1.0 } else { 0.0 };
        }
        self.graph
            .accumulate(&mut self.area)
            .expect("one area per cell; f64 sums do not overflow");
        let ca = self.cell * self.cell;
        for a in self.area.iter_mut() {
            *a *= ca;
        }
    }

    fn erode(&self, h: &mut [f64]) {
        let (k, m, n, dt) = (self.p.k, self.p.m, self.p.n, self.p.dt);
        if k == 0.0 {
            return;
        }
        let linear = n == 1.0;
        let (rec, dist) = (self.graph.receivers(), self.graph.distances());
        let level = self.lakes.levels();
        for &s in self.graph.stack() {
            let i = s as usize;
            let r = rec[i] as usize;
            if r == i || self.flags[i] != VALID {
                continue;
            }
            let hr = h[r];
            let hs = h[i];
            if hs <= hr || level.is_some_and(|l| l[i] > hs) {
                continue; // in a lake: no erosion, no deposition
            }
            let d = dist[i];
            let c = k * dt * self.area[i].powf(m);
            if linear {
                let fac = c / d;
                h[i] = (hs + fac * hr) / (1.0 + fac);
            } else {
                h[i] = newton(hs, hr, d, c, n);
            }
        }
    }

    fn diffuse(&mut self, h: &mut [f64]) -> Result<()> {
        let (w, ht) = (self.w, self.h);
        let (nsub, c) = diffusion_substeps(&self.p, self.cell)?;
        self.scratch.resize(w * ht, 0.0);
        for _ in 0..nsub {
            self.scratch.copy_from_slice(h);
            let old = &self.scratch;
            for y in 0..ht {
                for x in 0..w {
                    let i = y * w + x;
                    if self.flags[i] != VALID {
                        continue;
                    }
                    let hi = old[i];
                    let mut lap = 0.0;
                    if x > 0 && self.flags[i - 1] & VALID != 0 {
                        lap += old[i - 1] - hi;
                    }
                    if x + 1 < w && self.flags[i + 1] & VALID != 0 {
                        lap += old[i + 1] - hi;
                    }
                    if y > 0 && self.flags[i - w] & VALID != 0 {
                        lap += old[i - w] - hi;
                    }
                    if y + 1 < ht && self.flags[i + w] & VALID != 0 {
                        lap += old[i + w] - hi;
                    }
                    h[i] = hi + c * lap;
                }
            }
        }
        Ok(())
    }
}

/// Uplift of one step: every cell whose flags are exactly [`VALID`] rises
/// by its rate times `dt` (`u`'s map has the size of `h`). `Err(i)` at the
/// first such cell whose rate is not finite.
pub(crate) fn raise(
    h: &mut [f64],
    flags: &[u8],
    dt: f64,
    u: &Uplift,
) -> std::result::Result<(), usize> {
    match u {
        Uplift::Uniform(r) => {
            let du = r * dt;
            for (v, f) in h.iter_mut().zip(flags) {
                if *f == VALID {
                    *v += du;
                }
            }
        }
        Uplift::Map(g) => {
            for (i, (v, f)) in h.iter_mut().zip(flags).enumerate() {
                if *f == VALID {
                    let r = g.data()[i];
                    if !r.is_finite() {
                        return Err(i);
                    }
                    *v += r * dt;
                }
            }
        }
    }
    Ok(())
}

/// The error for a valid cell (column `x`, row `y`) the uplift map has no rate for.
pub(crate) fn no_uplift_rate(x: usize, y: usize) -> Error {
    Error::invalid(format!(
        "stream power: the uplift map has no value at column {x}, row {y} \
         where the DEM has one; give a rate for every valid cell"
    ))
}

/// The explicit diffusion substeps of one step of `p` on cells of `cell`
/// metres: how many (each within the stability limit
/// `dt_sub <= 0.2·cell²/Kd`) and the factor `Kd·dt_sub/cell²`; an error when
/// more than [`MAX_DIFFUSION_SUBSTEPS`] would be needed.
pub(crate) fn diffusion_substeps(p: &StreamPowerParams, cell: f64) -> Result<(usize, f64)> {
    let lim = 0.2 * cell * cell / p.kd;
    let nsub = (p.dt / lim).ceil().max(1.0);
    if nsub > MAX_DIFFUSION_SUBSTEPS as f64 {
        return Err(Error::invalid(format!(
            "stream power: diffusion with Kd = {} and dt = {} needs {nsub:.0} explicit substeps \
             per step (more than {MAX_DIFFUSION_SUBSTEPS}); lower dt or Kd",
            p.kd, p.dt
        )));
    }
    let nsub = nsub as usize;
    Ok((nsub, p.dt / nsub as f64 * p.kd / (cell * cell)))
}

/// Whether the valid cell `(x, y)` of a `w` x `h` raster is a base level
/// (see the module doc): on a border selected in `b`, or 8-adjacent to a cell
/// inside the raster for which `invalid(d, nx, ny)` (direction `d`, neighbour
/// `(nx, ny)`) holds.
pub(crate) fn is_base(
    b: &Boundary,
    x: usize,
    y: usize,
    w: usize,
    h: usize,
    mut invalid: impl FnMut(usize, usize, usize) -> bool,
) -> bool {
    if (b.north && y == 0)
        || (b.south && y + 1 == h)
        || (b.west && x == 0)
        || (b.east && x + 1 == w)
    {
        return true;
    }
    (0..8).any(|d| {
        let (nx, ny) = (x as isize + DX[d], y as isize + DY[d]);
        nx >= 0
            && ny >= 0
            && (nx as usize) < w
            && (ny as usize) < h
            && invalid(d, nx as usize, ny as usize)
    })
}

/// Solve `x − hs + c·((x − hr)/d)^n = 0` for `x` in `(hr, hs]` (`c = K·dt·A^m`).
/// `n = 2`: the root of the quadratic in `D = x − hr`, `(c/d²)·D² + D − Δ = 0`
/// with `Δ = hs − hr`, in the cancellation-free form `D = 2Δ/(1 + √(1 + 4cΔ/d²))`.
/// Otherwise Newton from `hs` (one `powf` per iteration); a step that would
/// leave the bracket `(lo, hi)` is replaced by bisection.
pub(crate) fn newton(hs: f64, hr: f64, d: f64, c: f64, n: f64) -> f64 {
    if n == 2.0 {
        let delta = hs - hr;
        return hr + 2.0 * delta / (1.0 + (1.0 + 4.0 * c * delta / (d * d)).sqrt());
    }
    let mut x = hs;
    let mut lo = hr;
    let mut hi = hs;
    for _ in 0..100 {
        let s = (x - hr) / d;
        let p = s.powf(n - 1.0); // s^(n-1); s^n = s·p
        let f = x - hs + c * s * p;
        if f > 0.0 {
            hi = x;
        } else {
            lo = x;
        }
        let df = 1.0 + c * n * p / d;
        let mut nx = x - f / df;
        if !(nx > lo && nx < hi && nx.is_finite()) {
            nx = 0.5 * (lo + hi);
        }
        if (nx - x).abs() <= 1e-12 * (1.0 + x.abs()) {
            return nx;
        }
        x = nx;
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn newton_matches_closed_form_for_n2() {
        // x - hs + c ((x-hr)/d)^2 = 0  =>  with u = (x-hr)/d: c u^2 + d u - (hs-hr) = 0.
        let (hs, hr, d, c): (f64, f64, f64, f64) = (10.0, 2.0, 30.0, 5000.0);
        let u = (-d + (d * d + 4.0 * c * (hs - hr)).sqrt()) / (2.0 * c);
        let x = newton(hs, hr, d, c, 2.0);
        assert!((x - (hr + u * d)).abs() < 1e-9, "{x} vs {}", hr + u * d);
        // Newton (n just off 2) agrees with the closed form to first order.
        let y = newton(hs, hr, d, c, 2.0 + 1e-9);
        assert!((y - x).abs() < 1e-6, "{y} vs {x}");
        // n = 1.5 by Newton satisfies its equation.
        let z = newton(hs, hr, d, c, 1.5);
        let f = z - hs + c * ((z - hr) / d).powf(1.5);
        assert!(f.abs() < 1e-9 && z > hr && z < hs, "{z}: {f}");
    }

    #[test]
    fn order_key_orders() {
        let v = [-5.0, -0.5, 0.0, 1e-300, 2.0, 1e10];
        for p in v.windows(2) {
            assert!(order_key(p[0]) < order_key(p[1]));
        }
    }

    #[test]
    fn fill_and_basin_graph_drain_every_cell_to_a_base_level() {
        // A bowl with a rim: the centre is a pit, every cell must reach the border.
        let w = 15;
        let mut levels = Vec::new();
        let mut heights = Vec::new();
        for dep in [Depressions::Fill, Depressions::BasinGraph] {
            let mut g = Grid::from_fn(w, w, |x, y| {
                let (dx, dy) = (x as f64 - 7.0, y as f64 - 7.0);
                let r = (dx * dx + dy * dy).sqrt();
                if x == 0 || y == 0 || x == w - 1 || y == w - 1 {
                    0.0
                } else {
                    10.0 + 5.0 * (-((r - 4.0) * (r - 4.0))).exp()
                        + 0.01 * ((x * 7 + y * 3) % 5) as f64
                }
            });
            let p = StreamPowerParams {
                depressions: dep,
                ..Default::default()
            };
            heights = g.data().to_vec();
            let mut sp = StreamPower::new(&mut g, 10.0, &p).unwrap();
            sp.step(&mut g, &Uplift::Uniform(0.0)).unwrap();
            for start in 0..w * w {
                let mut c = start;
                for _ in 0..w * w {
                    let r = sp.receivers()[c] as usize;
                    if r == c {
                        break;
                    }
                    c = r;
                }
                assert!(sp.is_base(c), "{dep:?}: cell {start} ends at {c}");
            }
            let outflow: f64 = (0..w * w)
                .filter(|&i| sp.is_base(i))
                .map(|i| sp.area[i])
                .sum();
            assert_eq!(outflow, (w * w) as f64 * 100.0);
            levels.push(sp.lakes.levels().expect("the bowl is a pit").to_vec());
        }
        // Both give the same water levels (flood level = highest pass on the
        // minimum-spanning-tree path), and the bowl does hold a lake.
        assert_eq!(levels[0], levels[1]);
        assert!(levels[0].iter().zip(&heights).any(|(l, z)| l > z));
    }
}
