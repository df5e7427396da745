//! `orogen compare A B -o DIR`: realism report of two terrains (see
//! `orogen::compare`).

use anyhow::{bail, Context, Result};
use clap::Args;
use orogen::compare::{self, CompareOptions};
use orogen::io::{open_raster, OpenOptions};
use std::path::PathBuf;

/// Arguments of `orogen compare`.
#[derive(Args)]
pub struct CompareArgs {
    /// First terrain (e.g. the synthetic one): any raster orogen reads.
    pub a: PathBuf,
    /// Second terrain (e.g. the real exemplar).
    pub b: PathBuf,
    /// Output folder: compare.json, compare.html, chart PNGs, thumbnails.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Peaks with at least this prominence (m).
    #[arg(long, default_value_t = 30.0)]
    pub min_prominence: f64,
    /// Disk radius of the orometric statistics, e.g. 5km (default: 10 km, or a
    /// quarter of the shorter side of the smaller terrain).
    #[arg(short = 'R', long)]
    pub radius: Option<String>,
    /// Channels start where the drainage area reaches this many km².
    #[arg(long, default_value_t = 1.0)]
    pub channel_area: f64,
    /// Seed of the blue-noise disk placement.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Name of the first terrain in the report (default: its file name).
    #[arg(long)]
    pub label_a: Option<String>,
    /// Name of the second terrain in the report (default: its file name).
    #[arg(long)]
    pub label_b: Option<String>,
    #[command(flatten)]
    pub run: crate::Run,
}

/// A distance such as `5km`, `5000m` or `5000` (metres).
fn parse_distance(s: &str) -> Result<f64> {
    let t = s.trim();
    let (num, mul) = if let Some(n) = t.strip_suffix("km") {
        (n, 1000.0)
    } else if let Some(n) = t.strip_suffix('m') {
        (n, 1.0)
    } else {
        (t, 1.0)
    };
    let v: f64 = num
        .trim()
        .parse()
        .with_context(|| format!("--radius {s}: give a distance such as 5km or 2000m"))?;
    if !(v.is_finite() && v > 0.0) {
        bail!("--radius {s}: give a positive distance");
    }
    Ok(v * mul)
}

pub fn run(a: CompareArgs) -> Result<()> {
    let cfg = crate::engine(&a.run)?;
    let radius_m = a.radius.as_deref().map(parse_distance).transpose()?;
    if !(a.channel_area.is_finite() && a.channel_area > 0.0) {
        bail!(
            "--channel-area {}: give a positive drainage area in km²",
            a.channel_area
        );
    }
    let name = |p: &PathBuf, l: &Option<String>| {
        l.clone().unwrap_or_else(|| {
            p.file_name()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| p.display().to_string())
        })
    };
    let (na, nb) = (name(&a.a, &a.label_a), name(&a.b, &a.label_b));
    // Both terrains are held at once; each gets half the budget.
    let half = cfg.memory_budget / 2;
    let sa = open_raster(&a.a, &OpenOptions::default())?;
    let ta = compare::load_terrain(sa.as_ref(), &na, half)?;
    drop(sa);
    let sb = open_raster(&a.b, &OpenOptions::default())?;
    let tb = compare::load_terrain(sb.as_ref(), &nb, half)?;
    drop(sb);
    let opts = CompareOptions {
        min_prominence: a.min_prominence,
        radius_m,
        channel_area_m2: a.channel_area * 1e6,
        seed: a.seed,
        engine: cfg,
    };
    let cmp = compare::compare(&ta, &tb, &opts)?;
    let files = compare::output::write_outputs(&cmp, &ta, &tb, &a.output)?;
    for f in files
        .iter()
        .filter(|f| f.extension().is_some_and(|e| e != "png"))
    {
        crate::wrote(f);
    }
    if !a.run.quiet {
        for an in [&cmp.a, &cmp.b] {
            if let Some(n) = &an.oro_note {
                eprintln!("warning: orometry of {}: {n}", an.name);
            }
        }
        eprintln!(
            "{} charts in {}",
            files.len().saturating_sub(2),
            a.output.display()
        );
    }
    Ok(())
}
