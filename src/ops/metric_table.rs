//! `orogen metric table [DEM] -o DIR`: the survey's cost table (time of
//! every metric relative to slope at several radii) and correlation matrix
//! (CSV + PNG heat map), see [`crate::metrics::table`].

use crate::error::{Error, Result};
use crate::metrics::registry::{parse_length, Length, METRICS};
use crate::metrics::table::{self, CostRow};
use crate::raster::RasterSource;
use std::path::{Path, PathBuf};

/// Options of `orogen metric table`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MetricTableOptions {
    /// Radii for the metrics with a radius, comma separated (m, km or c).
    pub radii: String,
    /// Radius of the metrics in the correlation matrix.
    pub corr_radius: String,
    /// Timing runs per metric (the best is kept).
    pub repeats: usize,
    /// Only these metrics in the cost table (comma-separated names).
    pub only: Option<String>,
    /// Skip the cost table (correlation only).
    pub no_cost: bool,
    /// Largest raster (cells) accepted; the table runs in memory.
    pub max_cells: usize,
}

impl Default for MetricTableOptions {
    fn default() -> Self {
        MetricTableOptions {
            radii: "100m,500m,1500m,5000m".into(),
            corr_radius: "500m".into(),
            repeats: 1,
            only: None,
            no_cost: false,
            max_cells: 16_000_000,
        }
    }
}

fn metres(s: &str, cell: f64) -> std::result::Result<f64, String> {
    match parse_length(s)? {
        Length::Metres(m) => Ok(m),
        Length::Cells(c) => Ok(c as f64 * cell),
    }
}

/// What [`run`] wrote.
#[derive(Debug, Clone)]
pub struct MetricTableOutcome {
    /// The cost table as Markdown (`None` with `no_cost`).
    pub cost_markdown: Option<String>,
    /// Files written, in order.
    pub files: Vec<PathBuf>,
}

/// Time the metrics on `dem` (calling `progress` after each row) and write
/// cost.csv, cost.md, correlation.csv, correlation_legend.csv and
/// correlation.png into `dir`.
pub fn run(
    dem: &dyn RasterSource,
    dir: &Path,
    opts: &MetricTableOptions,
    progress: impl FnMut(&CostRow),
) -> Result<MetricTableOutcome> {
    let a = opts;
    table::check_size(dem, a.max_cells)?;
    let cell = crate::metrics::registry::min_cell_size_m(dem.info());
    let radii: Vec<f64> = a
        .radii
        .split(',')
        .map(|r| metres(r, cell))
        .collect::<std::result::Result<_, _>>()
        .map_err(|e| Error::invalid(format!("--radii {:?}: {e}", a.radii)))?;
    let corr_r =
        metres(&a.corr_radius, cell).map_err(|e| Error::invalid(format!("--corr-radius: {e}")))?;
    let only = match &a.only {
        None => None,
        Some(list) => {
            let mut v = Vec::new();
            for n in list.split(',') {
                let n = n.trim();
                match METRICS.iter().find(|d| d.name == n) {
                    Some(d) => v.push(d.kind),
                    None => {
                        return Err(Error::invalid(format!(
                            "--only: unknown metric '{n}'; known metrics: {}",
                            METRICS
                                .iter()
                                .map(|d| d.name)
                                .collect::<Vec<_>>()
                                .join(", ")
                        )))
                    }
                }
            }
            Some(v)
        }
    };
    std::fs::create_dir_all(dir).map_err(|e| {
        Error::invalid(format!(
            "{}: cannot create the output folder: {e}",
            dir.display()
        ))
    })?;
    let mut files = Vec::new();
    let mut write = |name: &str, text: &str| -> Result<()> {
        let p = dir.join(name);
        crate::io::atomic::write_file_atomic(&p, text.as_bytes())?;
        files.push(p);
        Ok(())
    };
    let mut cost_markdown = None;
    if !a.no_cost {
        let rows = table::cost_table(dem, &radii, a.repeats, only.as_deref(), progress)?;
        write("cost.csv", &table::cost_csv(&rows))?;
        let md = table::cost_markdown(&rows, &radii);
        write("cost.md", &md)?;
        cost_markdown = Some(md);
    }
    let specs = table::correlation_specs(dem, corr_r);
    let (labels, m) = table::correlation(dem, &specs)?;
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
    let png = dir.join("correlation.png");
    table::write_heatmap(&png, &m, labels.len())?;
    files.push(png);
    Ok(MetricTableOutcome {
        cost_markdown,
        files,
    })
}
