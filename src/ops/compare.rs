//! `orogen compare A B -o DIR`: realism report of two terrains (orometric
//! histogram EMDs, pits, hypsometry, slope/curvature/geomorphon
//! distributions, drainage density, Horton ratios; see [`crate::compare`]).

use crate::compare::{self, Comparison};
use crate::error::{Error, Result};
use crate::exec::EngineConfig;
use crate::io::{open_raster, OpenOptions};
use crate::ops::note::{Note, Notify};
use std::path::{Path, PathBuf};

/// Options of `orogen compare`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CompareOptions {
    /// Peaks with at least this prominence (m).
    pub min_prominence: f64,
    /// Disk radius of the orometric statistics in metres (`None`: 10 km, or a
    /// quarter of the shorter side of the smaller terrain if less; a job may
    /// write `"5km"`).
    #[serde(with = "crate::ops::parse::serde_distance_opt")]
    pub radius: Option<f64>,
    /// Channels start where the drainage area reaches this (km²).
    pub channel_area: f64,
    /// Seed of the disk placement.
    pub seed: u64,
    /// Name of the first terrain in the report (default: its file name).
    pub label_a: Option<String>,
    /// Name of the second terrain in the report (default: its file name).
    pub label_b: Option<String>,
}

impl Default for CompareOptions {
    fn default() -> Self {
        CompareOptions {
            min_prominence: 30.0,
            radius: None,
            channel_area: 1.0,
            seed: 1,
            label_a: None,
            label_b: None,
        }
    }
}

impl CompareOptions {
    /// Check the parameters (the channel area).
    pub fn validate(&self) -> Result<()> {
        if !(self.channel_area.is_finite() && self.channel_area > 0.0) {
            return Err(Error::invalid(format!(
                "--channel-area {}: give a positive drainage area in km²",
                self.channel_area
            )));
        }
        Ok(())
    }
}

/// What [`run`] compared and wrote.
#[derive(Debug)]
pub struct CompareOutcome {
    /// The comparison (also in `compare.json`).
    pub comparison: Comparison,
    /// Files written into the output folder.
    pub files: Vec<PathBuf>,
}

/// Compare the terrains `a` and `b` (any raster orogen reads, each held in
/// memory with half of `cfg.memory_budget`) and write compare.json,
/// compare.html, chart PNGs and thumbnails into `dir`.
pub fn run(
    a: &Path,
    b: &Path,
    dir: &Path,
    opts: &CompareOptions,
    cfg: &EngineConfig,
) -> Result<CompareOutcome> {
    opts.validate()?;
    let name = |p: &Path, l: &Option<String>| {
        l.clone().unwrap_or_else(|| {
            p.file_name()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| p.display().to_string())
        })
    };
    let (na, nb) = (name(a, &opts.label_a), name(b, &opts.label_b));
    // Both terrains are held at once; each gets half the budget.
    let half = cfg.memory_budget / 2;
    let sa = open_raster(a, &OpenOptions::default())?;
    let ta = compare::load_terrain(sa.as_ref(), &na, half)?;
    drop(sa);
    let sb = open_raster(b, &OpenOptions::default())?;
    let tb = compare::load_terrain(sb.as_ref(), &nb, half)?;
    drop(sb);
    let copts = compare::CompareOptions {
        min_prominence: opts.min_prominence,
        radius_m: opts.radius,
        channel_area_m2: opts.channel_area * 1e6,
        seed: opts.seed,
        engine: cfg.clone(),
    };
    let comparison = compare::compare(&ta, &tb, &copts)?;
    let files = compare::output::write_outputs(&comparison, &ta, &tb, dir)?;
    Ok(CompareOutcome { comparison, files })
}

/// [`run`], telling `notify` the files written (not the charts), a
/// warning-level summary for a terrain whose orometry was cut short, and
/// how many charts it drew.
pub fn run_noted(
    a: &Path,
    b: &Path,
    dir: &Path,
    opts: &CompareOptions,
    cfg: &EngineConfig,
    notify: Notify<'_>,
) -> Result<CompareOutcome> {
    let done = run(a, b, dir, opts, cfg)?;
    let (cmp, files) = (&done.comparison, &done.files);
    for f in files
        .iter()
        .filter(|f| f.extension().is_some_and(|e| e != "png"))
    {
        notify(Note::Wrote(f.clone()));
    }
    for an in [&cmp.a, &cmp.b] {
        if let Some(n) = &an.oro_note {
            notify(Note::Info(format!("warning: orometry of {}: {n}", an.name)));
        }
    }
    notify(Note::Info(format!(
        "{} charts in {}",
        files.len().saturating_sub(2),
        dir.display()
    )));
    Ok(done)
}
