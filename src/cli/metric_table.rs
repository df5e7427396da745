//! `orogen metric table [DEM] -o DIR`: the survey's cost table (time of
//! every metric relative to slope at several radii) and correlation matrix
//! (CSV + PNG heat map), see `orogen::metrics::table`.

use anyhow::{bail, Context, Result};
use clap::Parser;
use orogen::metrics::registry::{parse_length, Length, METRICS};
use orogen::metrics::table;
use std::path::PathBuf;

/// Default DEM: the survey's own terrain (Mont Blanc, 647 x 647 cells of ~92.7 m).
pub const DEFAULT_DEM: &str = "../shared/data/terraindescriptors_alps_montblanc.tif";

/// Arguments of `orogen metric table`.
#[derive(Parser, Debug)]
#[command(
    name = "orogen metric table",
    about = "Cost table (time of each metric relative to slope, single-threaded) and Pearson correlation matrix of the metrics, as in the terrain-descriptors survey (Tables 1-2, Fig. 52)",
    after_help = "Example:\n  orogen metric table ../shared/data/terraindescriptors_alps_montblanc.tif -o table/\nWrites cost.csv, cost.md, correlation.csv, correlation.png (rows and columns labelled by index) and correlation_legend.csv.\nRuns in memory on the whole raster; use a release build for meaningful times."
)]
pub struct MetricTableArgs {
    /// Input DEM (default: the survey's Mont Blanc terrain).
    #[arg(default_value = DEFAULT_DEM)]
    pub input: PathBuf,
    /// Output folder.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Radii for the metrics with a radius, comma separated (m, km or c).
    #[arg(long, default_value = "100m,500m,1500m,5000m")]
    pub radii: String,
    /// Radius of the metrics in the correlation matrix.
    #[arg(long, default_value = "500m")]
    pub corr_radius: String,
    /// Timing runs per metric (the best is kept).
    #[arg(long, default_value_t = 1)]
    pub repeats: usize,
    /// Only these metrics in the cost table (comma-separated names).
    #[arg(long)]
    pub only: Option<String>,
    /// Skip the cost table (correlation only).
    #[arg(long)]
    pub no_cost: bool,
    /// Largest raster (cells) accepted; the table runs in memory.
    #[arg(long, default_value_t = 16_000_000)]
    pub max_cells: usize,
    /// Print no progress.
    #[arg(long, short)]
    pub quiet: bool,
}

fn metres(s: &str, cell: f64) -> Result<f64> {
    match parse_length(s).map_err(anyhow::Error::msg)? {
        Length::Metres(m) => Ok(m),
        Length::Cells(c) => Ok(c as f64 * cell),
    }
}

/// Run `orogen metric table`.
pub fn run(a: MetricTableArgs) -> Result<()> {
    let src = orogen::io::open_raster(&a.input, &Default::default())
        .with_context(|| format!("{}: cannot open the DEM", a.input.display()))?;
    table::check_size(src.as_ref(), a.max_cells)?;
    let cell = orogen::metrics::registry::min_cell_size_m(src.info());
    let radii: Vec<f64> = a
        .radii
        .split(',')
        .map(|r| metres(r, cell))
        .collect::<Result<_>>()
        .with_context(|| format!("--radii {:?}", a.radii))?;
    let corr_r = metres(&a.corr_radius, cell).with_context(|| "--corr-radius")?;
    let only = match &a.only {
        None => None,
        Some(list) => {
            let mut v = Vec::new();
            for n in list.split(',') {
                let n = n.trim();
                match METRICS.iter().find(|d| d.name == n) {
                    Some(d) => v.push(d.kind),
                    None => bail!(
                        "--only: unknown metric '{n}'; known metrics: {}",
                        METRICS
                            .iter()
                            .map(|d| d.name)
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                }
            }
            Some(v)
        }
    };
    std::fs::create_dir_all(&a.output)
        .with_context(|| format!("{}: cannot create the output folder", a.output.display()))?;
    let write = |name: &str, text: &str| -> Result<()> {
        let p = a.output.join(name);
        orogen::io::atomic::write_file_atomic(&p, text.as_bytes())?;
        if !a.quiet {
            eprintln!("wrote {}", p.display());
        }
        Ok(())
    };
    if !a.no_cost {
        let quiet = a.quiet;
        let rows = table::cost_table(src.as_ref(), &radii, a.repeats, only.as_deref(), |r| {
            if !quiet {
                eprintln!(
                    "{:<22} r={:>8} {:>8.4} s  x{:.2}{}",
                    r.name,
                    r.radius_m
                        .map(|m| format!("{m}m"))
                        .unwrap_or_else(|| "-".into()),
                    r.seconds,
                    r.relative,
                    if r.skipped.is_some() {
                        "  (skipped)"
                    } else {
                        ""
                    }
                );
            }
        })?;
        write("cost.csv", &table::cost_csv(&rows))?;
        let md = table::cost_markdown(&rows, &radii);
        write("cost.md", &md)?;
        if !a.quiet {
            print!("{md}");
        }
    }
    let specs = table::correlation_specs(src.as_ref(), corr_r);
    let (labels, m) = table::correlation(src.as_ref(), &specs)?;
    write("correlation.csv", &table::correlation_csv(&labels, &m))?;
    let legend: String = std::iter::once("index,metric\n".to_string())
        .chain(
            labels
                .iter()
                .enumerate()
                .map(|(i, l)| format!("{},{l}\n", i + 1)),
        )
        .collect();
    write("correlation_legend.csv", &legend)?;
    let png = a.output.join("correlation.png");
    table::write_heatmap(&png, &m, labels.len())?;
    if !a.quiet {
        eprintln!("wrote {}", png.display());
    }
    Ok(())
}
