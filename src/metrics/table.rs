//! The survey's cost table and correlation matrix (Argudo, Guérin, Schott &
//! Galin, "Terrain descriptors for landscape synthesis, analysis and
//! simulation", Tables 1-2 and Fig. 52): the single-threaded time of every
//! registered metric relative to slope at several radii, and the Pearson
//! correlation between all non-categorical metrics over the cells of a DEM.
//!
//! Both run in memory on the whole raster as one tile (the survey's setting:
//! a 647 x 647 DEM); the kernels are the ones `orogen metric` runs per tile.
//! Timings exclude reading and count only the metric's kernel (one
//! [`MultiMetric`] per metric, best of `repeats` runs).

use super::multi::MultiMetric;
use super::registry::{Length, MetricKind, MetricSpec, ParamKind, METRICS};
use crate::error::{Error, Result};
use crate::exec::LocalStep;
use crate::raster::{read_view, Grid, RasterInfo, RasterSource, TileLayout};
use std::path::Path;
use std::time::Instant;

/// One timed metric.
#[derive(Debug, Clone, PartialEq)]
pub struct CostRow {
    /// Registry name.
    pub name: &'static str,
    /// Radius in metres (None for metrics without a radius).
    pub radius_m: Option<f64>,
    /// Radius in cells after conversion (0 without a radius).
    pub radius_cells: usize,
    /// Best time over the repeats, seconds (NaN when skipped).
    pub seconds: f64,
    /// `seconds / slope's seconds`.
    pub relative: f64,
    /// Why it was skipped (radius beyond the raster or the cell limit).
    pub skipped: Option<String>,
}

/// Categorical or circular outputs, left out of the correlation matrix
/// (a Pearson coefficient of class codes or of angles that wrap at 360° is
/// not meaningful).
pub fn is_categorical(k: MetricKind) -> bool {
    super::registry::def(k).output != super::registry::OutputKind::Continuous
}

/// True if the metric takes a `radius` parameter.
pub fn has_radius(k: MetricKind) -> bool {
    super::registry::def(k)
        .params
        .iter()
        .any(|p| p.kind == ParamKind::Radius)
}

/// The spec of `kind` at `radius_m` metres (None: defaults). Weiss's
/// landforms get their large scale at three times the radius.
pub fn spec_at(kind: MetricKind, radius_m: Option<f64>) -> MetricSpec {
    let mut s = MetricSpec::new(kind);
    if let Some(r) = radius_m {
        if has_radius(kind) {
            s.radius = Some(Length::Metres(r));
            if kind == MetricKind::WeissLandform {
                s.radius2 = Some(Length::Metres(3.0 * r));
            }
        }
    }
    s
}

/// Compute `specs` on the whole raster as one tile, single-threaded;
/// returns the outputs and the kernel time in seconds (the best of at least
/// `repeats` runs, more while they take under 0.3 s in total).
pub fn run_whole(
    src: &dyn RasterSource,
    specs: &[MetricSpec],
    repeats: usize,
) -> Result<(Vec<Grid<f32>>, f64)> {
    let info = src.info();
    // Whole-raster metrics run their global passes on one tile.
    if specs
        .iter()
        .any(|s| super::peak_dw::is_whole_raster(s.kind))
    {
        return run_whole_global(src, specs, repeats);
    }
    let step = MultiMetric::new(specs, info)?;
    let layout = one_tile(info);
    let view = read_view::<f32>(src, &layout, 0, step.halo())?;
    let views = [view];
    let mut out: Vec<Grid<f32>> = specs
        .iter()
        .map(|_| Grid::new(info.width, info.height, f32::NAN))
        .collect();
    let best = best_time(repeats, || step.run(&views, &mut out))?;
    Ok((out, best))
}

/// The layout of the raster `info` as one tile.
fn one_tile(info: &RasterInfo) -> TileLayout {
    let (w, h) = (info.width, info.height);
    TileLayout::new(w, h, w.max(h).max(1))
}

/// The shortest time in seconds of at least `repeats` runs of `run`, and of
/// as many more as fit in about 0.3 s (at most 50): millisecond kernels on a
/// shared machine need them.
fn best_time(repeats: usize, mut run: impl FnMut() -> Result<()>) -> Result<f64> {
    let mut best = f64::INFINITY;
    let (mut runs, mut total) = (0usize, 0.0f64);
    while runs < repeats.max(1) || (total < 0.3 && runs < 50) {
        let t = Instant::now();
        run()?;
        let e = t.elapsed().as_secs_f64();
        best = best.min(e);
        total += e;
        runs += 1;
    }
    Ok(best)
}

/// [`run_whole`] for specs that include whole-raster metrics: the local ones
/// in one [`MultiMetric`] run, each whole-raster one through its global
/// passes on one tile, single-threaded; the times are summed.
fn run_whole_global(
    src: &dyn RasterSource,
    specs: &[MetricSpec],
    repeats: usize,
) -> Result<(Vec<Grid<f32>>, f64)> {
    let info = src.info();
    let local: Vec<MetricSpec> = specs
        .iter()
        .filter(|s| !super::peak_dw::is_whole_raster(s.kind))
        .cloned()
        .collect();
    let (mut local_out, mut total) = if local.is_empty() {
        (Vec::new(), 0.0)
    } else {
        run_whole(src, &local, repeats)?
    };
    local_out.reverse();
    let mut out = Vec::with_capacity(specs.len());
    for s in specs {
        if !super::peak_dw::is_whole_raster(s.kind) {
            out.push(
                local_out
                    .pop()
                    .ok_or_else(|| Error::invalid("metric table: missing output"))?,
            );
            continue;
        }
        super::registry::resolve(std::slice::from_ref(s), info)?;
        let cfg = crate::exec::EngineConfig {
            threads: 1,
            ..Default::default()
        };
        let layout = one_tile(info);
        let top = s.threshold.unwrap_or(super::peak_dw::DEFAULT_TOP);
        let proto = s.kind == MetricKind::PeakPrototypicality;
        let mut grid = None;
        let best = best_time(repeats, || {
            let (p, q) = super::peak_dw::run_to_memory(src, top, layout, &cfg, proto, !proto)?;
            grid = if proto { p } else { q };
            Ok(())
        })?;
        out.push(grid.ok_or_else(|| Error::invalid("peakedness_dw: no output"))?);
        total += best;
    }
    Ok((out, total))
}

/// Refuse rasters whose in-memory table would exceed `max_cells` cells.
pub fn check_size(src: &dyn RasterSource, max_cells: usize) -> Result<()> {
    let info = src.info();
    let cells = info.width.saturating_mul(info.height);
    if cells > max_cells {
        return Err(Error::too_large(
            &info.path,
            format!(
                "{}x{} = {cells} cells; the metric table runs in memory on the whole raster (limit {max_cells} cells): crop the DEM (orogen convert --window) or raise --max-cells",
                info.width, info.height
            ),
        ));
    }
    Ok(())
}

/// Time every registered metric (or those in `only`) relative to slope:
/// metrics with a radius once per radius of `radii_m`, the others once.
/// `progress` is called with each finished row.
pub fn cost_table(
    src: &dyn RasterSource,
    radii_m: &[f64],
    repeats: usize,
    only: Option<&[MetricKind]>,
    mut progress: impl FnMut(&CostRow),
) -> Result<Vec<CostRow>> {
    let (_, slope_t) = run_whole(src, &[MetricSpec::new(MetricKind::Slope)], repeats)?;
    let mut rows = Vec::new();
    for d in METRICS {
        if only.is_some_and(|o| !o.contains(&d.kind)) {
            continue;
        }
        let radii: Vec<Option<f64>> = if has_radius(d.kind) {
            radii_m.iter().map(|&r| Some(r)).collect()
        } else {
            vec![None]
        };
        for r in radii {
            let spec = spec_at(d.kind, r);
            let mut row = CostRow {
                name: d.name,
                radius_m: r,
                radius_cells: 0,
                seconds: f64::NAN,
                relative: f64::NAN,
                skipped: None,
            };
            match super::registry::resolve(std::slice::from_ref(&spec), src.info()).and_then(|r| {
                super::multi::check(std::slice::from_ref(&spec), src.info()).map(|_| r)
            }) {
                Err(e) => row.skipped = Some(e.to_string()),
                Ok(r) => {
                    row.radius_cells = r[0].radius_cells;
                    match run_whole(src, std::slice::from_ref(&spec), repeats) {
                        Ok((_, t)) => {
                            row.seconds = t;
                            row.relative = t / slope_t;
                        }
                        // A whole-raster metric can be undefined on a
                        // raster (peakedness_dw without any peak): skipped, said why.
                        Err(e) if super::peak_dw::is_whole_raster(d.kind) => {
                            row.skipped = Some(e.to_string())
                        }
                        Err(e) => return Err(e),
                    }
                }
            }
            progress(&row);
            rows.push(row);
        }
    }
    // Slope's own row is a second measurement of the baseline: keep the best.
    let base = rows
        .iter()
        .filter(|r| r.name == "slope" && r.seconds.is_finite())
        .map(|r| r.seconds)
        .fold(slope_t, f64::min);
    for r in rows.iter_mut() {
        if r.name == "slope" {
            r.seconds = base;
        }
        r.relative = r.seconds / base;
    }
    Ok(rows)
}

/// Cost rows as CSV: `metric,radius_m,radius_cells,seconds,relative_to_slope,skipped`.
pub fn cost_csv(rows: &[CostRow]) -> String {
    let mut s = String::from("metric,radius_m,radius_cells,seconds,relative_to_slope,skipped\n");
    for r in rows {
        s.push_str(&format!(
            "{},{},{},{:.6},{:.3},{}\n",
            r.name,
            r.radius_m.map(|m| m.to_string()).unwrap_or_default(),
            r.radius_cells,
            r.seconds,
            r.relative,
            r.skipped.as_deref().unwrap_or("").replace(',', ";")
        ));
    }
    s
}

/// Cost rows as a markdown table: one line per metric, one column per
/// radius (metrics without a radius in the first column).
pub fn cost_markdown(rows: &[CostRow], radii_m: &[f64]) -> String {
    let mut s = String::from("| metric | no radius |");
    for r in radii_m {
        s.push_str(&format!(" r = {r} m |"));
    }
    s.push_str("\n|---|---|");
    for _ in radii_m {
        s.push_str("---|");
    }
    s.push('\n');
    let fmt = |r: &CostRow| {
        if r.skipped.is_some() {
            "-".to_string()
        } else {
            format!("{:.2} ({}c)", r.relative, r.radius_cells)
        }
    };
    let mut names: Vec<&str> = rows.iter().map(|r| r.name).collect();
    names.dedup();
    for n in names {
        let mine: Vec<&CostRow> = rows.iter().filter(|r| r.name == n).collect();
        s.push_str(&format!("| {n} |"));
        if mine.len() == 1 && mine[0].radius_m.is_none() {
            s.push_str(&format!(" {:.2} |", mine[0].relative));
            for _ in radii_m {
                s.push_str(" |");
            }
        } else {
            s.push_str(" |");
            for r in radii_m {
                let c = mine
                    .iter()
                    .find(|x| x.radius_m == Some(*r))
                    .map(|x| fmt(x))
                    .unwrap_or_default();
                s.push_str(&format!(" {c} |"));
            }
        }
        s.push('\n');
    }
    s
}

/// Pearson correlation of `a` and `b` over the cells finite in both (NaN if
/// fewer than 2 or if either is constant there). Two passes (means, then
/// centred sums) in f64, in cell order: deterministic.
pub fn pearson(a: &[f32], b: &[f32]) -> f64 {
    let (mut n, mut sa, mut sb) = (0usize, 0.0f64, 0.0f64);
    for (&x, &y) in a.iter().zip(b) {
        if x.is_finite() && y.is_finite() {
            n += 1;
            sa += x as f64;
            sb += y as f64;
        }
    }
    if n < 2 {
        return f64::NAN;
    }
    let (ma, mb) = (sa / n as f64, sb / n as f64);
    let (mut sab, mut saa, mut sbb) = (0.0f64, 0.0f64, 0.0f64);
    for (&x, &y) in a.iter().zip(b) {
        if x.is_finite() && y.is_finite() {
            let (dx, dy) = (x as f64 - ma, y as f64 - mb);
            sab += dx * dy;
            saa += dx * dx;
            sbb += dy * dy;
        }
    }
    if saa == 0.0 || sbb == 0.0 {
        return f64::NAN;
    }
    (sab / (saa * sbb).sqrt()).clamp(-1.0, 1.0)
}

/// The correlation matrix of `specs` (labels, row-major n x n matrix).
pub fn correlation(
    src: &dyn RasterSource,
    specs: &[MetricSpec],
) -> Result<(Vec<String>, Vec<f64>)> {
    let (grids, _) = run_whole(src, specs, 1)?;
    let n = grids.len();
    let mut m = vec![f64::NAN; n * n];
    for i in 0..n {
        for j in i..n {
            let c = pearson(grids[i].data(), grids[j].data());
            m[i * n + j] = c;
            m[j * n + i] = c;
        }
    }
    Ok((specs.iter().map(|s| s.label()).collect(), m))
}

/// The non-categorical metrics at `radius_m` (those with a radius) or their
/// defaults, for the correlation matrix; radii that do not fit the raster
/// fall back to the metric's defaults, and metrics that cannot run on this
/// raster at all (e.g. solar metrics on a raster without a usable latitude)
/// are left out.
pub fn correlation_specs(src: &dyn RasterSource, radius_m: f64) -> Vec<MetricSpec> {
    let ok = |s: &MetricSpec| {
        super::multi::check(std::slice::from_ref(s), src.info()).is_ok()
            && (s.kind != MetricKind::PeakednessDw || super::peak_dw::has_peaks(src))
    };
    METRICS
        .iter()
        .filter(|d| !is_categorical(d.kind))
        .filter_map(|d| {
            let s = spec_at(d.kind, Some(radius_m));
            if ok(&s) {
                Some(s)
            } else {
                let s = MetricSpec::new(d.kind);
                ok(&s).then_some(s)
            }
        })
        .collect()
}

/// Correlation matrix as CSV (header row and column of labels).
pub fn correlation_csv(labels: &[String], m: &[f64]) -> String {
    let n = labels.len();
    let mut s = String::from("metric");
    for l in labels {
        s.push(',');
        s.push_str(l);
    }
    s.push('\n');
    for i in 0..n {
        s.push_str(&labels[i]);
        for j in 0..n {
            s.push_str(&format!(",{:.4}", m[i * n + j]));
        }
        s.push('\n');
    }
    s
}

/// 3x5 bitmaps of the digits 0-9, rows top to bottom, 3 bits per row (MSB left).
const DIGITS: [[u8; 5]; 10] = [
    [7, 5, 5, 5, 7],
    [2, 6, 2, 2, 7],
    [7, 1, 7, 4, 7],
    [7, 1, 7, 1, 7],
    [5, 5, 7, 1, 1],
    [7, 4, 7, 1, 7],
    [7, 4, 7, 5, 7],
    [7, 1, 1, 1, 1],
    [7, 5, 7, 5, 7],
    [7, 5, 7, 1, 7],
];

/// Diverging colour of a correlation: blue (−1), white (0), red (+1); grey for NaN.
pub fn corr_colour(c: f64) -> [u8; 3] {
    if !c.is_finite() {
        return [160, 160, 160];
    }
    let c = c.clamp(-1.0, 1.0);
    let f = |x: f64| (255.0 * (1.0 - x)).round() as u8;
    if c >= 0.0 {
        [255, f(c), f(c)]
    } else {
        [f(-c), f(-c), 255]
    }
}

/// Set pixel (x, y) of a `w x h` RGB image (ignored outside).
fn set_px(px: &mut [u8], w: usize, h: usize, x: usize, y: usize, c: [u8; 3]) {
    if x < w && y < h {
        px[(y * w + x) * 3..(y * w + x) * 3 + 3].copy_from_slice(&c);
    }
}

/// Draw decimal digits `s` in black with the 3x5 font scaled by `scale`,
/// top-left corner at (x0, y0).
fn draw_digits(px: &mut [u8], w: usize, h: usize, s: &str, x0: usize, y0: usize, scale: usize) {
    for (k, ch) in s.bytes().filter(u8::is_ascii_digit).enumerate() {
        let g = DIGITS[(ch - b'0') as usize];
        for (row, bits) in g.iter().enumerate() {
            for col in 0..3 {
                if bits & (4 >> col) == 0 {
                    continue;
                }
                for sy in 0..scale {
                    for sx in 0..scale {
                        let (x, y) = (x0 + (k * 4 + col) * scale + sx, y0 + row * scale + sy);
                        set_px(px, w, h, x, y, [0, 0, 0]);
                    }
                }
            }
        }
    }
}

/// Heat map of an n x n matrix as RGB pixels: `cell` pixels per entry,
/// rows and columns labelled by their 1-based index in a built-in 3x5 digit
/// font (the legend CSV maps indices to metric names). Returns (w, h, rgb).
pub fn heatmap_rgb(m: &[f64], n: usize, cell: usize) -> (usize, usize, Vec<u8>) {
    let scale = 2;
    let digits = n.max(1).to_string().len();
    let margin = digits * 4 * scale + 2 * scale;
    let (w, h) = (margin + n * cell, margin + n * cell);
    let mut px = vec![255u8; w * h * 3];
    for i in 0..n {
        for j in 0..n {
            let c = corr_colour(m[i * n + j]);
            for y in 0..cell {
                for x in 0..cell {
                    set_px(
                        &mut px,
                        w,
                        h,
                        margin + j * cell + x,
                        margin + i * cell + y,
                        c,
                    );
                }
            }
        }
        let label = (i + 1).to_string();
        // Row label at the left, column label at the top (centred in the cell).
        let ty = margin + i * cell + cell.saturating_sub(5 * scale) / 2;
        draw_digits(&mut px, w, h, &label, scale, ty, scale);
        let tx = margin + i * cell + cell.saturating_sub(label.len() * 4 * scale) / 2;
        draw_digits(&mut px, w, h, &label, tx, scale, scale);
    }
    (w, h, px)
}

/// Write the heat map PNG of the matrix to `path`.
pub fn write_heatmap(path: &Path, m: &[f64], n: usize) -> Result<()> {
    let (w, h, px) = heatmap_rgb(m, n, 20);
    let mut bytes = Vec::new();
    crate::io::png::encode_png(&mut bytes, w as u32, h as u32, ::png::ColorType::Rgb, &px)
        .map_err(|e| Error::invalid(format!("{}: PNG encoding failed: {e}", path.display())))?;
    crate::io::png::write_atomic(path, &bytes)
}
