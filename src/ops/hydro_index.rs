//! `orogen hydro-index`: hydrological indices ([`crate::hydro::indices`]):
//! twi, spi, sti, ls (tile by tile), hand (exact across tiles), dtw (depth to
//! water) and branch-length (maximum branch length), in memory.

use super::hydro_io::{full, guard, open_path, read_dirs, same_size, write_mem};
use super::Target;
use crate::error::{Error, Result};
use crate::exec::EngineConfig;
use crate::hydro::basins::{Seeds, TiledDownstream};
use crate::hydro::indices::{self, IndexKind, INDEX_NODATA};
use crate::raster::{read_window, DType, GeoRef, Grid, MemRaster, RasterSource};
use std::path::PathBuf;

/// Options of `orogen hydro-index`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct HydroIndexOptions {
    /// Index: twi, spi, sti, ls, hand, dtw, branch-length.
    pub index: String,
    /// DEM (filled): twi, spi, sti, ls, hand, dtw.
    pub dem: Option<PathBuf>,
    /// Flow accumulation in cells: twi, spi, sti, ls; default streams for hand/dtw.
    pub acc: Option<PathBuf>,
    /// D8 directions: hand, branch-length.
    pub dirs: Option<PathBuf>,
    /// Stream raster for hand/dtw (cells >= `threshold` are streams).
    pub streams: Option<PathBuf>,
    /// Stream threshold on `streams` (or `acc`).
    pub threshold: f64,
    /// Smallest slope (tan) in twi/sti/ls, avoiding division by zero.
    pub min_slope: f64,
}

impl Default for HydroIndexOptions {
    fn default() -> Self {
        HydroIndexOptions {
            index: String::new(),
            dem: None,
            acc: None,
            dirs: None,
            streams: None,
            threshold: 1000.0,
            min_slope: 1e-4,
        }
    }
}

/// Open the input `flag` that `index` needs.
fn need(p: &Option<PathBuf>, flag: &str, index: &str) -> Result<Box<dyn RasterSource>> {
    match p {
        Some(p) => open_path(p),
        None => Err(Error::invalid(format!("--index {index} needs {flag}"))),
    }
}

/// Compute the index of `opts` into `target` (f32, nodata -9999).
pub fn run(opts: &HydroIndexOptions, target: &Target, cfg: &EngineConfig) -> Result<()> {
    let a = opts;
    let local = match a.index.as_str() {
        "twi" => Some(IndexKind::Twi),
        "spi" => Some(IndexKind::Spi),
        "sti" => Some(IndexKind::Sti),
        "ls" => Some(IndexKind::Ls),
        "hand" | "dtw" | "branch-length" => None,
        i => {
            return Err(Error::invalid(format!(
                "--index {i:?}: use twi, spi, sti, ls, hand, dtw or branch-length"
            )))
        }
    };
    if !(a.threshold.is_finite()) {
        return Err(Error::invalid("--threshold must be a number"));
    }
    if let Some(kind) = local {
        if !(a.min_slope.is_finite() && a.min_slope > 0.0) {
            return Err(Error::invalid("--min-slope must be a positive number"));
        }
        let dem = need(&a.dem, "--dem", &a.index)?;
        let acc = need(&a.acc, "--acc", &a.index)?;
        same_size(dem.as_ref(), acc.as_ref())?;
        let step = indices::HydroIndex {
            kind,
            min_slope: a.min_slope,
        };
        return target.run_local(&step, &[dem.as_ref(), acc.as_ref()], cfg);
    }
    let streams_path = a.streams.clone().or_else(|| a.acc.clone());
    match a.index.as_str() {
        "hand" => {
            let dirs = need(&a.dirs, "--dirs", "hand")?;
            let dem = need(&a.dem, "--dem", "hand")?;
            let st = need(&streams_path, "--streams or --acc", "hand")?;
            same_size(dirs.as_ref(), dem.as_ref())?;
            same_size(dirs.as_ref(), st.as_ref())?;
            let step = TiledDownstream {
                seeds: Seeds::Streams {
                    threshold: a.threshold,
                },
                labels: DType::F32,
            };
            target.run_global(&step, &[dirs.as_ref(), dem.as_ref(), st.as_ref()], cfg)
        }
        "dtw" => {
            let dem = need(&a.dem, "--dem", "dtw")?;
            let st = need(&streams_path, "--streams or --acc", "dtw")?;
            same_size(dem.as_ref(), st.as_ref())?;
            guard(
                dem.as_ref(),
                indices::DTW_BYTES_PER_CELL,
                "depth to water",
                cfg,
            )?;
            let z = read_window::<f32>(dem.as_ref(), full(dem.as_ref()))?;
            let s = read_window::<f64>(st.as_ref(), full(st.as_ref()))?;
            let mask = s.map(|v| v >= a.threshold);
            let georef = dem.info().georef.clone();
            let g = indices::depth_to_water(&z, &mask, &georef)?;
            write_f32(g, georef, target, cfg)
        }
        _ => {
            let dirs = need(&a.dirs, "--dirs", "branch-length")?;
            guard(
                dirs.as_ref(),
                indices::BRANCH_BYTES_PER_CELL,
                "branch length",
                cfg,
            )?;
            let d = read_dirs(dirs.as_ref())?;
            let georef = dirs.info().georef.clone();
            let g = indices::max_branch_length(&d, &georef)?;
            write_f32(g, georef, target, cfg)
        }
    }
}

fn write_f32(g: Grid<f32>, georef: GeoRef, target: &Target, cfg: &EngineConfig) -> Result<()> {
    let nd = INDEX_NODATA as f32;
    let g = g.map(|v| if v.is_nan() { nd } else { v });
    let mem = MemRaster::from_grid(g, georef);
    write_mem(
        mem,
        &target.path,
        &target.options,
        target.tile,
        cfg,
        (DType::F32, Some(INDEX_NODATA)),
    )
}
