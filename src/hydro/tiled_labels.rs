//! Watershed labels across tiles, equal to [`super::flow::outlet_labels`]
//! bit for bit: every cell gets the row-major index + 1 of the terminal cell
//! its D8 flow path ends at (an outlet whose code leaves the DEM, or a pit).
//!
//! The pointer-jumping structure of Barnes (2017)'s tiled flow
//! accumulation, run for labels instead of sums (labels flow *upstream*
//! from terminals, sums downstream): *map* follows every perimeter cell's
//! path inside its tile to a terminal cell (its label is then known
//! locally), to another perimeter cell of the tile it leaves through, or
//! notes the cell of another tile its code points into; *reduce* resolves
//! these O(perimeter) links into a label per perimeter cell (memoised path
//! following, cycles are errors); *apply* follows every cell's path inside
//! the tile and takes the label of its terminal or of the perimeter cell it
//! leaves through.
//!
//! Barnes, R. (2017). "Parallel non-divergent flow accumulation for trillion
//! cell digital elevation models on desktops or clusters". Environmental
//! Modelling & Software 92, 202–212.

use super::tiled::decode_code;
use super::{code_to_dir, DX, DY, NODATA_DIR, NO_FLOW};
use crate::error::{Error, Result};
use crate::exec::output::OutputSpec;
use crate::exec::GlobalStep;
use crate::raster::{perimeter_cells, perimeter_index, perimeter_len};
use crate::raster::{DType, Grid, TileId, TileLayout, TileView};
use serde::{Deserialize, Serialize};

/// Watershed labels from D8 directions across tiles. Input: D8 codes read
/// as f32 (NaN or 255 = nodata), halo 1; output: u32 labels (0 = nodata).
/// Rasters must have fewer than 2^32 cells.
#[derive(Debug, Clone, Copy, Default)]
pub struct TiledLabels;

/// Where a perimeter cell's flow path leads, seen from its tile.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
pub enum LabelLink {
    /// Nodata cell.
    Nodata,
    /// The path ends inside the tile at this global row-major cell index.
    Term(u64),
    /// The path leaves the tile through this other perimeter cell (index).
    Via(u32),
    /// The cell's own code points into another tile, at global (x, y).
    Cross(u64, u64),
}

/// Per-tile summary of [`TiledLabels`]: one link per perimeter cell.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct LabelSummary {
    pub w: usize,
    pub h: usize,
    pub perimeter: Vec<LabelLink>,
}

/// Reduced solution: the label of every perimeter cell.
#[derive(Debug, Clone)]
pub struct LabelSolution {
    offsets: Vec<usize>,
    label: Vec<u32>,
}

/// Per core cell: where its path ends inside the tile.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Res {
    Unknown,
    Nodata,
    /// Terminal global index.
    Term(u64),
    /// Leaves through this core cell (a perimeter cell whose code crosses).
    Leave(u32),
}

struct Resolved {
    w: usize,
    h: usize,
    res: Vec<Res>,
    /// Decoded core codes.
    codes: Vec<u8>,
}

/// Follow every core cell's path inside the tile.
fn resolve(v: &TileView<f32>) -> Result<Resolved> {
    if v.halo < 1 {
        return Err(Error::invalid(
            "labels: tile views need a halo of at least 1",
        ));
    }
    let (w, h) = (v.core.w, v.core.h);
    let rw = v.raster_width as u64;
    let mut codes = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            codes.push(decode_code(v.at(x as i64, y as i64), || {
                (v.core.x + x as i64, v.core.y + y as i64)
            })?);
        }
    }
    let gidx = |c: usize| -> u64 {
        (v.core.y as u64 + (c / w) as u64) * rw + v.core.x as u64 + (c % w) as u64
    };
    let mut res = vec![Res::Unknown; w * h];
    let mut on_path = vec![false; w * h];
    let mut path = Vec::new();
    for s in 0..w * h {
        if res[s] != Res::Unknown {
            continue;
        }
        let mut c = s;
        let r = loop {
            if res[c] != Res::Unknown {
                break res[c];
            }
            let (x, y) = (c % w, c / w);
            if on_path[c] {
                return Err(Error::invalid(format!(
                    "flow directions contain a cycle through cell ({}, {})",
                    v.core.x + x as i64,
                    v.core.y + y as i64
                )));
            }
            let code = codes[c];
            if code == NODATA_DIR {
                break Res::Nodata;
            }
            on_path[c] = true;
            path.push(c);
            let Some(d) = code_to_dir(code) else {
                // NO_FLOW: a pit
                debug_assert_eq!(code, NO_FLOW);
                break Res::Term(gidx(c));
            };
            let (nx, ny) = (x as i64 + DX[d], y as i64 + DY[d]);
            if nx >= 0 && ny >= 0 && nx < w as i64 && ny < h as i64 {
                let m = ny as usize * w + nx as usize;
                if codes[m] == NODATA_DIR {
                    break Res::Term(gidx(c));
                }
                c = m;
            } else {
                let t = v.at(nx, ny);
                if t.is_nan() || t == NODATA_DIR as f32 {
                    break Res::Term(gidx(c));
                }
                break Res::Leave(c as u32);
            }
        };
        for &p in &path {
            res[p] = r;
            on_path[p] = false;
        }
        path.clear();
        if res[s] == Res::Unknown {
            res[s] = r;
        }
    }
    Ok(Resolved { w, h, res, codes })
}

impl GlobalStep for TiledLabels {
    type In = f32;
    type Out = u32;
    type Summary = LabelSummary;
    type Solution = LabelSolution;
    type Slice = Vec<u32>;

    fn name(&self) -> String {
        "watershed-labels".into()
    }
    fn params(&self) -> serde_json::Value {
        serde_json::json!({"algorithm": "outlet labels along D8 paths (label = row-major index of the terminal cell + 1)"})
    }
    fn halo(&self) -> usize {
        1
    }

    fn outputs(&self) -> Vec<OutputSpec> {
        vec![OutputSpec::categorical(DType::U32, 0.0)]
    }
    fn map(&self, inputs: &[TileView<f32>]) -> Result<LabelSummary> {
        let v = inputs
            .first()
            .ok_or_else(|| Error::invalid("labels need the flow directions as input"))?;
        let r = resolve(v)?;
        let (w, h) = (r.w, r.h);
        let perimeter = perimeter_cells(w, h)
            .map(|(x, y)| {
                let c = y * w + x;
                match r.res[c] {
                    Res::Nodata | Res::Unknown => LabelLink::Nodata,
                    Res::Term(g) => LabelLink::Term(g),
                    Res::Leave(l) if l as usize == c => {
                        let d = code_to_dir(r.codes[c]).unwrap_or(0);
                        LabelLink::Cross(
                            (v.core.x + x as i64 + DX[d]) as u64,
                            (v.core.y + y as i64 + DY[d]) as u64,
                        )
                    }
                    Res::Leave(l) => {
                        let l = l as usize;
                        let k = perimeter_index(w, h, l % w, l / w).unwrap_or(0);
                        LabelLink::Via(k as u32)
                    }
                }
            })
            .collect();
        Ok(LabelSummary { w, h, perimeter })
    }

    fn reduce(&self, layout: &TileLayout, summaries: Vec<LabelSummary>) -> Result<LabelSolution> {
        if summaries.len() != layout.count() {
            return Err(Error::invalid(format!(
                "labels reduce: {} summaries for {} tiles",
                summaries.len(),
                layout.count()
            )));
        }
        let cells = (layout.width as u64) * (layout.height as u64);
        if cells > u32::MAX as u64 {
            return Err(Error::invalid(format!(
                "{}x{} cells: watershed labels need fewer than 2^32 cells",
                layout.width, layout.height
            )));
        }
        let mut offsets = Vec::with_capacity(summaries.len() + 1);
        let mut total = 0usize;
        for (t, s) in summaries.iter().enumerate() {
            let win = layout.window(t);
            if s.w != win.w || s.h != win.h || s.perimeter.len() != perimeter_len(s.w, s.h) {
                return Err(Error::invalid(format!(
                    "labels reduce: summary of tile {t} does not match the layout"
                )));
            }
            offsets.push(total);
            total += s.perimeter.len();
        }
        offsets.push(total);
        let corrupt = |t: usize| Error::invalid(format!("labels reduce: bad link in tile {t}"));
        const NONE: usize = usize::MAX;
        // next node, or NONE with a terminal label in `label`
        let mut next = vec![NONE; total];
        let mut label = vec![0u32; total];
        for (t, s) in summaries.iter().enumerate() {
            for (k, &link) in s.perimeter.iter().enumerate() {
                let u = offsets[t] + k;
                match link {
                    LabelLink::Nodata => {}
                    LabelLink::Term(g) => {
                        if g >= cells {
                            return Err(corrupt(t));
                        }
                        label[u] = g as u32 + 1;
                    }
                    LabelLink::Via(j) => {
                        if j as usize >= s.perimeter.len() || j as usize == k {
                            return Err(corrupt(t));
                        }
                        next[u] = offsets[t] + j as usize;
                    }
                    LabelLink::Cross(gx, gy) => {
                        if gx >= layout.width as u64 || gy >= layout.height as u64 {
                            return Err(corrupt(t));
                        }
                        let (gx, gy) = (gx as usize, gy as usize);
                        let tb = layout.id(gx / layout.tile, gy / layout.tile);
                        let win = layout.window(tb);
                        let j =
                            perimeter_index(win.w, win.h, gx - win.x as usize, gy - win.y as usize)
                                .ok_or_else(|| corrupt(t))?;
                        if tb == t || summaries[tb].perimeter[j] == LabelLink::Nodata {
                            return Err(corrupt(t));
                        }
                        next[u] = offsets[tb] + j;
                    }
                }
            }
        }
        // memoised path following over the perimeter graph
        let mut state = vec![0u8; total];
        let mut path = Vec::new();
        for s in 0..total {
            if state[s] == 2 {
                continue;
            }
            let mut u = s;
            let l = loop {
                if state[u] == 2 {
                    break label[u];
                }
                if state[u] == 1 {
                    return Err(Error::invalid(
                        "flow directions contain a cycle across tiles; directions must come from a D8 routing of one DEM",
                    ));
                }
                state[u] = 1;
                path.push(u);
                if next[u] == NONE {
                    break label[u];
                }
                u = next[u];
            };
            for &p in &path {
                label[p] = l;
                state[p] = 2;
            }
            path.clear();
        }
        Ok(LabelSolution { offsets, label })
    }

    fn slice(&self, sol: &LabelSolution, id: TileId) -> Vec<u32> {
        sol.label[sol.offsets[id]..sol.offsets[id + 1]].to_vec()
    }

    fn apply(
        &self,
        inputs: &[TileView<f32>],
        slice: &Vec<u32>,
        out: &mut [Grid<u32>],
    ) -> Result<()> {
        let v = inputs
            .first()
            .ok_or_else(|| Error::invalid("labels need the flow directions as input"))?;
        let r = resolve(v)?;
        let (w, h) = (r.w, r.h);
        if slice.len() != perimeter_len(w, h) {
            return Err(Error::invalid(
                "labels apply: slice does not belong to this tile",
            ));
        }
        let o = out
            .first_mut()
            .ok_or_else(|| Error::invalid("labels apply: no output grid"))?;
        for (c, cell) in o.data_mut().iter_mut().enumerate() {
            *cell = match r.res[c] {
                Res::Nodata | Res::Unknown => 0,
                Res::Term(g) => u32::try_from(g + 1)
                    .map_err(|_| Error::invalid("watershed labels need fewer than 2^32 cells"))?,
                Res::Leave(l) => {
                    let l = l as usize;
                    let k = perimeter_index(w, h, l % w, l / w)
                        .ok_or_else(|| Error::invalid("labels apply: inconsistent tile"))?;
                    slice[k]
                }
            };
        }
        Ok(())
    }
}
