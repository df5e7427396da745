//! `report.html`: one self-contained page per job (images inlined as base64
//! PNG, charts as inline SVG, no external resources) with a table of the
//! steps (command, status, time, peak memory) and, for every output, a
//! preview with hillshade or a colour ramp and its legend, the value range,
//! a histogram and, for CSV/GeoJSON outputs, their first rows or feature
//! counts.
//!
//! Previews and histograms come from a block-mean downsampling of the raster
//! ([`crate::io::render::downsample_mean`], at most 512 pixels a side), so
//! the histogram is that of the preview's cells, not of every cell; the
//! minimum and maximum are exact.

use crate::error::{Error, Result};
use crate::io::render::{downsample_mean, render_preview, RenderKind, RenderOptions};
use crate::io::{open_raster, OpenOptions};
use crate::raster::{AnyGrid, MemRaster};
use base64::Engine as _;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// How a step ended.
#[derive(Debug, Clone, PartialEq)]
pub enum Status {
    Ran,
    /// Finished in an earlier run (resume).
    Skipped,
    Failed(String),
    /// Not reached because an earlier step failed.
    NotRun,
}

/// One step's line in the report.
#[derive(Debug, Clone)]
pub struct StepOutcome {
    pub name: String,
    pub command_line: String,
    pub status: Status,
    pub seconds: f64,
    pub peak_rss_bytes: u64,
    pub output: Option<PathBuf>,
    /// Render rasters as elevation (hillshade + hypsometric colours) rather
    /// than a plain colour ramp.
    pub elevation: bool,
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn is_raster(p: &Path) -> bool {
    let ext = p
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    matches!(ext.as_str(), "tif" | "tiff" | "asc" | "hgt")
        || (ext == "tiles" && p.join("manifest.json").exists())
}

/// Files an output stands for: itself, or the visible files of a folder.
fn output_files(p: &Path) -> Vec<PathBuf> {
    if p.is_dir() && !is_raster(p) {
        let mut v: Vec<PathBuf> = std::fs::read_dir(p)
            .map(|rd| rd.flatten().map(|e| e.path()).collect())
            .unwrap_or_default();
        v.retain(|f| {
            !f.file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with('.'))
        });
        v.sort();
        v
    } else if p.exists() {
        vec![p.to_path_buf()]
    } else {
        vec![]
    }
}

/// Inline SVG bar chart of `values` (finite cells) in 40 bins.
fn histogram_svg(values: &[f32], lo: f64, hi: f64) -> String {
    const BINS: usize = 40;
    let mut counts = [0u64; BINS];
    let span = hi - lo;
    for &v in values {
        if v.is_finite() {
            let b = if span > 0.0 {
                (((v as f64 - lo) / span) * BINS as f64) as usize
            } else {
                0
            };
            counts[b.min(BINS - 1)] += 1;
        }
    }
    let max = counts.iter().copied().max().unwrap_or(0).max(1) as f64;
    let (w, h) = (320.0, 90.0);
    let bw = w / BINS as f64;
    let mut s = format!(
        "<svg xmlns='http://www.w3.org/2000/svg' width='{w}' height='{}' role='img'>",
        h + 16.0
    );
    for (i, &c) in counts.iter().enumerate() {
        let bh = (c as f64 / max) * h;
        let _ = write!(
            s,
            "<rect x='{:.1}' y='{:.1}' width='{:.1}' height='{bh:.1}' fill='#4a7bb7'><title>{c}</title></rect>",
            i as f64 * bw,
            h - bh,
            bw - 1.0
        );
    }
    let _ = write!(
        s,
        "<text x='0' y='{}' font-size='11'>{}</text><text x='{w}' y='{}' font-size='11' text-anchor='end'>{}</text></svg>",
        h + 13.0,
        fmt_num(lo),
        h + 13.0,
        fmt_num(hi)
    );
    s
}

fn fmt_num(v: f64) -> String {
    if !v.is_finite() {
        "–".into()
    } else if v.abs() >= 1e5 || (v != 0.0 && v.abs() < 1e-2) {
        format!("{v:.3e}")
    } else {
        format!("{v:.2}")
    }
}

fn raster_section(p: &Path, elevation: bool, tmp: &Path) -> Result<String> {
    let src = open_raster(p, &OpenOptions::default())?;
    let info = src.info().clone();
    let factor = info.width.max(info.height).div_ceil(512).max(1);
    // One pass over the raster: the block means serve both the histogram and
    // the preview (rendered from an in-memory raster with cells `factor` times
    // larger, and the exact value range).
    let (small, lo, hi) = downsample_mean(src.as_ref(), factor)?;
    let mut georef = info.georef.clone();
    for k in [1, 2, 4, 5] {
        georef.transform[k] *= factor as f64;
    }
    georef.nodata = None;
    let hist = histogram_svg(small.data(), lo, hi);
    let preview_src = MemRaster::new(AnyGrid::F32(small), georef, p);
    let png = tmp.join("preview.png");
    let opts = RenderOptions {
        range: (lo <= hi).then_some((lo, hi)),
        cell_size_m: (!info.georef.georeferenced).then_some(factor as f64),
        kind: if elevation {
            RenderKind::Elevation
        } else {
            RenderKind::Ramp("viridis".into())
        },
        max_size: 512,
        legend: true,
        sea: elevation,
        ..Default::default()
    };
    render_preview(&preview_src, &png, &opts)?;
    let bytes = std::fs::read(&png).map_err(|e| Error::io(&png, e))?;
    let b64 = base64::engine::general_purpose::STANDARD.encode(bytes);
    let mut s = String::new();
    let _ = write!(
        s,
        "<div class='out'><h3>{}</h3><p>{} x {} {} · min {} · max {}</p><img src='data:image/png;base64,{b64}' alt='preview of {}'>{}</div>",
        esc(&p.display().to_string()),
        info.width,
        info.height,
        info.dtype,
        fmt_num(lo),
        fmt_num(hi),
        esc(&p.display().to_string()),
        hist
    );
    Ok(s)
}

fn csv_section(p: &Path) -> Result<String> {
    let text = std::fs::read_to_string(p).map_err(|e| Error::io(p, e))?;
    let lines: Vec<&str> = text.lines().collect();
    let mut s = format!(
        "<div class='out'><h3>{}</h3><p>{} rows</p><table>",
        esc(&p.display().to_string()),
        lines.len().saturating_sub(1)
    );
    for (i, l) in lines.iter().take(16).enumerate() {
        let tag = if i == 0 { "th" } else { "td" };
        s.push_str("<tr>");
        for c in l.split(',') {
            let _ = write!(s, "<{tag}>{}</{tag}>", esc(c));
        }
        s.push_str("</tr>");
    }
    s.push_str("</table></div>");
    Ok(s)
}

fn geojson_section(p: &Path) -> Result<String> {
    let len = std::fs::metadata(p).map_err(|e| Error::io(p, e))?.len();
    let count = if len < 256 << 20 {
        let text = std::fs::read_to_string(p).map_err(|e| Error::io(p, e))?;
        serde_json::from_str::<serde_json::Value>(&text)
            .ok()
            .and_then(|v| {
                v.get("features")
                    .and_then(|f| f.as_array())
                    .map(|a| a.len())
            })
            .map(|n| n.to_string())
            .unwrap_or_else(|| "?".into())
    } else {
        "?".into()
    };
    Ok(format!(
        "<div class='out'><h3>{}</h3><p>GeoJSON, {count} features, {len} bytes</p></div>",
        esc(&p.display().to_string())
    ))
}

/// Write the report of a job to `path` (atomically). Outputs that cannot
/// be read are listed with the reason instead of failing the report.
pub fn write_report(title: &str, steps: &[StepOutcome], path: &Path) -> Result<()> {
    let tmpdir = tempfile_dir(path)?;
    let mut body = String::new();
    let _ = write!(
        body,
        "<h1>{}</h1><h2>Steps</h2><table><tr><th>#</th><th>step</th><th>command</th><th>status</th><th>time</th><th>peak memory</th></tr>",
        esc(title)
    );
    for (i, s) in steps.iter().enumerate() {
        let status = match &s.status {
            Status::Ran => "ran".to_string(),
            Status::Skipped => "done earlier (resumed)".to_string(),
            Status::Failed(m) => format!("FAILED: {m}"),
            Status::NotRun => "not run".to_string(),
        };
        let _ = write!(
            body,
            "<tr><td>{}</td><td>{}</td><td><code>{}</code></td><td>{}</td><td>{}</td><td>{}</td></tr>",
            i + 1,
            esc(&s.name),
            esc(&s.command_line),
            esc(&status),
            if s.status == Status::Ran {
                format!("{:.2} s", s.seconds)
            } else {
                "–".into()
            },
            if s.status == Status::Ran && s.peak_rss_bytes > 0 {
                format!("{:.0} MiB", s.peak_rss_bytes as f64 / 1048576.0)
            } else {
                "–".into()
            }
        );
    }
    body.push_str("</table><h2>Outputs</h2>");
    for s in steps {
        let Some(out) = &s.output else { continue };
        let _ = write!(body, "<h2 class='step'>{}</h2>", esc(&s.name));
        for f in output_files(out) {
            let ext = f
                .extension()
                .and_then(|e| e.to_str())
                .unwrap_or("")
                .to_ascii_lowercase();
            let part = if is_raster(&f) {
                raster_section(&f, s.elevation, &tmpdir)
            } else if ext == "csv" {
                csv_section(&f)
            } else if ext == "geojson" || ext == "json" && f.to_string_lossy().ends_with(".geojson")
            {
                geojson_section(&f)
            } else {
                Ok(format!(
                    "<div class='out'><h3>{}</h3></div>",
                    esc(&f.display().to_string())
                ))
            };
            match part {
                Ok(html) => body.push_str(&html),
                Err(e) => {
                    let _ = write!(
                        body,
                        "<div class='out'><h3>{}</h3><p>not shown: {}</p></div>",
                        esc(&f.display().to_string()),
                        esc(&e.to_string())
                    );
                }
            }
        }
    }
    let _ = std::fs::remove_dir_all(&tmpdir);
    let html = format!(
        "<!doctype html><html><head><meta charset='utf-8'><title>{}</title><style>\
body{{font-family:sans-serif;margin:2em;max-width:1200px}}table{{border-collapse:collapse;margin:.5em 0}}\
td,th{{border:1px solid #ccc;padding:2px 6px;font-size:13px;text-align:left}}\
.out{{display:inline-block;vertical-align:top;margin:0 1em 1em 0}}img{{display:block;max-width:512px}}\
h3{{font-size:14px;word-break:break-all;max-width:512px}}</style></head><body>{body}</body></html>",
        esc(title)
    );
    let tmp = path.with_extension("html.tmp");
    std::fs::write(&tmp, html).map_err(|e| Error::io(&tmp, e))?;
    std::fs::rename(&tmp, path).map_err(|e| Error::io(path, e))
}

/// A private scratch folder next to `path` for preview PNGs.
fn tempfile_dir(path: &Path) -> Result<PathBuf> {
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."))
        .join(format!(".orogen-report-{}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    Ok(dir)
}
