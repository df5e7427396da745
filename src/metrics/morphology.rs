//! Grey-level morphology over square windows: local relief (max − min) and
//! the white and black top-hats (height above the opening, depth below the
//! closing). Nodata cells are excluded from the windows.
//!
//! Sources: running max/min of van Herk 1992 (Pattern Recognition Letters
//! 13(7)) and Gil & Werman 1993 (IEEE PAMI 15(5)), in [`super::windowed`];
//! top-hats, Serra 1982, *Image Analysis and Mathematical Morphology*.

use super::param::RADIUS;
use super::registry::{metric_def, Metric, MetricDef, MetricKind, ScratchClass};
use super::spec::Resolved;
use super::tile::{region, region_cells, Tile};
use super::windowed::{open_close, running_max};
use crate::error::Result;
use crate::raster::{Grid, TileView};

/// Local relief.
pub struct Relief(MetricDef);

impl Metric for Relief {
    fn def(&self) -> &MetricDef {
        &self.0
    }
    fn halo(&self, m: &Resolved) -> usize {
        m.radius_cells
    }
    fn scratch(&self, m: &Resolved, tile: usize) -> Option<(ScratchClass, u64)> {
        let r = m.radius_cells;
        Some((
            ("relief", 0),
            region_cells(tile, r) * 8 + (tile + 2 * r) as u64 * tile as u64 * 16,
        ))
    }
    fn run(&self, t: &mut Tile<'_>, m: &Resolved, o: &mut Grid<f32>) -> Result<()> {
        let view = t.view;
        relief(view, m.radius_cells, o, &mut t.g1, &mut t.g2);
        Ok(())
    }
}

/// White or black top-hat.
pub struct TopHat(MetricDef);

impl Metric for TopHat {
    fn def(&self) -> &MetricDef {
        &self.0
    }
    fn halo(&self, m: &Resolved) -> usize {
        // Two passes of the window.
        2 * m.radius_cells
    }
    fn scratch(&self, m: &Resolved, tile: usize) -> Option<(ScratchClass, u64)> {
        // region, flipped copy, first pass, running lines
        Some((
            ("tophat", 0),
            region_cells(tile, 2 * m.radius_cells) * 8 * 4,
        ))
    }
    fn run(&self, t: &mut Tile<'_>, m: &Resolved, o: &mut Grid<f32>) -> Result<()> {
        let view = t.view;
        let cw = view.core.w;
        let nan = f32::NAN;
        let r = m.radius_cells;
        let vals = region(view, 2 * r);
        let w = view.core.w + 4 * r;
        let white = self.0.kind == MetricKind::TopHatWhite;
        let oc = open_close(&vals, w, view.core.h + 4 * r, r, !white);
        for (i, (o, v)) in o.data_mut().iter_mut().zip(&oc).enumerate() {
            let z = vals[(i / cw + 2 * r) * w + i % cw + 2 * r];
            *o = if z.is_nan() {
                nan
            } else if white {
                (z - v) as f32
            } else {
                (v - z) as f32
            };
        }
        Ok(())
    }
}

/// `relief`: local relief: max - min of valid cells in the square window.
///
/// Source: van Herk 1992 / Gil & Werman 1993 running max/min.
pub static RELIEF: Relief = Relief(metric_def!(
    Relief,
    "relief",
    &[RADIUS],
    "z",
    "local relief: max - min of valid cells in the square window",
    "van Herk 1992 / Gil & Werman 1993 running max/min"
));

/// `tophat_white`: white top-hat z - opening (square window): height above the local 'floor'.
///
/// Source: grey-level morphology, Serra 1982; van Herk/Gil-Werman max/min.
pub static TOP_HAT_WHITE: TopHat = TopHat(metric_def!(
    TopHatWhite,
    "tophat_white",
    &[RADIUS],
    "z",
    "white top-hat z - opening (square window): height above the local 'floor'",
    "grey-level morphology, Serra 1982; van Herk/Gil-Werman max/min"
));

/// `tophat_black`: black top-hat closing - z (square window): depth below the local 'lid'.
///
/// Source: grey-level morphology, Serra 1982; van Herk/Gil-Werman max/min.
pub static TOP_HAT_BLACK: TopHat = TopHat(metric_def!(
    TopHatBlack,
    "tophat_black",
    &[RADIUS],
    "z",
    "black top-hat closing - z (square window): depth below the local 'lid'",
    "grey-level morphology, Serra 1982; van Herk/Gil-Werman max/min"
));

/// Local relief (max − min over the square window of half-side `r`, valid
/// cells only) by separable van Herk / Gil-Werman running max and min.
fn relief(view: &TileView<f32>, r: usize, o: &mut Grid<f32>, g1: &mut Vec<f64>, g2: &mut Vec<f64>) {
    let (cw, ch) = (view.core.w, view.core.h);
    let vals = region(view, r);
    let w = cw + 2 * r;
    let rows = ch + 2 * r;
    // Horizontal pass: for every region row, max and min over columns.
    let mut hmax = vec![0.0; rows * cw];
    let mut hmin = vec![0.0; rows * cw];
    let mut line = vec![0.0; w];
    let mut res = vec![0.0; w];
    for y in 0..rows {
        let row = &vals[y * w..(y + 1) * w];
        for (l, &z) in line.iter_mut().zip(row) {
            *l = if z.is_nan() { f64::NEG_INFINITY } else { z };
        }
        running_max(&line, r, &mut res, g1, g2);
        hmax[y * cw..(y + 1) * cw].copy_from_slice(&res[r..r + cw]);
        for (l, &z) in line.iter_mut().zip(row) {
            *l = if z.is_nan() { f64::NEG_INFINITY } else { -z };
        }
        running_max(&line, r, &mut res, g1, g2);
        for (d, s) in hmin[y * cw..(y + 1) * cw].iter_mut().zip(&res[r..r + cw]) {
            *d = -s;
        }
    }
    // Vertical pass per core column.
    let mut col = vec![0.0; rows];
    let mut cmax = vec![0.0; rows];
    let mut cmin = vec![0.0; rows];
    for x in 0..cw {
        for (y, c) in col.iter_mut().enumerate() {
            *c = hmax[y * cw + x];
        }
        running_max(&col, r, &mut cmax, g1, g2);
        for (y, c) in col.iter_mut().enumerate() {
            // −(+∞) from an all-nodata row stays −∞ for the max of negatives.
            *c = -hmin[y * cw + x];
        }
        running_max(&col, r, &mut cmin, g1, g2);
        for y in 0..ch {
            let z = vals[(y + r) * w + x + r];
            let v = if z.is_nan() {
                f32::NAN
            } else {
                (cmax[y + r] + cmin[y + r]) as f32
            };
            o.set(x, y, v);
        }
    }
}
