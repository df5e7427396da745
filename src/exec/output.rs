//! What a step writes: each output's [`OutputSpec`] (cell type, nodata
//! rule, kind), declared by the step ([`super::LocalStep::outputs`],
//! [`super::GlobalStep::outputs`]) and resolved by the plan
//! ([`super::plan`]) into sinks, so no caller builds `(dtype, nodata)`
//! pairs. The kind ([`OutputKind`]: continuous, categorical, angle) picks
//! how a Cloud-Optimized GeoTIFF's overviews are made when the user did not
//! choose (nearest for codes and angles, the mean otherwise) and is recorded
//! in a tile store's provenance.
//!
//! The nodata rules ([`NodataRule`]) that depend on the data are resolved
//! on input 0 at plan time, each at most once per run:
//!
//! **Elevation outputs** (filled or breached DEMs, [`NodataRule::BelowInput`]):
//! a nodata value that cannot collide with a real elevation.
//! Hydrological steps write f32 DEMs with nodata [`FILL_NODATA`]
//! (−9999, gdal's and ESRI's habit). Bathymetry reaches −10 994 m (Challenger
//! Deep), so a DEM without nodata may hold −9999 as a real value; written
//! as is, that cell would read back as nodata. Floats could use NaN, but a
//! tile store's JSON manifest cannot hold NaN or ±inf, so the value stays
//! finite: −9999 when every valid input cell is above −9999 + margin (the
//! common case: outputs unchanged), else the first of a few customary
//! values below the data (−99 999, −999 999, −f32::MAX); NaN only when the
//! data reach −f32::MAX itself (then a store's manifest records no nodata,
//! which for f32 tiles means the same: NaN cells are nodata).
//!
//! The steps that write these outputs only raise cells (fill) or lower them
//! towards a real lower cell (breach: paths descend to an outlet), so a
//! value below the input minimum, with a margin for epsilon gradients,
//! stays below every output value.
//!
//! **Outputs in the DEM's unit that may be differences** (window means,
//! TPI, relief, [`NodataRule::BelowDifference`]): values lie in
//! `[min(lo, lo − hi), hi − lo]` for valid input cells in `[lo, hi]`, so
//! the nodata is the first candidate below `min(lo, lo − hi)`
//! ([`difference_nodata`]).

use crate::error::Result;
use crate::raster::{read_window, DType, RasterSource, Window};

pub use crate::raster::OutputKind;

/// How an output's nodata value is chosen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum NodataRule {
    /// This value.
    Value(f64),
    /// No nodata value (every cell is data; NaN cells of floats still read
    /// as nodata).
    None,
    /// Below every valid elevation of input 0: [`elevation_nodata`].
    BelowInput,
    /// Below every difference of two valid cells of input 0 and below its
    /// lowest cell: [`difference_nodata`].
    BelowDifference,
    /// Input 0's declared nodata, for a step that only raises the cells of
    /// an elevation output already written with a [`NodataRule::BelowInput`]
    /// nodata (fill-epsilon on the filled DEM): the value chosen for the
    /// original DEM stays below the data, and no read pass is needed.
    /// [`NodataRule::BelowInput`] when input 0 declares none.
    OfRaisedInput,
}

/// One output of a step: its cell type on disk, nodata rule and kind.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OutputSpec {
    /// Cell type the output is written as.
    pub dtype: DType,
    /// How its nodata value is chosen.
    pub nodata: NodataRule,
    /// What its values are.
    pub kind: OutputKind,
}

impl OutputSpec {
    /// A continuous output of `dtype` with nodata `nodata`.
    pub const fn continuous(dtype: DType, nodata: f64) -> OutputSpec {
        OutputSpec {
            dtype,
            nodata: NodataRule::Value(nodata),
            kind: OutputKind::Continuous,
        }
    }

    /// A categorical output (codes, labels) of `dtype` with nodata `nodata`.
    pub const fn categorical(dtype: DType, nodata: f64) -> OutputSpec {
        OutputSpec {
            dtype,
            nodata: NodataRule::Value(nodata),
            kind: OutputKind::Categorical,
        }
    }

    /// An f32 elevation output whose nodata lies below input 0's data
    /// ([`NodataRule::BelowInput`]): filled and breached DEMs.
    pub const fn elevation() -> OutputSpec {
        OutputSpec {
            dtype: DType::F32,
            nodata: NodataRule::BelowInput,
            kind: OutputKind::Continuous,
        }
    }

    /// This spec with nodata rule `nodata`.
    pub const fn with_nodata(self, nodata: NodataRule) -> OutputSpec {
        OutputSpec { nodata, ..self }
    }

    /// This spec of kind `kind`.
    pub const fn with_kind(self, kind: OutputKind) -> OutputSpec {
        OutputSpec { kind, ..self }
    }
}

/// The nodata value of each of `specs` for a run on `src` (input 0): the
/// data-dependent rules read `src` once each, however many outputs use them.
pub fn resolve_nodata(specs: &[OutputSpec], src: &dyn RasterSource) -> Result<Vec<Option<f64>>> {
    let (mut below_input, mut below_difference) = (None, None);
    let mut out = Vec::with_capacity(specs.len());
    for s in specs {
        out.push(match s.nodata {
            NodataRule::Value(v) => Some(v),
            NodataRule::None => None,
            NodataRule::BelowInput => Some(match below_input {
                Some(v) => v,
                None => *below_input.insert(elevation_nodata(src)?),
            }),
            NodataRule::OfRaisedInput => match src.info().georef.nodata {
                Some(v) => Some(v),
                None => Some(match below_input {
                    Some(v) => v,
                    None => *below_input.insert(elevation_nodata(src)?),
                }),
            },
            NodataRule::BelowDifference => Some(match below_difference {
                Some(v) => v,
                None => *below_difference.insert(difference_nodata(src)?),
            }),
        });
    }
    Ok(out)
}

/// Nodata value written for filled DEMs (f32 outputs): below any real elevation.
pub const FILL_NODATA: f64 = -9999.0;

/// Output nodata values tried in order: the first one more than
/// [`MARGIN`] below every valid input elevation is used.
pub const CANDIDATES: [f64; 4] = [FILL_NODATA, -99_999.0, -999_999.0, -(f32::MAX as f64)];

/// Distance (m) a candidate must keep below the lowest valid cell: room for
/// the small gradients fill-epsilon and breaching add.
pub const MARGIN: f64 = 1.0;

/// Cells read per window of the scan (4 Mi cells: 16 MiB as f32).
const SCAN_CELLS: usize = 1 << 22;

/// The nodata for an f32 elevation output computed from `src`: see the
/// module documentation. Reads `src` once (in block-aligned windows of at
/// most [`SCAN_CELLS`] cells) unless its type cannot go below −9999.
pub fn elevation_nodata(src: &dyn RasterSource) -> Result<f64> {
    let info = src.info();
    if matches!(info.dtype, DType::U8 | DType::U16 | DType::U32 | DType::I8) {
        return Ok(FILL_NODATA);
    }
    Ok(below(lowest_valid(src)?).unwrap_or(f64::NAN))
}

/// The nodata for an f32 output in `src`'s unit whose values may be
/// differences of two cells (see the module documentation): [`FILL_NODATA`]
/// unless `min(lo, lo − hi)` of the valid range comes within [`MARGIN`] of
/// it, then the next of [`CANDIDATES`]; NaN past them all. One read pass,
/// unless `src`'s type cannot reach −9999 (u8, i8).
pub fn difference_nodata(src: &dyn RasterSource) -> Result<f64> {
    if matches!(src.info().dtype, DType::U8 | DType::I8) {
        return Ok(FILL_NODATA);
    }
    let bound = valid_range(src)?.map(|(lo, hi)| (lo as f64).min(lo as f64 - hi as f64) as f32);
    Ok(below(bound).unwrap_or(f64::NAN))
}

/// The first of [`CANDIDATES`] more than [`MARGIN`] below `min` (the
/// lowest valid elevation; `None` when there is none).
pub fn below(min: Option<f32>) -> Option<f64> {
    let Some(m) = min else {
        return Some(FILL_NODATA);
    };
    CANDIDATES
        .iter()
        .copied()
        .find(|&c| c < m as f64 - MARGIN || (c == -(f32::MAX as f64) && c < m as f64))
}

/// The lowest valid (finite as f32, not the declared nodata) cell of `src`.
fn lowest_valid(src: &dyn RasterSource) -> Result<Option<f32>> {
    Ok(valid_range(src)?.map(|r| r.0))
}

/// The lowest and highest valid (finite as f32, not the declared nodata)
/// cells of `src`, from one read pass in block-aligned windows of at most
/// [`SCAN_CELLS`] cells; `None` when no cell is valid.
pub fn valid_range(src: &dyn RasterSource) -> Result<Option<(f32, f32)>> {
    let info = src.info();
    let (w, h) = (info.width, info.height);
    if w == 0 || h == 0 {
        return Ok(None);
    }
    // Whole rows for striped files (a strip is decoded once), tiles of a
    // multiple of the block otherwise.
    let (bw, bh) = (info.block.0.max(1), info.block.1.max(1));
    let (ww, wh) = if bw >= w {
        let rows = (SCAN_CELLS / w).max(1);
        (w, (rows / bh).max(1) * bh)
    } else {
        let side = ((SCAN_CELLS as f64).sqrt() as usize).max(1);
        ((side / bw).max(1) * bw, (side / bh).max(1) * bh)
    };
    let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
    let mut y = 0;
    while y < h {
        let hh = wh.min(h - y);
        let mut x = 0;
        while x < w {
            let cw = ww.min(w - x);
            // read_window turns the declared nodata into NaN.
            let g = read_window::<f32>(src, Window::new(x as i64, y as i64, cw, hh))?;
            for &v in g.data() {
                if v.is_finite() {
                    lo = lo.min(v);
                    hi = hi.max(v);
                }
            }
            x += cw;
        }
        y += hh;
    }
    Ok(lo.is_finite().then_some((lo, hi)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster::{GeoRef, Grid, MemRaster};

    #[test]
    fn candidates_below_the_data() {
        assert_eq!(below(None), Some(-9999.0));
        assert_eq!(below(Some(0.0)), Some(-9999.0));
        assert_eq!(below(Some(-9997.5)), Some(-9999.0));
        assert_eq!(below(Some(-9998.5)), Some(-99_999.0));
        assert_eq!(below(Some(-9999.0)), Some(-99_999.0));
        assert_eq!(below(Some(-10_994.0)), Some(-99_999.0));
        assert_eq!(below(Some(-500_000.0)), Some(-999_999.0));
        assert_eq!(below(Some(-1e30)), Some(-(f32::MAX as f64)));
        assert_eq!(below(Some(-f32::MAX)), None);
    }

    fn mem(g: Grid<f32>, nodata: Option<f64>) -> MemRaster {
        MemRaster::from_grid(g, GeoRef::pixel().with_nodata(nodata))
    }

    #[test]
    fn scans_every_cell_and_skips_nodata_and_non_finite() {
        // 3000 x 1500: several scan windows; the minimum sits in the last.
        let mut g = Grid::from_fn(3000, 1500, |x, y| (x + y) as f32);
        g.set(2999, 1499, -10_500.0);
        assert_eq!(elevation_nodata(&mem(g.clone(), None)).unwrap(), -99_999.0);
        // The same cell as declared nodata is not data.
        g.set(2999, 1499, -20_000.0);
        assert_eq!(
            elevation_nodata(&mem(g.clone(), Some(-20_000.0))).unwrap(),
            -9999.0
        );
        g.set(0, 0, f32::NEG_INFINITY);
        g.set(1, 0, f32::NAN);
        assert_eq!(
            elevation_nodata(&mem(g.clone(), Some(-20_000.0))).unwrap(),
            -9999.0
        );
        g.set(5, 5, -f32::MAX);
        assert!(elevation_nodata(&mem(g, None)).unwrap().is_nan());
    }

    #[test]
    fn rules_resolve_on_the_input() {
        // Valid cells in [-5000, 6000]: every elevation is above -9999 + 1,
        // but a difference of two cells reaches -11 000.
        let mut g = Grid::from_fn(40, 30, |x, y| (x * 100 + y) as f32);
        g.set(3, 4, -5000.0);
        g.set(5, 6, 6000.0);
        let src = mem(g, None);
        let specs = [
            OutputSpec::elevation(),
            OutputSpec::categorical(DType::U8, 255.0),
            OutputSpec {
                dtype: DType::F32,
                nodata: NodataRule::BelowDifference,
                kind: OutputKind::Continuous,
            },
            OutputSpec {
                dtype: DType::F64,
                nodata: NodataRule::None,
                kind: OutputKind::Angle,
            },
            OutputSpec::elevation(),
        ];
        assert_eq!(
            resolve_nodata(&specs, &src).unwrap(),
            [
                Some(-9999.0),
                Some(255.0),
                Some(-99_999.0),
                None,
                Some(-9999.0)
            ]
        );
        assert_eq!(difference_nodata(&src).unwrap(), -99_999.0);
        // A raised elevation output keeps the declared nodata of its input
        // (a filled DEM whose -99 999 was chosen below an original -10 994
        // m, while the filled cells themselves all lie above -9999).
        let raised = [OutputSpec::elevation().with_nodata(NodataRule::OfRaisedInput)];
        let filled = Grid::from_fn(8, 8, |x, y| (x + y) as f32 - 9000.0);
        assert_eq!(
            resolve_nodata(&raised, &mem(filled.clone(), Some(-99_999.0))).unwrap(),
            [Some(-99_999.0)]
        );
        assert_eq!(
            resolve_nodata(&raised, &mem(filled, None)).unwrap(),
            [Some(-9999.0)]
        );
        // Byte inputs are never scanned: nothing they hold reaches -9999.
        let b = MemRaster::from_grid(Grid::new(4, 4, 7u8), GeoRef::pixel());
        assert_eq!(difference_nodata(&b).unwrap(), -9999.0);
    }
}
