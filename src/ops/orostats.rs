//! `orogen orostats`: orometric feature vectors over blue-noise disks and a
//! region profile (Argudo et al. 2019, Table 1; see [`crate::oro::stats`]),
//! in memory.

use crate::error::{Error, Result};
use crate::exec::EngineConfig;
use crate::ops::note::{Note, Notify};
use crate::oro::stats::{self, OroStats, StatsOptions};
use crate::oro::EdgeConvention;
use crate::raster::{GeoRef, Grid, RasterSource, Window};
use std::path::{Path, PathBuf};

/// Read a whole DEM as f32 (NaN = nodata), refusing what the memory budget
/// cannot hold (`bytes_per_cell` of working set).
pub fn read_dem(
    src: &dyn RasterSource,
    bytes_per_cell: u64,
    cfg: &EngineConfig,
) -> Result<(Grid<f32>, GeoRef)> {
    let info = src.info().clone();
    crate::ops::hydro_io::guard(src, bytes_per_cell, "this step", cfg)?;
    let dem = crate::raster::read_window::<f32>(src, Window::full(info.width, info.height))?;
    Ok((dem, info.georef))
}

/// Bytes per cell of the in-memory orometric statistics.
pub const OROSTATS_BYTES_PER_CELL: u64 = 40;

/// Options of `orogen orostats`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OrostatsOptions {
    /// Disk radius in metres (a job may write `"10km"`).
    #[serde(with = "crate::ops::parse::serde_distance")]
    pub radius: f64,
    /// Minimum distance between disk centres in metres (at least R/2; `None`: R/2).
    #[serde(with = "crate::ops::parse::serde_distance_opt")]
    pub separation: Option<f64>,
    /// Region label stored with every feature vector (for `orogen classify`).
    pub label: String,
    /// Seed of the blue-noise disk placement.
    pub seed: u64,
    /// Peaks with at least this prominence.
    pub min_prominence: f64,
    /// Edge and nodata convention (`sea-level` or `unknown`).
    #[serde(with = "crate::ops::peaks::edge_text")]
    pub edge: EdgeConvention,
    /// Skip disks with a smaller fraction of valid cells.
    pub min_valid: f64,
    /// Also write the region profile (pooled distributions, JSON).
    pub profile: Option<PathBuf>,
}

impl Default for OrostatsOptions {
    fn default() -> Self {
        OrostatsOptions {
            radius: 10_000.0,
            separation: None,
            label: String::new(),
            seed: 1,
            min_prominence: 30.0,
            edge: EdgeConvention::SeaLevel,
            min_valid: 0.9,
            profile: None,
        }
    }
}

impl OrostatsOptions {
    /// Check the parameters and build the statistics' options.
    pub fn stats_options(&self) -> Result<StatsOptions> {
        let mut opts = StatsOptions::new(self.radius);
        if let Some(s) = self.separation {
            opts.separation_m = s;
        }
        if !(self.min_prominence.is_finite() && self.min_prominence >= 0.0) {
            return Err(Error::invalid(format!(
                "--min-prominence {}: give a prominence of 0 or more",
                self.min_prominence
            )));
        }
        if !(0.0..=1.0).contains(&self.min_valid) {
            return Err(Error::invalid(format!(
                "--min-valid {}: give a fraction between 0 and 1",
                self.min_valid
            )));
        }
        opts.seed = self.seed;
        opts.min_prominence = self.min_prominence;
        opts.convention = self.edge;
        opts.min_valid_fraction = self.min_valid;
        Ok(opts)
    }
}

/// Check that `output` is named `.csv` or `.json`.
pub fn check_output(output: &Path) -> Result<()> {
    let ext = output
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    if ext != "csv" && ext != "json" {
        return Err(Error::invalid(format!(
            "-o {}: name the output .csv or .json",
            output.display()
        )));
    }
    Ok(())
}

/// The statistics of `dem` (read in memory), with the DEM's file name as
/// the source of every vector.
pub fn compute(
    dem: &dyn RasterSource,
    opts: &OrostatsOptions,
    cfg: &EngineConfig,
) -> Result<OroStats> {
    let sopts = opts.stats_options()?;
    let (grid, georef) = read_dem(dem, OROSTATS_BYTES_PER_CELL, cfg)?;
    let source = dem
        .info()
        .path
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    stats::orostats(&grid, &georef, &sopts, &opts.label, &source)
}

/// Compute the feature vectors of `dem` ([`compute`]) and write them to
/// `output` ([`write`]), telling `notify` a summary line, a warning-level
/// summary when no peak qualifies (the histograms are then all zero) and
/// the files written.
pub fn run_noted(
    dem: &dyn RasterSource,
    output: &Path,
    opts: &OrostatsOptions,
    cfg: &EngineConfig,
    notify: Notify<'_>,
) -> Result<Vec<PathBuf>> {
    let st = compute(dem, opts, cfg)?;
    if st.profile.n_peaks == 0 {
        notify(Note::Info(format!(
            "warning: {}: no peaks with prominence >= {} (flat or all-nodata DEM?); the histograms are all zero",
            dem.info().path.display(),
            opts.min_prominence
        )));
    }
    let files = write(&st, dem, output, opts)?;
    notify(Note::Info(format!(
        "{} disks of radius {} m, {} peaks (prominence >= {})",
        st.disks.len(),
        opts.radius,
        st.profile.n_peaks,
        opts.min_prominence
    )));
    for f in &files {
        notify(Note::Wrote(f.clone()));
    }
    Ok(files)
}

/// Write the feature vectors of `st` to `output` (`.csv` or `.json`) and the
/// profile if `opts.profile` names a file; an error when no disk fits.
/// Returns the files written.
pub fn write(
    st: &OroStats,
    dem: &dyn RasterSource,
    output: &Path,
    opts: &OrostatsOptions,
) -> Result<Vec<PathBuf>> {
    check_output(output)?;
    if st.disks.is_empty() {
        return Err(Error::invalid(format!(
            "{}: no disk of radius {} m with at least {:.0}% valid cells fits in the DEM; give a smaller -R or --min-valid",
            dem.info().path.display(),
            opts.radius,
            opts.min_valid * 100.0
        )));
    }
    let csv = output
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("csv"));
    if csv {
        stats::write_features_csv(output, &st.disks)?;
    } else {
        stats::write_features_json(output, &st.disks)?;
    }
    let mut files = vec![output.to_path_buf()];
    if let Some(p) = &opts.profile {
        st.profile.save(p)?;
        files.push(p.clone());
    }
    Ok(files)
}

/// [`compute`], then [`write`].
pub fn run(
    dem: &dyn RasterSource,
    output: &Path,
    opts: &OrostatsOptions,
    cfg: &EngineConfig,
) -> Result<OroStats> {
    check_output(output)?;
    let st = compute(dem, opts, cfg)?;
    write(&st, dem, output, opts)?;
    Ok(st)
}
