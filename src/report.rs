//! `report.html`: one self-contained page per job (images inlined as base64
//! PNG, charts as inline SVG, no external resources) with a table of the
//! steps (command, status, time, peak memory) and, for every output, a
//! preview with hillshade or a colour ramp and its legend, the value range,
//! a histogram and, for CSV/GeoJSON outputs, their first rows or feature
//! counts.
//!
//! Previews and histograms come from a downsampling of the raster by what
//! it holds ([`crate::tiles::render::downsample`], at most 512 pixels a
//! side: block means, circular means of angles, centre cells of class
//! codes), so the histogram is that of the preview's cells, not of every
//! cell; the minimum and maximum are exact. Class codes (D8 directions,
//! labels, landforms) get a class palette, bars per class and a legend;
//! angles (aspect) a hue wheel; heavy-tailed non-negative outputs (flow
//! accumulation: median below a thousandth of the maximum) a log scale.

use crate::error::{Error, Result};
use crate::io::{open_raster, OpenOptions};
use crate::raster::{AnyGrid, MemRaster};
use crate::store::scratch::ScratchDir;
use crate::tiles::render::{downsample, render_preview, RenderKind, RenderOptions};
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
    /// Other files the step wrote (paths given to options such as
    /// `--metrics`, `--profile`, `--stats`), shown after `output`.
    pub extra_outputs: Vec<PathBuf>,
    /// Render rasters as elevation (hillshade + hypsometric colours) rather
    /// than a plain colour ramp.
    pub elevation: bool,
    /// What the step's raster outputs hold (a `metric` step's files: each
    /// metric's own kind, looked up by file name): class codes are previewed
    /// with a class palette and per-class bars, angles with a colour wheel.
    pub kind: crate::raster::OutputKind,
    /// The classes' names, for the legend (D8 directions of `flow`).
    pub classes: Option<&'static [(u32, &'static str)]>,
}

/// The names of the ESRI D8 codes (`orogen flow`), for legends.
pub const D8_CLASSES: &[(u32, &str)] = &[
    (0, "no flow"),
    (1, "E"),
    (2, "SE"),
    (4, "S"),
    (8, "SW"),
    (16, "W"),
    (32, "NW"),
    (64, "N"),
    (128, "NE"),
];

/// The kind of a metric output file (`NAME_...tif` of `orogen metric`):
/// the registry's kind of the longest metric name the stem starts with.
fn metric_file_kind(p: &Path) -> Option<crate::raster::OutputKind> {
    let stem = p.file_stem()?.to_str()?;
    crate::metrics::registry::METRICS
        .iter()
        .map(|m| m.def())
        .filter(|d| stem == d.name || stem.starts_with(&format!("{}_", d.name)))
        .max_by_key(|d| d.name.len())
        .map(|d| d.output)
}

/// Escape text for HTML.
pub fn esc(s: &str) -> String {
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

/// A number for a table cell: 2 decimals, scientific when very large or small.
pub fn fmt_num(v: f64) -> String {
    if !v.is_finite() {
        "–".into()
    } else if v.abs() >= 1e5 || (v != 0.0 && v.abs() < 1e-2) {
        format!("{v:.3e}")
    } else {
        format!("{v:.2}")
    }
}

/// A distinct colour for class `v` (a D8 code, a label, a landform):
/// twelve well separated hues for small codes, a hash of the value beyond.
fn class_colour(v: f32) -> [u8; 3] {
    const PALETTE: [[u8; 3]; 12] = [
        [31, 119, 180],
        [255, 127, 14],
        [44, 160, 44],
        [214, 39, 40],
        [148, 103, 189],
        [140, 86, 75],
        [227, 119, 194],
        [127, 127, 127],
        [188, 189, 34],
        [23, 190, 207],
        [255, 215, 0],
        [0, 0, 128],
    ];
    let k = v as i64;
    if (0..12).contains(&k) {
        return PALETTE[k as usize];
    }
    if k > 0 && k <= 128 && (k as u64).is_power_of_two() {
        return PALETTE[(k as u64).trailing_zeros() as usize + 1];
    }
    let mut x = (v.to_bits() as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    x ^= x >> 29;
    [
        (x >> 8) as u8 | 32,
        (x >> 16) as u8 | 32,
        (x >> 24) as u8 | 32,
    ]
}

/// A hue wheel colour for an angle in degrees (0 = north red, 120 green,
/// 240 blue), full saturation.
fn wheel_colour(deg: f32) -> [u8; 3] {
    let h = (deg as f64).rem_euclid(360.0) / 60.0;
    let x = 1.0 - (h % 2.0 - 1.0).abs();
    let (r, g, b) = match h as u32 {
        0 => (1.0, x, 0.0),
        1 => (x, 1.0, 0.0),
        2 => (0.0, 1.0, x),
        3 => (0.0, x, 1.0),
        4 => (x, 0.0, 1.0),
        _ => (1.0, 0.0, x),
    };
    [(r * 255.0) as u8, (g * 255.0) as u8, (b * 255.0) as u8]
}

/// An RGBA PNG of `g` coloured by `colour` (nodata transparent).
fn coloured_png(g: &crate::raster::Grid<f32>, colour: impl Fn(f32) -> [u8; 3]) -> Result<Vec<u8>> {
    let mut rgba = Vec::with_capacity(g.data().len() * 4);
    for &v in g.data() {
        if v.is_nan() {
            rgba.extend_from_slice(&[0, 0, 0, 0]);
        } else {
            let c = colour(v);
            rgba.extend_from_slice(&[c[0], c[1], c[2], 255]);
        }
    }
    let mut out = Vec::new();
    crate::io::png::encode_png(
        &mut out,
        g.width() as u32,
        g.height() as u32,
        ::png::ColorType::Rgba,
        &rgba,
    )
    .map_err(|e| Error::invalid(format!("preview PNG: {e}")))?;
    Ok(out)
}

/// A class code as text: integers without decimals.
fn class_label(v: f32) -> String {
    if v.fract() == 0.0 && v.abs() < 1e9 {
        format!("{}", v as i64)
    } else {
        fmt_num(v as f64)
    }
}

/// Inline SVG bars, one per class of `values` (at most 40, the most common),
/// with a legend of the classes' colours and names.
fn class_bars_svg(values: &[f32], names: Option<&[(u32, &str)]>) -> String {
    let mut counts: std::collections::BTreeMap<u32, u64> = Default::default();
    for &v in values {
        if v.is_finite() {
            *counts.entry(v.to_bits()).or_default() += 1;
        }
    }
    let mut classes: Vec<(f32, u64)> = counts
        .into_iter()
        .map(|(b, c)| (f32::from_bits(b), c))
        .collect();
    let total_classes = classes.len();
    if classes.len() > 40 {
        classes.sort_by_key(|c| std::cmp::Reverse(c.1));
        classes.truncate(40);
    }
    classes.sort_by(|a, b| a.0.total_cmp(&b.0));
    let max = classes.iter().map(|c| c.1).max().unwrap_or(1).max(1) as f64;
    let (w, h) = (320.0, 90.0);
    let bw = w / classes.len().max(1) as f64;
    let mut s = format!(
        "<svg xmlns='http://www.w3.org/2000/svg' width='{w}' height='{}' role='img'>",
        h + 16.0
    );
    for (i, &(v, c)) in classes.iter().enumerate() {
        let bh = (c as f64 / max) * h;
        let [r, g, b] = class_colour(v);
        let name = names
            .and_then(|n| n.iter().find(|(k, _)| *k as f32 == v))
            .map(|(_, n)| format!(" {n}"))
            .unwrap_or_default();
        let _ = write!(
            s,
            "<rect x='{:.1}' y='{:.1}' width='{:.1}' height='{bh:.1}' fill='rgb({r},{g},{b})'><title>{}{}: {c}</title></rect>",
            i as f64 * bw,
            h - bh,
            (bw - 1.0).max(1.0),
            class_label(v),
            esc(&name)
        );
    }
    let _ = write!(
        s,
        "<text x='0' y='{}' font-size='11'>{} classes{}</text></svg>",
        h + 13.0,
        total_classes,
        if total_classes > 40 {
            " (the 40 most common shown)"
        } else {
            ""
        }
    );
    if total_classes <= 16 {
        s.push_str("<p class='legend'>");
        for &(v, _) in &classes {
            let [r, g, b] = class_colour(v);
            let name = names
                .and_then(|n| n.iter().find(|(k, _)| *k as f32 == v))
                .map(|(_, n)| n.to_string())
                .unwrap_or_else(|| class_label(v));
            let _ = write!(
                s,
                "<span style='display:inline-block;width:10px;height:10px;background:rgb({r},{g},{b})'></span> {} ",
                esc(&name)
            );
        }
        s.push_str("</p>");
    }
    s
}

/// True if a non-negative quantity is heavy-tailed (flow accumulation,
/// drainage areas): its median is below a thousandth of its maximum. Such
/// outputs are previewed as log10(1 + v), else one colour would hide every
/// river.
fn heavy_tailed(values: &[f32], lo: f64, hi: f64) -> bool {
    if !(lo >= 0.0 && hi > 0.0) {
        return false;
    }
    let mut v: Vec<f32> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return false;
    }
    let mid = v.len() / 2;
    let (_, m, _) = v.select_nth_unstable_by(mid, |a, b| a.total_cmp(b));
    (*m as f64) < hi / 1000.0
}

fn raster_section(
    p: &Path,
    elevation: bool,
    kind: crate::raster::OutputKind,
    classes: Option<&[(u32, &str)]>,
    tmp: &Path,
) -> Result<String> {
    use crate::raster::OutputKind;
    let src = open_raster(p, &OpenOptions::default())?;
    let info = src.info().clone();
    let factor = info.width.max(info.height).div_ceil(512).max(1);
    // One pass over the raster: the block values serve both the histogram
    // and the preview (rendered from an in-memory raster with cells `factor`
    // times larger, and the exact value range); blocks by the output's kind.
    let (small, lo, hi) = downsample(src.as_ref(), factor, kind)?;
    let title = esc(&p.display().to_string());
    let head = format!(
        "<div class='out'><h3>{title}</h3><p>{} x {} {} · min {} · max {}",
        info.width,
        info.height,
        info.dtype,
        fmt_num(lo),
        fmt_num(hi)
    );
    let img = |bytes: &[u8], note: &str, chart: String| {
        let b64 = base64::engine::general_purpose::STANDARD.encode(bytes);
        format!("{head}{note}</p><img src='data:image/png;base64,{b64}' alt='preview of {title}'>{chart}</div>")
    };
    match kind {
        OutputKind::Categorical => {
            let png = coloured_png(&small, class_colour)?;
            let chart = class_bars_svg(small.data(), classes);
            return Ok(img(&png, " · classes (block centre cells)", chart));
        }
        OutputKind::Angle => {
            let png = coloured_png(&small, wheel_colour)?;
            let hist = histogram_svg(small.data(), 0.0, 360.0);
            return Ok(img(
                &png,
                " · angle: hue wheel (0° red, 120° green, 240° blue), circular block means",
                hist,
            ));
        }
        OutputKind::Continuous => {}
    }
    let log = !elevation && heavy_tailed(small.data(), lo, hi);
    let shown = if log {
        small.map(|v| {
            if v.is_nan() {
                v
            } else {
                (1.0 + v as f64).log10() as f32
            }
        })
    } else {
        small
    };
    let (slo, shi) = if log {
        ((1.0 + lo).log10(), (1.0 + hi).log10())
    } else {
        (lo, hi)
    };
    let mut georef = info.georef.clone();
    for k in [1, 2, 4, 5] {
        georef.transform[k] *= factor as f64;
    }
    georef.nodata = None;
    let hist = histogram_svg(shown.data(), slo, shi);
    let preview_src = MemRaster::new(AnyGrid::F32(shown), georef, p);
    let png = tmp.join("preview.png");
    let opts = RenderOptions {
        range: (slo <= shi).then_some((slo, shi)),
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
    let note = if log {
        " · log scale: colours and histogram of log10(1 + value)"
    } else {
        ""
    };
    Ok(img(&bytes, note, hist))
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

/// Largest CSV read whole for a dedicated section.
const MAX_CSV_BYTES: u64 = 256 << 20;

/// Header and rows of a comma-separated file (no quoting: orogen's CSVs have none).
fn read_csv(p: &Path) -> Result<(Vec<String>, Vec<Vec<String>>)> {
    let len = std::fs::metadata(p).map_err(|e| Error::io(p, e))?.len();
    if len > MAX_CSV_BYTES {
        return Err(Error::too_large(p, "CSV over 256 MiB; not summarised"));
    }
    let text = std::fs::read_to_string(p).map_err(|e| Error::io(p, e))?;
    let mut lines = text.lines();
    let header: Vec<String> = lines
        .next()
        .unwrap_or("")
        .split(',')
        .map(|c| c.trim().to_string())
        .collect();
    let rows = lines
        .filter(|l| !l.trim().is_empty())
        .map(|l| l.split(',').map(|c| c.trim().to_string()).collect())
        .collect();
    Ok((header, rows))
}

/// Column `j` of `rows` as numbers (unparsable and non-finite cells skipped).
fn column(rows: &[Vec<String>], j: usize) -> Vec<f64> {
    rows.iter()
        .filter_map(|r| r.get(j).and_then(|c| c.parse::<f64>().ok()))
        .filter(|v| v.is_finite())
        .collect()
}

/// The dedicated section of a CSV written by `orogen orostats` (disk
/// feature vectors) or `orogen basins --metrics` (one row per basin),
/// recognised by their columns; None for other CSVs.
fn special_csv_section(p: &Path) -> Result<Option<String>> {
    let (header, rows) = read_csv(p)?;
    let h: Vec<&str> = header.iter().map(|s| s.as_str()).collect();
    if h.len() > 5 && h[..5] == ["label", "source", "col", "row", "n_peaks"] {
        return Ok(Some(orostats_section(p, &header, &rows)?));
    }
    if h.len() > 6 && h[..3] == ["label", "outlet_col", "outlet_row"] {
        return Ok(Some(basins_section(p, &header, &rows)?));
    }
    Ok(None)
}

/// Mean of `v` (NaN when empty).
fn mean(v: &[f64]) -> f64 {
    if v.is_empty() {
        f64::NAN
    } else {
        v.iter().sum::<f64>() / v.len() as f64
    }
}

/// Orometric statistics (Argudo et al. 2019, Table 1): per feature, the
/// mean histogram of the disks where the feature has values, as a bar
/// chart over its bins; a table of the per-disk scalars.
fn orostats_section(p: &Path, header: &[String], rows: &[Vec<String>]) -> Result<String> {
    let mut s = format!(
        "<div class='out'><h3>{} — orometric statistics</h3><p>{} disks (Table 1 features of Argudo et al. 2019; mean histogram of the disks with values)</p>",
        esc(&p.display().to_string()),
        rows.len()
    );
    // Feature columns: `name:lo-hi`, grouped by name in file order.
    let mut groups: Vec<(String, Vec<(usize, String)>)> = vec![];
    for (j, c) in header.iter().enumerate().skip(5) {
        if let Some((name, bin)) = c.split_once(':') {
            match groups.last_mut() {
                Some((n, v)) if n == name => v.push((j, bin.to_string())),
                _ => groups.push((name.to_string(), vec![(j, bin.to_string())])),
            }
        }
    }
    let _ = write!(
        s,
        "<table><tr><th>figure</th><th>mean over disks</th></tr><tr><td>peaks per disk</td><td>{}</td></tr>",
        fmt_num(mean(&column(rows, 4)))
    );
    for name in ["density_per_100km2", "nni"] {
        if let Some(j) = header.iter().position(|c| c == name) {
            let _ = write!(
                s,
                "<tr><td>{name}</td><td>{}</td></tr>",
                fmt_num(mean(&column(rows, j)))
            );
        }
    }
    s.push_str("</table></div>");
    for (name, cols) in &groups {
        let nb = cols.len();
        let mut sum = vec![0.0; nb];
        let mut n = 0usize;
        for r in rows {
            let v: Vec<f64> = cols
                .iter()
                .map(|(j, _)| r.get(*j).and_then(|c| c.parse().ok()).unwrap_or(0.0))
                .collect();
            if v.iter().sum::<f64>() > 0.0 {
                n += 1;
                for (a, b) in sum.iter_mut().zip(&v) {
                    *a += b;
                }
            }
        }
        let ys: Vec<f64> = sum.iter().map(|v| v / n.max(1) as f64).collect();
        let ymax = ys.iter().copied().fold(0.0, f64::max).max(1e-9);
        let series = vec![Series {
            label: name.clone(),
            colour: COLOUR_A,
            style: Style::Bars,
            xs: (0..=nb).map(|i| i as f64).collect(),
            ys,
        }];
        let png = Chart {
            width: 320,
            height: 140,
            x_range: (0.0, nb as f64),
            y_range: (0.0, ymax),
            series,
        }
        .to_png()?;
        let bins: Vec<&str> = cols.iter().map(|(_, b)| b.as_str()).collect();
        let _ = write!(
            s,
            "<div class='out'><h3>{}</h3>{}<p class='key'>{n} disks with values; bins {}</p></div>",
            esc(name),
            png_img(&png, name),
            esc(&bins.join(", ").replace("inf", "∞"))
        );
    }
    Ok(s)
}

/// Bar chart of the histogram of `v` in `bins` equal bins over its range.
fn histogram_png(v: &[f64], bins: usize) -> Result<(Vec<u8>, f64, f64)> {
    let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let (lo, hi) = if lo.is_finite() { (lo, hi) } else { (0.0, 1.0) };
    let span = if hi > lo { hi - lo } else { 1.0 };
    let mut c = vec![0.0; bins];
    for &x in v {
        c[(((x - lo) / span * bins as f64) as usize).min(bins - 1)] += 1.0;
    }
    let ymax = c.iter().copied().fold(1.0, f64::max);
    let png = Chart {
        width: 320,
        height: 140,
        x_range: (lo, lo + span),
        y_range: (0.0, ymax),
        series: vec![Series {
            label: String::new(),
            colour: COLOUR_A,
            style: Style::Bars,
            xs: (0..=bins)
                .map(|i| lo + span * i as f64 / bins as f64)
                .collect(),
            ys: c,
        }],
    }
    .to_png()?;
    Ok((png, lo, hi))
}

/// Basin metrics (`orogen basins --metrics`): a summary table of every
/// metric (count, min, median, mean, max), distributions of a few, and the
/// mean hypsometric curve.
fn basins_section(p: &Path, header: &[String], rows: &[Vec<String>]) -> Result<String> {
    let mut s = format!(
        "<div class='out'><h3>{} — basin metrics</h3><p>{} basins</p><table><tr><th>metric</th><th>n</th><th>min</th><th>median</th><th>mean</th><th>max</th></tr>",
        esc(&p.display().to_string()),
        rows.len()
    );
    let first = header.iter().position(|c| c == "cells").unwrap_or(5);
    for (j, name) in header.iter().enumerate().skip(first) {
        if name.starts_with("hyp_") {
            continue;
        }
        let mut v = column(rows, j);
        v.sort_by(f64::total_cmp);
        let med = if v.is_empty() {
            f64::NAN
        } else {
            v[v.len() / 2]
        };
        let _ = write!(
            s,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            esc(name),
            v.len(),
            fmt_num(v.first().copied().unwrap_or(f64::NAN)),
            fmt_num(med),
            fmt_num(mean(&v)),
            fmt_num(v.last().copied().unwrap_or(f64::NAN))
        );
    }
    s.push_str("</table></div>");
    for name in ["area_m2", "relief", "hypsometric_integral", "circularity"] {
        let Some(j) = header.iter().position(|c| c == name) else {
            continue;
        };
        let mut v = column(rows, j);
        let shown = if name == "area_m2" {
            v.retain(|x| *x > 0.0);
            v.iter_mut().for_each(|x| *x = x.log10());
            "log10 area_m2"
        } else {
            name
        };
        if v.is_empty() {
            continue;
        }
        let (png, lo, hi) = histogram_png(&v, 30)?;
        let _ = write!(
            s,
            "<div class='out'><h3>{shown}</h3>{}<p class='key'>{} basins, {} to {}</p></div>",
            png_img(&png, shown),
            v.len(),
            fmt_num(lo),
            fmt_num(hi)
        );
    }
    let hyp: Vec<(usize, f64)> = header
        .iter()
        .enumerate()
        .filter_map(|(j, c)| {
            c.strip_prefix("hyp_")
                .and_then(|h| h.parse().ok())
                .map(|h| (j, h))
        })
        .collect();
    if hyp.len() >= 2 {
        let ys: Vec<f64> = hyp.iter().map(|&(j, _)| mean(&column(rows, j))).collect();
        let png = Chart {
            width: 320,
            height: 200,
            x_range: (0.0, 1.0),
            y_range: (0.0, 1.0),
            series: vec![Series {
                label: "mean".into(),
                colour: COLOUR_A,
                style: Style::Line,
                xs: hyp.iter().map(|&(_, h)| h).collect(),
                ys,
            }],
        }
        .to_png()?;
        let _ = write!(
            s,
            "<div class='out'><h3>mean hypsometric curve</h3>{}<p class='key'>x: column hyp_h of the CSV, y: its mean over the basins</p></div>",
            png_img(&png, "mean hypsometric curve")
        );
    }
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
        if s.output.is_none() && s.extra_outputs.is_empty() {
            continue;
        }
        let _ = write!(body, "<h2 class='step'>{}</h2>", esc(&s.name));
        let files = s
            .output
            .iter()
            .flat_map(|o| output_files(o))
            .chain(s.extra_outputs.iter().cloned());
        for f in files {
            let ext = f
                .extension()
                .and_then(|e| e.to_str())
                .unwrap_or("")
                .to_ascii_lowercase();
            let part = if is_raster(&f) {
                let kind = metric_file_kind(&f)
                    .filter(|_| s.command_line.split_whitespace().nth(1) == Some("metric"))
                    .unwrap_or(s.kind);
                raster_section(&f, s.elevation, kind, s.classes, tmpdir.path())
            } else if ext == "csv" {
                special_csv_section(&f).and_then(|o| match o {
                    Some(html) => Ok(html),
                    None => csv_section(&f),
                })
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
    drop(tmpdir);
    write_html(path, &html_page(title, &body))
}

/// A self-contained HTML page (inline CSS) around `body`.
pub fn html_page(title: &str, body: &str) -> String {
    format!(
        "<!doctype html><html><head><meta charset='utf-8'><title>{}</title><style>\
body{{font-family:sans-serif;margin:2em;max-width:1200px}}table{{border-collapse:collapse;margin:.5em 0}}\
td,th{{border:1px solid #ccc;padding:2px 6px;font-size:13px;text-align:left}}\
.out{{display:inline-block;vertical-align:top;margin:0 1em 1em 0}}img{{display:block;max-width:512px}}\
h3{{font-size:14px;word-break:break-all;max-width:512px}}.key{{font-size:12px}}</style></head><body>{body}</body></html>",
        esc(title)
    )
}

/// Write an HTML page atomically (temporary name, then rename).
pub fn write_html(path: &Path, html: &str) -> Result<()> {
    crate::io::atomic::write_file_atomic(path, html.as_bytes())
}

/// An `<img>` tag holding PNG `bytes` inline (base64 data URI).
pub fn png_img(bytes: &[u8], alt: &str) -> String {
    let b64 = base64::engine::general_purpose::STANDARD.encode(bytes);
    format!("<img src='data:image/png;base64,{b64}' alt='{}'>", esc(alt))
}

/// How a [`Series`] is drawn.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Style {
    /// Polyline through (xs[i], ys[i]).
    Line,
    /// Histogram: bar i spans xs[i]..xs[i+1] (xs has one more entry than
    /// ys), drawn half-transparent so overlaid histograms stay readable.
    Bars,
}

/// One data series of a [`Chart`].
#[derive(Debug, Clone)]
pub struct Series {
    pub label: String,
    pub colour: [u8; 3],
    pub style: Style,
    pub xs: Vec<f64>,
    pub ys: Vec<f64>,
}

/// A small PNG chart: overlaid histograms and curves on common axes, with
/// the axis ranges written at the ends of the axes. Titles and legends are
/// left to the HTML around it (the bitmap font has digits only).
#[derive(Debug, Clone)]
pub struct Chart {
    pub width: usize,
    pub height: usize,
    pub x_range: (f64, f64),
    pub y_range: (f64, f64),
    pub series: Vec<Series>,
}

/// Colours of the first and second terrain in comparisons (blue, orange).
pub const COLOUR_A: [u8; 3] = [51, 102, 204];
pub const COLOUR_B: [u8; 3] = [220, 110, 30];

/// An axis label without exponent notation (the glyphs are digits, '-', '.').
fn axis_label(v: f64) -> String {
    let a = v.abs();
    let s = if !v.is_finite() {
        String::new()
    } else if a >= 100.0 || v.fract() == 0.0 {
        format!("{v:.0}")
    } else if a >= 1.0 {
        format!("{v:.2}")
    } else if a >= 1e-3 {
        format!("{v:.4}")
    } else {
        format!("{v:.7}")
    };
    if s == "-0" {
        "0".into()
    } else {
        s
    }
}

impl Chart {
    /// Margins of the plot area: left, right, top, bottom (pixels).
    const MARGIN: (usize, usize, usize, usize) = (8, 8, 18, 18);

    /// Render to PNG bytes (8-bit RGBA). Non-finite values are skipped.
    pub fn to_png(&self) -> Result<Vec<u8>> {
        let (w, h) = (self.width.max(64), self.height.max(48));
        let mut px = vec![255u8; w * h * 4];
        let (ml, mr, mt, mb) = Self::MARGIN;
        let (pw, ph) = ((w - ml - mr) as f64, (h - mt - mb) as f64);
        let (x0, x1) = self.x_range;
        let (y0, y1) = self.y_range;
        let sx = if x1 > x0 { pw / (x1 - x0) } else { 0.0 };
        let sy = if y1 > y0 { ph / (y1 - y0) } else { 0.0 };
        let to_px = |x: f64, y: f64| -> (f64, f64) {
            (
                ml as f64 + (x.clamp(x0, x1) - x0) * sx,
                (h - mb) as f64 - (y.clamp(y0, y1) - y0) * sy,
            )
        };
        let blend = |px: &mut [u8], x: i64, y: i64, c: [u8; 3], a: f64| {
            if x >= 0 && y >= 0 && (x as usize) < w && (y as usize) < h {
                let i = (y as usize * w + x as usize) * 4;
                for (p, &ck) in px[i..i + 3].iter_mut().zip(&c) {
                    *p = (*p as f64 * (1.0 - a) + ck as f64 * a).round() as u8;
                }
            }
        };
        for s in &self.series {
            match s.style {
                Style::Bars => {
                    for (i, &v) in s.ys.iter().enumerate() {
                        let (Some(&xa), Some(&xb)) = (s.xs.get(i), s.xs.get(i + 1)) else {
                            break;
                        };
                        if !(v.is_finite() && xa.is_finite() && xb.is_finite()) {
                            continue;
                        }
                        let (pa, top) = to_px(xa, v);
                        let (pb, base) = to_px(xb, y0.max(0.0).min(y1));
                        let (ya, yb) = (top.min(base).round() as i64, top.max(base).round() as i64);
                        for y in ya..yb {
                            for x in
                                pa.round() as i64..(pb.round() as i64).max(pa.round() as i64 + 1)
                            {
                                blend(&mut px, x, y, s.colour, 0.45);
                            }
                        }
                    }
                }
                Style::Line => {
                    let pts: Vec<(f64, f64)> =
                        s.xs.iter()
                            .zip(&s.ys)
                            .filter(|(x, y)| x.is_finite() && y.is_finite())
                            .map(|(&x, &y)| to_px(x, y))
                            .collect();
                    for seg in pts.windows(2) {
                        let (a, b) = (seg[0], seg[1]);
                        let n = ((b.0 - a.0).abs().max((b.1 - a.1).abs()).ceil() as usize).max(1);
                        for k in 0..=n {
                            let t = k as f64 / n as f64;
                            let (x, y) = (a.0 + (b.0 - a.0) * t, a.1 + (b.1 - a.1) * t);
                            for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                                blend(&mut px, x as i64 + dx, y as i64 + dy, s.colour, 1.0);
                            }
                        }
                    }
                }
            }
        }
        // Axes and their ranges.
        for x in ml..w - mr {
            blend(&mut px, x as i64, (h - mb) as i64, [90, 90, 90], 1.0);
        }
        for y in mt..=h - mb {
            blend(&mut px, ml as i64, y as i64, [90, 90, 90], 1.0);
        }
        use crate::tiles::render::{draw_text, text_width};
        let (lx0, lx1, ly1) = (axis_label(x0), axis_label(x1), axis_label(y1));
        draw_text(&mut px, w, ml, h - mb + 5, &lx0);
        draw_text(
            &mut px,
            w,
            (w - mr).saturating_sub(text_width(&lx1)),
            h - mb + 5,
            &lx1,
        );
        draw_text(&mut px, w, ml + 3, 3, &ly1);
        let mut out = Vec::new();
        crate::io::png::encode_png(&mut out, w as u32, h as u32, ::png::ColorType::Rgba, &px)
            .map_err(|e| Error::invalid(format!("chart PNG encoding failed: {e}")))?;
        Ok(out)
    }
}

/// HTML key for the series of a chart (coloured squares and labels).
pub fn chart_key(series: &[Series]) -> String {
    let mut s = String::from("<div class='key'>");
    for se in series {
        let [r, g, b] = se.colour;
        let _ = write!(
            s,
            "<span style='color:rgb({r},{g},{b})'>&#9632;</span> {} &nbsp; ",
            esc(&se.label)
        );
    }
    s.push_str("</div>");
    s
}

/// A private scratch folder next to `path` for preview PNGs.
fn tempfile_dir(path: &Path) -> Result<ScratchDir> {
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."))
        .join(format!(".orogen-report-{}", std::process::id()));
    ScratchDir::new(dir).create()
}
