//! Pass 1 of the tiled divide tree ([`PlateauStep`]): flat pieces on the
//! tile perimeters labelled by their first cell, joined across seams into
//! global region representatives.

use super::super::regions::neighbours_in;
use super::bits;
use super::check_finite;
use super::first_view;
use super::NONE;
use crate::error::Error;
use crate::error::Result;
use crate::exec::GlobalStep;
use crate::raster::perimeter_cells;
use crate::raster::perimeter_index;
use crate::raster::perimeter_len;
use crate::raster::Grid;
use crate::raster::TileId;
use crate::raster::TileLayout;
use crate::raster::TileView;
use crate::raster::UnionFind;
use serde::Deserialize;
use serde::Serialize;

/// Pass 1: the global representative (first cell in row-major order) of
/// every region touching a tile perimeter. See the module docs.
#[derive(Debug, Clone, Copy, Default)]
pub struct PlateauStep;

/// Per-tile summary of [`PlateauStep`]: O(perimeter).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct PlateauSummary {
    pub w: usize,
    pub h: usize,
    /// Piece index of each perimeter cell (row-major perimeter order),
    /// `u32::MAX` for nodata.
    pub piece: Vec<u32>,
    /// Elevation of each perimeter cell (0 for nodata).
    #[serde(with = "bits::f32vec")]
    pub z: Vec<f32>,
    /// Global id (y·W + x) of each piece's first cell.
    pub first: Vec<u64>,
}

/// Reduced [`PlateauStep`]: per tile, the global region id of each
/// perimeter cell (`u64::MAX` for nodata).
#[derive(Debug, Clone, Default)]
pub struct PlateauSolution {
    pub perimeter_id: Vec<Vec<u64>>,
}

impl GlobalStep for PlateauStep {
    type In = f32;
    type Out = f32;
    type Summary = PlateauSummary;
    type Solution = PlateauSolution;
    type Slice = Vec<u64>;

    fn name(&self) -> String {
        "divide tree (plateaus)".into()
    }
    fn params(&self) -> serde_json::Value {
        serde_json::json!({})
    }
    fn halo(&self) -> usize {
        0
    }
    fn outputs(&self) -> Vec<crate::exec::output::OutputSpec> {
        Vec::new()
    }

    fn map(&self, inputs: &[TileView<f32>]) -> Result<PlateauSummary> {
        let v = first_view(inputs, "divide tree")?;
        let (w, h) = (v.core.w, v.core.h);
        let rw = v.raster_width as u64;
        let mut label = vec![NONE; w * h];
        let mut piece = Vec::with_capacity(perimeter_len(w, h));
        let mut zs = Vec::with_capacity(perimeter_len(w, h));
        let mut first = Vec::new();
        let mut queue: Vec<usize> = Vec::new();
        for (x, y) in perimeter_cells(w, h) {
            let z = v.at(x as i64, y as i64);
            if z.is_nan() {
                piece.push(NONE);
                zs.push(0.0);
                continue;
            }
            check_finite(z, v.core.x + x as i64, v.core.y + y as i64)?;
            let s = y * w + x;
            if label[s] == NONE {
                let id = first.len() as u32;
                label[s] = id;
                queue.clear();
                queue.push(s);
                let mut min = s;
                let mut head = 0;
                while head < queue.len() {
                    let c = queue[head];
                    head += 1;
                    min = min.min(c);
                    for (n, nx, ny) in neighbours_in(w, h, c) {
                        if label[n] == NONE && v.at(nx, ny) == z {
                            label[n] = id;
                            queue.push(n);
                        }
                    }
                }
                let (mx, my) = ((min % w) as i64 + v.core.x, (min / w) as i64 + v.core.y);
                first.push(my as u64 * rw + mx as u64);
            }
            piece.push(label[s]);
            zs.push(z);
        }
        Ok(PlateauSummary {
            w,
            h,
            piece,
            z: zs,
            first,
        })
    }

    fn reduce(
        &self,
        layout: &TileLayout,
        summaries: Vec<PlateauSummary>,
    ) -> Result<PlateauSolution> {
        if summaries.len() != layout.count() {
            return Err(Error::invalid(format!(
                "divide tree (plateaus): {} summaries for {} tiles",
                summaries.len(),
                layout.count()
            )));
        }
        let mut offset = Vec::with_capacity(summaries.len() + 1);
        let mut total = 0usize;
        for (t, s) in summaries.iter().enumerate() {
            let win = layout.window(t);
            if s.w != win.w
                || s.h != win.h
                || s.piece.len() != perimeter_len(s.w, s.h)
                || s.z.len() != s.piece.len()
                || s.piece
                    .iter()
                    .any(|&p| p != NONE && p as usize >= s.first.len())
            {
                return Err(Error::invalid(format!(
                    "divide tree (plateaus): summary of tile {t} does not match the layout"
                )));
            }
            offset.push(total);
            total += s.first.len();
        }
        let mut uf = UnionFind::<usize>::new(total);
        crate::raster::cross_tile_pairs(layout, |ta, (xa, ya), tb, (xb, yb)| {
            let sa = &summaries[ta];
            let sb = &summaries[tb];
            let (Some(ka), Some(kb)) = (
                perimeter_index(sa.w, sa.h, xa, ya),
                perimeter_index(sb.w, sb.h, xb, yb),
            ) else {
                return;
            };
            let (pa, pb) = (sa.piece[ka], sb.piece[kb]);
            if pa == NONE || pb == NONE || sa.z[ka] != sb.z[kb] {
                return;
            }
            let a = uf.find(offset[ta] + pa as usize);
            let b = uf.find(offset[tb] + pb as usize);
            uf.union_min(a, b);
        });
        let mut rep = vec![u64::MAX; total];
        for (t, s) in summaries.iter().enumerate() {
            for (p, &f) in s.first.iter().enumerate() {
                let r = uf.find(offset[t] + p);
                rep[r] = rep[r].min(f);
            }
        }
        let mut perimeter_id = Vec::with_capacity(summaries.len());
        for (t, s) in summaries.iter().enumerate() {
            let ids = s
                .piece
                .iter()
                .map(|&p| {
                    if p == NONE {
                        u64::MAX
                    } else {
                        rep[uf.find(offset[t] + p as usize)]
                    }
                })
                .collect();
            perimeter_id.push(ids);
        }
        Ok(PlateauSolution { perimeter_id })
    }

    fn slice(&self, solution: &PlateauSolution, id: TileId) -> Vec<u64> {
        solution.perimeter_id.get(id).cloned().unwrap_or_default()
    }

    fn apply(&self, _: &[TileView<f32>], _: &Vec<u64>, _: &mut [Grid<f32>]) -> Result<()> {
        Err(Error::invalid(
            "divide tree (plateaus) writes no raster; run it without outputs",
        ))
    }
}
