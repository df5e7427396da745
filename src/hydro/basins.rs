//! Basins, watersheds from pour points and height above nearest drainage —
//! all one operation: *carry a value from the first "seed" cell met on each
//! cell's D8 path back up to the cell*.
//!
//! - **Basin labels**: the seeds are the DEM's outlets (cells whose flow
//!   leaves the raster, enters nodata, or stops: [`super::NO_FLOW`]); each
//!   basin is labelled by its outlet's row-major global index + 1, a label
//!   that does not depend on tiling (0 / NaN = nodata).
//! - **Watersheds from points** (the ArcGIS "Watershed" tool's definition):
//!   the seeds are pour points with ids `1..=n`; a cell belongs to the first
//!   pour point on its downstream path (nested points give nested, disjoint
//!   watersheds); cells whose path meets none are 0.
//! - **HAND**, height above the nearest drainage (Rennó, C.D. et al. 2008,
//!   "HAND, a new terrain descriptor using SRTM-DEM: Mapping terra-firme
//!   rainforest environments in Amazonia", Remote Sensing of Environment
//!   112, 3469–3481): the seeds are stream cells carrying their elevation;
//!   HAND = z − z(first stream cell down the D8 path) (NaN when the path
//!   leaves the DEM without meeting a stream).
//!
//! In memory, [`basin_labels`], [`watersheds`] and [`hand`] walk each path
//! once with memoisation (O(n)). Across tiles, [`TiledDownstream`] is an
//! exact global pass built like Barnes (2017)'s perimeter-link graph
//! (see [`super::tiled`]), but propagating *upstream*: *map* resolves every
//! core cell either to a value (its path meets a seed or ends inside the
//! tile) or to the perimeter cell through which its path leaves the tile,
//! and records, for each perimeter cell, that resolution plus the cell of
//! the neighbouring tile the leaving cells flow into; *reduce* follows these
//! links over the perimeter graph (O(total perimeter)) to resolve every
//! leaving cell; *apply* resolves the tile again and reads leaving cells'
//! values from its slice. No arithmetic happens across tiles, so the tiled
//! result equals the in-memory one bit for bit.

use super::indices::INDEX_NODATA;
use super::{code_to_dir, DX, DY, NODATA_DIR, NO_FLOW};
use crate::error::{Error, Result};
use crate::exec::output::OutputSpec;
use crate::exec::GlobalStep;
use crate::io::vector::PointNoun;
use crate::raster::{perimeter_cells, perimeter_index, perimeter_len};
use crate::raster::{DType, Grid, RasterSource, TileId, TileLayout, TileView, Window};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// How a cell's downstream walk ends inside one array (a tile or a grid).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Term {
    /// A value (a seed's value, or NaN when the path ends without a seed).
    Val(f64),
    /// The path leaves the array through this perimeter cell (index in the
    /// row-major perimeter enumeration) into a valid cell of another tile.
    Exit(u32),
}

/// What a cell is, for the walk.
pub(crate) enum Class {
    /// Nodata: value NaN, no walk.
    Nodata,
    /// A seed with its value: the walk stops here.
    Seed(f64),
    /// The flow stops or leaves the DEM without a seed: NaN.
    End,
    /// The flow continues to this cell of the array.
    Next(usize),
    /// The flow continues into a valid cell outside the array.
    Exit,
}

/// Resolve every cell of a `w` x `h` array (see [`Term`]); `classify`
/// describes each cell. Errors on a cycle. Each cell is visited once: paths
/// are walked until a resolved cell, then the stack is unwound.
pub(crate) fn resolve_terms(
    w: usize,
    h: usize,
    mut classify: impl FnMut(usize) -> Result<Class>,
) -> Result<Vec<Term>> {
    const UNSET: u8 = 0;
    const ACTIVE: u8 = 1;
    const DONE: u8 = 2;
    let n = w * h;
    let mut state = vec![UNSET; n];
    let mut term = vec![Term::Val(f64::NAN); n];
    let mut stack: Vec<usize> = Vec::new();
    for c0 in 0..n {
        if state[c0] != UNSET {
            continue;
        }
        let mut c = c0;
        let result = loop {
            state[c] = ACTIVE;
            stack.push(c);
            match classify(c)? {
                Class::Nodata | Class::End => break Term::Val(f64::NAN),
                Class::Seed(v) => break Term::Val(v),
                Class::Exit => {
                    let k = perimeter_index(w, h, c % w, c / w).ok_or_else(|| {
                        Error::invalid("internal: a cell leaving the tile is not on its perimeter")
                    })?;
                    break Term::Exit(k as u32);
                }
                Class::Next(r) => match state[r] {
                    DONE => break term[r],
                    ACTIVE => {
                        return Err(Error::invalid(format!(
                            "flow directions contain a cycle through cell ({}, {}) of the tile or grid; directions must come from a D8 routing of one DEM",
                            r % w,
                            r / w
                        )))
                    }
                    _ => c = r,
                },
            }
        };
        for &s in &stack {
            state[s] = DONE;
            term[s] = result;
        }
        stack.clear();
    }
    Ok(term)
}

/// The D8 receiver of (x, y) as an offset, or `None` for no flow; errors on
/// an invalid code.
#[inline]
fn step_of(code: u8, x: i64, y: i64) -> Result<Option<(i64, i64)>> {
    if code == NO_FLOW {
        return Ok(None);
    }
    match code_to_dir(code) {
        Some(d) => Ok(Some((x + DX[d], y + DY[d]))),
        None => Err(Error::invalid(format!(
            "flow direction {code} at cell ({x}, {y}) is not a D8 code (0, 1, 2, 4, …, 128; 255 for nodata)"
        ))),
    }
}

/// Classify cell `c` of a whole grid of codes (no tiles).
fn classify_grid(dirs: &Grid<u8>, c: usize, seed: impl Fn(usize) -> Option<f64>) -> Result<Class> {
    let (w, h) = (dirs.width(), dirs.height());
    let code = dirs.data()[c];
    if code == NODATA_DIR {
        return Ok(Class::Nodata);
    }
    if let Some(v) = seed(c) {
        return Ok(Class::Seed(v));
    }
    let (x, y) = ((c % w) as i64, (c / w) as i64);
    Ok(match step_of(code, x, y)? {
        None => Class::End,
        Some((nx, ny)) => {
            if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                Class::End
            } else {
                let r = ny as usize * w + nx as usize;
                if dirs.data()[r] == NODATA_DIR {
                    Class::End
                } else {
                    Class::Next(r)
                }
            }
        }
    })
}

/// True if the flow of cell `c` of a whole grid leaves the DEM or stops.
fn is_outlet(dirs: &Grid<u8>, c: usize) -> Result<bool> {
    Ok(matches!(
        classify_grid(dirs, c, |_| None)?,
        Class::End | Class::Nodata
    ) && dirs.data()[c] != NODATA_DIR)
}

fn values(dirs: &Grid<u8>, seed: impl Fn(usize) -> Option<f64>) -> Result<Vec<f64>> {
    let t = resolve_terms(dirs.width(), dirs.height(), |c| {
        classify_grid(dirs, c, &seed)
    })?;
    Ok(t.into_iter()
        .map(|t| match t {
            Term::Val(v) => v,
            Term::Exit(_) => f64::NAN,
        })
        .collect())
}

/// Basin label of every cell: the row-major index + 1 of the outlet its D8
/// path reaches (0 for nodata). `dirs` are ESRI codes.
pub fn basin_labels(dirs: &Grid<u8>) -> Result<Grid<u64>> {
    let out = values(dirs, |c| {
        // an outlet is a seed labelled by its own index
        match is_outlet(dirs, c) {
            Ok(true) => Some((c + 1) as f64),
            _ => None,
        }
    })?;
    Grid::from_vec(
        dirs.width(),
        dirs.height(),
        out.into_iter()
            .map(|v| if v.is_nan() { 0 } else { v as u64 })
            .collect(),
    )
}

/// Watersheds of pour points `(x, y)` (cell coordinates): cells whose D8 path
/// meets point `i` first get `i + 1`; others 0. Later duplicates of a cell
/// are ignored (the first point at a cell wins).
pub fn watersheds(dirs: &Grid<u8>, points: &[(usize, usize)]) -> Result<Grid<u32>> {
    let (w, h) = (dirs.width(), dirs.height());
    let mut id = vec![0u32; w * h];
    for (i, &(x, y)) in points.iter().enumerate().rev() {
        if x >= w || y >= h {
            return Err(Error::invalid(format!(
                "pour point {} at cell ({x}, {y}) lies outside the {w}x{h} raster",
                i + 1
            )));
        }
        id[y * w + x] = (i + 1) as u32;
    }
    let out = values(dirs, |c| (id[c] != 0).then_some(id[c] as f64))?;
    Grid::from_vec(
        w,
        h,
        out.into_iter()
            .map(|v| if v.is_nan() { 0 } else { v as u32 })
            .collect(),
    )
}

/// Height above nearest drainage (Rennó et al. 2008): `z − z_s` with `z_s` the
/// elevation of the first cell of `streams` (true) on the D8 path; NaN where
/// the path meets no stream or `z` is nodata.
pub fn hand(dem: &Grid<f32>, dirs: &Grid<u8>, streams: &Grid<bool>) -> Result<Grid<f32>> {
    same_size(dem.width(), dem.height(), dirs.width(), dirs.height())?;
    same_size(
        streams.width(),
        streams.height(),
        dirs.width(),
        dirs.height(),
    )?;
    let z = dem.data();
    let s = streams.data();
    let base = values(dirs, |c| (s[c] && z[c].is_finite()).then_some(z[c] as f64))?;
    Grid::from_vec(
        dem.width(),
        dem.height(),
        base.iter()
            .zip(z)
            .map(|(&b, &zc)| {
                if b.is_nan() || !zc.is_finite() {
                    f32::NAN
                } else {
                    (zc as f64 - b) as f32
                }
            })
            .collect(),
    )
}

fn same_size(w: usize, h: usize, w2: usize, h2: usize) -> Result<()> {
    if (w, h) != (w2, h2) {
        return Err(Error::invalid(format!(
            "rasters of one step must have the same size: {w}x{h} vs {w2}x{h2}"
        )));
    }
    Ok(())
}

// ------------------------------------------------------------- tiled ----

/// What the seeds of a [`TiledDownstream`] pass are.
#[derive(Debug, Clone, PartialEq)]
pub enum Seeds {
    /// Basin labels: every outlet, labelled by its global row-major index + 1.
    Outlets,
    /// Pour points: `(global row-major index, id)` sorted by index, ids ≥ 1.
    Points(Vec<(u64, u32)>),
    /// HAND: cells of input 2 with a value ≥ `threshold` are streams (an
    /// accumulation with a channel threshold, or a stream raster with 1).
    Streams { threshold: f64 },
}

/// Exact tiled propagation of the first downstream seed's value (see the
/// module docs). Inputs, read as f64: 0 = D8 directions (ESRI codes, NaN/255
/// nodata); for [`Seeds::Streams`] also 1 = DEM and 2 = stream raster.
/// Output (f64): the label (basins: outlet index + 1; points: id; 0 where
/// none) or HAND (NaN where none).
#[derive(Debug, Clone)]
pub struct TiledDownstream {
    pub seeds: Seeds,
    /// Cell type of a label output (basins, watersheds; not HAND, which is
    /// f32): [`TiledDownstream::label_type`] of the raster's size.
    pub labels: DType,
}

/// A perimeter cell's resolution inside its tile (`None` = NaN).
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
pub enum PerimTerm {
    Val(Option<f64>),
    Exit(u32),
}

/// Per-tile summary of [`TiledDownstream`]: O(perimeter).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct DownSummary {
    pub w: usize,
    pub h: usize,
    /// One entry per perimeter cell (row-major perimeter order).
    pub perimeter: Vec<PerimTerm>,
    /// Leaving perimeter cells: (perimeter index, global x, global y of the
    /// cell of another tile it flows into).
    pub exits: Vec<(u32, u64, u64)>,
}

/// Reduced solution: the value of every leaving perimeter cell.
#[derive(Debug, Clone)]
pub struct DownSolution {
    offsets: Vec<usize>,
    value: Vec<Option<f64>>,
}

fn opt(v: f64) -> Option<f64> {
    (!v.is_nan()).then_some(v)
}

impl TiledDownstream {
    /// The label cell type for a raster of `width` x `height`: u32 while
    /// every label (at most the cell count) fits, else f64 (exact to 2^53).
    pub fn label_type(width: usize, height: usize) -> DType {
        if (width as u64) * (height as u64) < u32::MAX as u64 {
            DType::U32
        } else {
            DType::F64
        }
    }

    fn inputs_needed(&self) -> usize {
        match self.seeds {
            Seeds::Streams { .. } => 3,
            _ => 1,
        }
    }

    /// Decode a direction value read as f64 into a code.
    fn code(v: f64, gx: i64, gy: i64) -> Result<u8> {
        if v.is_nan() || v == NODATA_DIR as f64 {
            return Ok(NODATA_DIR);
        }
        if (0.0..=128.0).contains(&v) && v.fract() == 0.0 {
            let c = v as u8;
            if c == NO_FLOW || code_to_dir(c).is_some() {
                return Ok(c);
            }
        }
        Err(Error::invalid(format!(
            "flow direction {v} at cell ({gx}, {gy}) is not a D8 code (0, 1, 2, 4, …, 128; 255 or nodata)"
        )))
    }

    /// Resolve one tile's core cells.
    fn tile_terms(&self, inputs: &[TileView<f64>]) -> Result<Vec<Term>> {
        if inputs.len() < self.inputs_needed() {
            return Err(Error::invalid(format!(
                "this pass needs {} input(s): directions{}",
                self.inputs_needed(),
                if self.inputs_needed() == 3 {
                    ", DEM, streams"
                } else {
                    ""
                }
            )));
        }
        let d = &inputs[0];
        if d.halo < 1 {
            return Err(Error::invalid("downstream pass: views need a halo of 1"));
        }
        for i in &inputs[1..] {
            if i.core != d.core {
                return Err(Error::invalid("downstream pass: input tiles differ"));
            }
        }
        let (w, h) = (d.core.w, d.core.h);
        let (rw, rh) = (d.raster_width as i64, d.raster_height as i64);
        let (ox, oy) = (d.core.x, d.core.y);
        let seeds = &self.seeds;
        let classify = |c: usize| -> Result<Class> {
            let (x, y) = ((c % w) as i64, (c / w) as i64);
            let (gx, gy) = (ox + x, oy + y);
            let code = Self::code(d.at(x, y), gx, gy)?;
            if code == NODATA_DIR {
                return Ok(Class::Nodata);
            }
            let next = match step_of(code, x, y).map_err(|_| {
                Error::invalid(format!(
                    "flow direction {code} at cell ({gx}, {gy}) is not a D8 code"
                ))
            })? {
                None => None,
                Some((nx, ny)) => {
                    let (gnx, gny) = (ox + nx, oy + ny);
                    let outside = gnx < 0 || gny < 0 || gnx >= rw || gny >= rh;
                    if outside || Self::code(d.at(nx, ny), gnx, gny)? == NODATA_DIR {
                        None
                    } else {
                        Some((nx, ny))
                    }
                }
            };
            match seeds {
                Seeds::Outlets => {
                    if next.is_none() {
                        return Ok(Class::Seed((gy * rw + gx + 1) as f64));
                    }
                }
                Seeds::Points(p) => {
                    let g = (gy * rw + gx) as u64;
                    if let Ok(i) = p.binary_search_by_key(&g, |q| q.0) {
                        return Ok(Class::Seed(p[i].1 as f64));
                    }
                }
                Seeds::Streams { threshold } => {
                    let s = inputs[2].at(x, y);
                    let z = inputs[1].at(x, y);
                    if s >= *threshold && z.is_finite() {
                        return Ok(Class::Seed(z));
                    }
                }
            }
            Ok(match next {
                None => Class::End,
                Some((nx, ny)) => {
                    if nx >= 0 && ny >= 0 && nx < w as i64 && ny < h as i64 {
                        Class::Next(ny as usize * w + nx as usize)
                    } else {
                        Class::Exit
                    }
                }
            })
        };
        resolve_terms(w, h, classify)
    }
}

impl GlobalStep for TiledDownstream {
    type In = f64;
    type Out = f64;
    type Summary = DownSummary;
    type Solution = DownSolution;
    type Slice = Vec<Option<f64>>;

    fn name(&self) -> String {
        match self.seeds {
            Seeds::Outlets => "basins",
            Seeds::Points(_) => "watersheds",
            Seeds::Streams { .. } => "hand",
        }
        .into()
    }
    fn params(&self) -> serde_json::Value {
        match &self.seeds {
            Seeds::Outlets => serde_json::json!({"labels": "outlet row-major index + 1"}),
            Seeds::Points(p) => serde_json::json!({"points": p.len()}),
            Seeds::Streams { threshold } => serde_json::json!({
                "algorithm": "HAND (Renno et al. 2008)", "stream_threshold": threshold}),
        }
    }
    fn halo(&self) -> usize {
        1
    }

    fn outputs(&self) -> Vec<OutputSpec> {
        vec![match self.seeds {
            Seeds::Streams { .. } => OutputSpec::continuous(DType::F32, INDEX_NODATA),
            _ => OutputSpec::categorical(self.labels, 0.0),
        }]
    }
    fn map(&self, inputs: &[TileView<f64>]) -> Result<DownSummary> {
        let terms = self.tile_terms(inputs)?;
        let d = &inputs[0];
        let (w, h) = (d.core.w, d.core.h);
        let mut perimeter = Vec::with_capacity(perimeter_len(w, h));
        let mut exits = Vec::new();
        for (k, (x, y)) in perimeter_cells(w, h).enumerate() {
            let t = terms[y * w + x];
            perimeter.push(match t {
                Term::Val(v) => PerimTerm::Val(opt(v)),
                Term::Exit(j) => {
                    if j as usize == k {
                        let code = Self::code(d.at(x as i64, y as i64), 0, 0)?;
                        let dd = code_to_dir(code)
                            .ok_or_else(|| Error::invalid("internal: exit without a direction"))?;
                        exits.push((
                            k as u32,
                            (d.core.x + x as i64 + DX[dd]) as u64,
                            (d.core.y + y as i64 + DY[dd]) as u64,
                        ));
                    }
                    PerimTerm::Exit(j)
                }
            });
        }
        Ok(DownSummary {
            w,
            h,
            perimeter,
            exits,
        })
    }

    fn reduce(&self, layout: &TileLayout, summaries: Vec<DownSummary>) -> Result<DownSolution> {
        if summaries.len() != layout.count() {
            return Err(Error::invalid(format!(
                "{} reduce: {} summaries for {} tiles",
                self.name(),
                summaries.len(),
                layout.count()
            )));
        }
        let corrupt =
            |t: usize| Error::invalid(format!("{} reduce: bad summary of tile {t}", self.name()));
        let mut offsets = Vec::with_capacity(summaries.len());
        let mut total = 0usize;
        for (t, s) in summaries.iter().enumerate() {
            let win = layout.window(t);
            if s.w != win.w || s.h != win.h || s.perimeter.len() != perimeter_len(s.w, s.h) {
                return Err(corrupt(t));
            }
            offsets.push(total);
            total += s.perimeter.len();
        }
        // next[u]: the node u's value comes from (u itself when resolved)
        const NONE: usize = usize::MAX;
        let mut next = vec![NONE; total];
        let mut value: Vec<Option<f64>> = vec![None; total];
        let mut resolved = vec![false; total];
        for (t, s) in summaries.iter().enumerate() {
            let mut target = vec![NONE; s.perimeter.len()];
            for &(k, gx, gy) in &s.exits {
                let k = k as usize;
                if k >= s.perimeter.len()
                    || gx as usize >= layout.width
                    || gy as usize >= layout.height
                {
                    return Err(corrupt(t));
                }
                let (gx, gy) = (gx as usize, gy as usize);
                let tb = layout.id(gx / layout.tile, gy / layout.tile);
                let wb = layout.window(tb);
                let j = perimeter_index(wb.w, wb.h, gx - wb.x as usize, gy - wb.y as usize)
                    .ok_or_else(|| corrupt(t))?;
                if tb == t {
                    return Err(corrupt(t));
                }
                target[k] = offsets[tb] + j;
            }
            for (k, p) in s.perimeter.iter().enumerate() {
                let u = offsets[t] + k;
                match *p {
                    PerimTerm::Val(v) => {
                        value[u] = v;
                        resolved[u] = true;
                    }
                    PerimTerm::Exit(j) => {
                        let j = j as usize;
                        if j >= s.perimeter.len() || target[j] == NONE {
                            return Err(corrupt(t));
                        }
                        next[u] = target[j];
                    }
                }
            }
        }
        // follow the links, memoised; a path longer than `total` is a cycle
        let mut stack = Vec::new();
        let mut on_stack = vec![false; total];
        for u0 in 0..total {
            let mut u = u0;
            while !resolved[u] {
                if on_stack[u] {
                    return Err(Error::invalid(
                        "flow directions contain a cycle across tiles; directions must come from a D8 routing of one DEM",
                    ));
                }
                on_stack[u] = true;
                stack.push(u);
                u = next[u];
            }
            let v = value[u];
            for s in stack.drain(..) {
                value[s] = v;
                resolved[s] = true;
                on_stack[s] = false;
            }
        }
        Ok(DownSolution { offsets, value })
    }

    fn slice(&self, sol: &DownSolution, id: TileId) -> Vec<Option<f64>> {
        let end = sol.offsets.get(id + 1).copied().unwrap_or(sol.value.len());
        sol.value[sol.offsets[id]..end].to_vec()
    }

    fn apply(
        &self,
        inputs: &[TileView<f64>],
        slice: &Vec<Option<f64>>,
        out: &mut [Grid<f64>],
    ) -> Result<()> {
        let terms = self.tile_terms(inputs)?;
        let d = &inputs[0];
        let (w, h) = (d.core.w, d.core.h);
        if slice.len() != perimeter_len(w, h) {
            return Err(Error::invalid(format!(
                "{} apply: slice does not belong to this tile",
                self.name()
            )));
        }
        let o = out
            .first_mut()
            .ok_or_else(|| Error::invalid("downstream apply: no output grid"))?;
        for (c, cell) in o.data_mut().iter_mut().enumerate() {
            let v = match terms[c] {
                Term::Val(v) => v,
                Term::Exit(k) => slice.get(k as usize).copied().flatten().unwrap_or(f64::NAN),
            };
            *cell = match self.seeds {
                Seeds::Streams { .. } => {
                    let z = inputs[1].at((c % w) as i64, (c / w) as i64);
                    if v.is_nan() || !z.is_finite() {
                        f64::NAN
                    } else {
                        // same arithmetic as `hand`: f32 result of an f64 difference
                        ((z - v) as f32) as f64
                    }
                }
                _ => {
                    if v.is_nan() {
                        if Self::code(d.at((c % w) as i64, (c / w) as i64), 0, 0)? == NODATA_DIR {
                            f64::NAN
                        } else {
                            0.0
                        }
                    } else {
                        v
                    }
                }
            };
        }
        Ok(())
    }
}

// -------------------------------------------------------- pour points ----

/// A pour point read from a CSV or GeoJSON file, in map coordinates.
pub use crate::io::vector::MapPoint as PourPoint;
/// Upper bound on pour points read from a file (they are held in memory).
pub use crate::io::vector::MAX_POINTS;

/// What the pour points are, in the reader's messages.
const POUR_POINTS: PointNoun = PointNoun {
    one: "pour point",
    many: "pour points",
};

/// Read pour points: a `.geojson`/`.json` FeatureCollection of Points, or a
/// CSV with a header naming `x` and `y` (or `lon`/`lat`, `lng`/`lat`,
/// `longitude`/`latitude`) columns and optionally `id` or `name`
/// ([`crate::io::vector::read_points`]).
pub fn read_points(path: &Path) -> Result<Vec<PourPoint>> {
    crate::io::vector::read_points(path, POUR_POINTS)
}

/// [`read_points`] in the map coordinates of rasters with `georef` (a
/// GeoJSON `crs` member honoured, [`crate::io::vector::read_points_in`]).
pub fn read_points_in(path: &Path, georef: &crate::raster::GeoRef) -> Result<Vec<PourPoint>> {
    crate::io::vector::read_points_in(path, POUR_POINTS, georef)
}

/// Cell (col, row) of each map point in a raster of `src`'s georeference;
/// errors naming points that fall outside. With `snap_radius` > 0, each point
/// moves to the cell of largest `acc` within that many cells (Chebyshev
/// distance; ties: nearer, then row-major first) — reading only a window
/// around each point, so `acc` may be any size.
pub fn locate_points(
    src: &dyn RasterSource,
    pts: &[PourPoint],
    acc: Option<&dyn RasterSource>,
    snap_radius: usize,
) -> Result<Vec<(usize, usize)>> {
    let info = src.info();
    let (w, h) = (info.width, info.height);
    let mut out = Vec::with_capacity(pts.len());
    for (i, p) in pts.iter().enumerate() {
        let Some((cx, cy)) = info.georef.cell_at(p.x, p.y, w, h) else {
            return Err(Error::invalid(format!(
                "pour point {} ({}, {}) lies outside {} ({w}x{h} cells)",
                p.name.clone().unwrap_or_else(|| (i + 1).to_string()),
                p.x,
                p.y,
                info.path.display()
            )));
        };
        let (mut x, mut y) = (cx, cy);
        if snap_radius > 0 {
            let a = acc.ok_or_else(|| {
                Error::invalid("snapping pour points needs the flow accumulation raster")
            })?;
            let r = snap_radius as i64;
            let win = Window::new(
                x as i64 - r,
                y as i64 - r,
                2 * r as usize + 1,
                2 * r as usize + 1,
            );
            let g = crate::raster::read_window::<f64>(a, win)?;
            let mut best: Option<(f64, i64, usize)> = None;
            for (k, &v) in g.data().iter().enumerate() {
                if !v.is_finite() {
                    continue;
                }
                let (dx, dy) = ((k % g.width()) as i64 - r, (k / g.width()) as i64 - r);
                let dist = dx.abs().max(dy.abs());
                let better = match best {
                    None => true,
                    Some((bv, bd, _)) => v > bv || (v == bv && dist < bd),
                };
                if better {
                    best = Some((v, dist, k));
                }
            }
            if let Some((_, _, k)) = best {
                x = (win.x + (k % g.width()) as i64) as usize;
                y = (win.y + (k / g.width()) as i64) as usize;
            }
        }
        out.push((x, y));
    }
    Ok(out)
}

/// Pour points as [`Seeds::Points`] (sorted; the first point at a cell wins).
pub fn point_seeds(cells: &[(usize, usize)], width: usize) -> Seeds {
    let mut v: Vec<(u64, u32)> = cells
        .iter()
        .enumerate()
        .map(|(i, &(x, y))| ((y * width + x) as u64, (i + 1) as u32))
        .collect();
    v.sort();
    v.dedup_by_key(|p| p.0);
    Seeds::Points(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chain_and_outlet() {
        // 3 cells flowing east, the last leaves the raster
        let d = Grid::from_vec(3, 1, vec![1u8, 1, 1]).unwrap();
        assert_eq!(basin_labels(&d).unwrap().data(), &[3, 3, 3]);
        let ws = watersheds(&d, &[(1, 0)]).unwrap();
        assert_eq!(ws.data(), &[1, 1, 0]);
        let cyc = Grid::from_vec(2, 1, vec![1u8, 16]).unwrap();
        assert!(basin_labels(&cyc).is_err());
    }

    #[test]
    fn snapping_moves_to_the_largest_accumulation() {
        use crate::raster::{Crs, GeoRef, MemRaster};
        let g = GeoRef::north_up(100.0, 200.0, 10.0, Crs::projected(32633));
        // accumulation: 5 at (4, 2), 9 at (7, 2) (3 cells away), 9 at (1, 2)
        let mut a = Grid::new(10, 5, 1.0f64);
        a.set(4, 2, 5.0);
        a.set(7, 2, 9.0);
        a.set(1, 2, 9.0);
        let src = MemRaster::from_grid(a, g.clone());
        let p = |x: f64, y: f64| PourPoint { x, y, name: None };
        // cell (3, 2) has its centre at (135, 175)
        let pts = [p(135.0, 175.0)];
        assert_eq!(locate_points(&src, &pts, None, 0).unwrap(), vec![(3, 2)]);
        assert_eq!(
            locate_points(&src, &pts, Some(&src), 1).unwrap(),
            vec![(4, 2)]
        );
        // radius 4: both 9s in reach, (1, 2) is nearer (2 vs 4 cells)
        assert_eq!(
            locate_points(&src, &pts, Some(&src), 4).unwrap(),
            vec![(1, 2)]
        );
        assert!(locate_points(&src, &[p(0.0, 0.0)], None, 0).is_err());
    }

    #[test]
    fn csv_and_geojson_points() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("p.csv");
        std::fs::write(&p, "id,x,y\na,1.5,2\nb,3,4\n").unwrap();
        let v = read_points(&p).unwrap();
        assert_eq!(v.len(), 2);
        assert_eq!(
            (v[1].x, v[1].y, v[1].name.as_deref()),
            (3.0, 4.0, Some("b"))
        );
        let g = dir.path().join("p.geojson");
        std::fs::write(
            &g,
            r#"{"type":"FeatureCollection","features":[{"type":"Feature","geometry":{"type":"Point","coordinates":[5,6]},"properties":{"name":"x"}}]}"#,
        )
        .unwrap();
        assert_eq!(read_points(&g).unwrap()[0].x, 5.0);
        std::fs::write(&p, "a,b\n1,2\n").unwrap();
        assert!(read_points(&p).is_err());
    }
}
