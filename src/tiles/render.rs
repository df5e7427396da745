//! Preview renderer: an 8-bit RGBA PNG of a raster of any size.
//!
//! The source is streamed in bands of `k` rows (and column chunks bounded to
//! [`CHUNK_CELLS`] cells), each `k x k` block averaged ignoring nodata into a
//! small grid, so peak memory depends on the preview size, not the raster's.
//!
//! Elevation previews blend a hypsometric tint with a hillshade: Horn's
//! gradient and Lambertian shading (`metrics::terrain::hillshade_grid`, light
//! at azimuth 315°, altitude 45° by default) on the downsampled grid with its
//! true metric cell size, combined by the "soft light" blend in the form
//! published by Pegtop (pegtop.net, "Soft light" blend mode):
//! `out = (1 - 2s)·c² + 2s·c` (c = tint, s = shade in 0..1; s = 0.5 leaves
//! the tint unchanged). The shade is normalised so that flat ground gives
//! s = 0.5 (with a mild contrast gain of 0.7): flat areas show the exact ramp
//! colour, slopes lit by the sun are lighter and slopes facing away darker.
//!
//! Colours: the land ramp is a hypsometric tint in the tradition of Imhof
//! (1982, *Cartographic Relief Presentation*): green (low) -> yellow -> brown
//! -> grey -> white (high), over the data's min..max or a given range.
//! Sea: when `sea` is on and the range reaches 0 or below while the maximum is
//! above 0 (a DEM with sea, like SRTM coasts where the sea is 0), cells <= 0
//! are blue (darker deeper) and the land ramp starts above 0. Nodata is
//! transparent (alpha 0). Other rasters (slope, hillshade, indices) use
//! [`RenderKind::Grey`] or a named ramp, without hillshade.

use crate::error::{Error, Result};
use crate::io::png::{encode_png, write_atomic};
use crate::metrics::neighbourhood::EdgeMode;
use crate::metrics::terrain::{hillshade_grid, Hillshade};
use crate::raster::{read_window, GeoRef, Grid, OutputKind, RasterSource, Window};
use std::path::Path;

/// Most source cells read at once while downsampling (16 MiB of f32).
pub const CHUNK_CELLS: usize = 1 << 22;

/// What the raster holds, which decides how it is coloured.
#[derive(Debug, Clone, PartialEq)]
pub enum RenderKind {
    /// Elevation: hypsometric tint blended with a hillshade.
    Elevation,
    /// Any value mapped to grey, black (min) to white (max), no hillshade.
    Grey,
    /// Any value mapped through a named ramp (see [`RAMPS`]), no hillshade.
    Ramp(String),
}

/// Named colour ramps for [`RenderKind::Ramp`].
pub const RAMPS: [&str; 4] = ["terrain", "viridis", "grey", "magma"];

/// Rendering options.
#[derive(Debug, Clone)]
pub struct RenderOptions {
    pub kind: RenderKind,
    /// Longest side of the image in pixels (the data part, legend excluded).
    pub max_size: usize,
    /// Value range mapped to the ramp ends; `None` = the data's min..max.
    pub range: Option<(f64, f64)>,
    /// Draw a colour bar with min/max labels below the image (needs >= 64 px width).
    pub legend: bool,
    /// Light azimuth (degrees clockwise from north) and altitude (degrees).
    pub azimuth: f64,
    pub altitude: f64,
    /// Vertical exaggeration of the hillshade.
    pub z_factor: f64,
    /// Colour cells <= 0 as sea when the data spans 0 (Elevation only).
    pub sea: bool,
    /// Cell size in metres for rasters without georeference (PNG heightmaps);
    /// `None` = 1 m. Ignored for georeferenced rasters.
    pub cell_size_m: Option<f64>,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            kind: RenderKind::Elevation,
            max_size: 2048,
            range: None,
            legend: false,
            azimuth: 315.0,
            altitude: 45.0,
            z_factor: 1.0,
            sea: true,
            cell_size_m: None,
        }
    }
}

/// What was rendered.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderInfo {
    /// Image size in pixels (legend included).
    pub width: usize,
    pub height: usize,
    /// Each image pixel averages a `factor x factor` block of cells.
    pub factor: usize,
    /// Smallest and largest valid cell of the source (NaN if none).
    pub data_min: f64,
    pub data_max: f64,
    /// The range mapped onto the ramp.
    pub range: (f64, f64),
    /// True when cells <= 0 were drawn as sea.
    pub sea: bool,
    /// True when a legend was drawn.
    pub legend: bool,
}

/// Block means of `src` over `factor x factor` blocks (NaN where a block has
/// no valid cell), plus the exact min and max of the valid cells. Streams the
/// source in bands of `factor` rows and chunks of at most [`CHUNK_CELLS`]
/// cells; memory is the output plus one chunk.
pub fn downsample_mean(src: &dyn RasterSource, factor: usize) -> Result<(Grid<f32>, f64, f64)> {
    downsample(src, factor, OutputKind::Continuous)
}

/// [`downsample_mean`] by what the raster holds: the block mean of a
/// continuous quantity, the circular mean of an angle in degrees (the
/// direction of the summed unit vectors, in [0, 360); a block averaging
/// 350° and 10° is 0°, not 180°), and for class codes the block's centre
/// cell (nearest; a mean of D8 codes 1 and 128 is no code). Min and max
/// are exact for every kind.
pub fn downsample(
    src: &dyn RasterSource,
    factor: usize,
    kind: OutputKind,
) -> Result<(Grid<f32>, f64, f64)> {
    if factor == 0 {
        return Err(Error::invalid("downsampling factor must be at least 1"));
    }
    let info = src.info();
    let (w, h) = (info.width, info.height);
    let (ow, oh) = (w.div_ceil(factor), h.div_ceil(factor));
    let mut out = Grid::new(ow, oh, f32::NAN);
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    // Columns per chunk: a multiple of `factor` keeping a chunk of `factor`
    // rows under CHUNK_CELLS; rows per read: as many as fit in CHUNK_CELLS
    // (fewer than `factor` only for factors beyond 2048).
    let blocks_per_chunk = (CHUNK_CELLS / (factor * factor)).max(1);
    let chunk_w = (blocks_per_chunk * factor).min(w);
    let rows_per_read = (CHUNK_CELLS / chunk_w).max(1);
    // Sums: the values (continuous), cos and sin (angle); the centre cell (classes).
    let mut sum = vec![0f64; ow];
    let mut sum2 = vec![0f64; ow];
    let mut cnt = vec![0u64; ow];
    let centre = factor / 2;
    for by in 0..oh {
        let y0 = by * factor;
        let y_end = (y0 + factor).min(h);
        let cy = (y0 + centre).min(y_end - 1);
        sum.iter_mut().for_each(|s| *s = 0.0);
        sum2.iter_mut().for_each(|s| *s = 0.0);
        cnt.iter_mut().for_each(|c| *c = 0);
        let mut x0 = 0;
        while x0 < w {
            let cw = chunk_w.min(w - x0);
            let mut yy = y0;
            while yy < y_end {
                let rh = rows_per_read.min(y_end - yy);
                let win = Window::new(x0 as i64, yy as i64, cw, rh);
                let g: Grid<f32> = read_window(src, win)?;
                for y in 0..rh {
                    let at_centre = yy + y == cy;
                    for (x, &v) in g.row(y).iter().enumerate() {
                        if v.is_nan() {
                            continue;
                        }
                        let v = v as f64;
                        lo = lo.min(v);
                        hi = hi.max(v);
                        let gx = x0 + x;
                        let b = gx / factor;
                        match kind {
                            OutputKind::Continuous => {
                                sum[b] += v;
                                cnt[b] += 1;
                            }
                            OutputKind::Angle => {
                                let r = v.to_radians();
                                sum[b] += r.cos();
                                sum2[b] += r.sin();
                                cnt[b] += 1;
                            }
                            OutputKind::Categorical => {
                                let cx = (b * factor + centre).min(w - 1);
                                if at_centre && gx == cx {
                                    sum[b] = v;
                                    cnt[b] = 1;
                                }
                            }
                        }
                    }
                }
                yy += rh;
            }
            x0 += cw;
        }
        for (bx, o) in out.row_mut(by).iter_mut().enumerate() {
            if cnt[bx] == 0 {
                continue;
            }
            *o = match kind {
                OutputKind::Continuous => (sum[bx] / cnt[bx] as f64) as f32,
                OutputKind::Angle => sum2[bx].atan2(sum[bx]).to_degrees().rem_euclid(360.0) as f32,
                OutputKind::Categorical => sum[bx] as f32,
            };
        }
    }
    if lo > hi {
        lo = f64::NAN;
        hi = f64::NAN;
    }
    Ok((out, lo, hi))
}

/// A colour ramp: stops (t in 0..1, r, g, b), t increasing, first t = 0, last t = 1.
type Ramp = &'static [(f64, [u8; 3])];

/// Hypsometric land tint (green lowlands, yellow, browns, grey rock, white peaks).
const TERRAIN: Ramp = &[
    (0.00, [52, 118, 64]),
    (0.12, [96, 152, 80]),
    (0.28, [168, 190, 106]),
    (0.42, [226, 212, 138]),
    (0.56, [205, 160, 100]),
    (0.70, [160, 116, 84]),
    (0.84, [158, 150, 144]),
    (1.00, [255, 255, 255]),
];
/// Sea, from the deepest cell (t = 0) to the shore (t = 1).
const SEA: Ramp = &[
    (0.0, [20, 50, 110]),
    (0.7, [60, 110, 170]),
    (1.0, [120, 170, 210]),
];
/// Viridis (perceptually uniform; stops sampled from the matplotlib definition).
const VIRIDIS: Ramp = &[
    (0.00, [68, 1, 84]),
    (0.25, [59, 82, 139]),
    (0.50, [33, 145, 140]),
    (0.75, [94, 201, 98]),
    (1.00, [253, 231, 37]),
];
/// Magma (stops sampled from the matplotlib definition).
const MAGMA: Ramp = &[
    (0.00, [0, 0, 4]),
    (0.25, [81, 18, 124]),
    (0.50, [183, 55, 121]),
    (0.75, [252, 137, 97]),
    (1.00, [252, 253, 191]),
];
const GREY: Ramp = &[(0.0, [0, 0, 0]), (1.0, [255, 255, 255])];

/// Colour of `t` (clamped to 0..1) on `ramp`, linear between stops.
fn ramp_rgb(ramp: Ramp, t: f64) -> [f64; 3] {
    let t = t.clamp(0.0, 1.0);
    let mut i = 1;
    while i < ramp.len() - 1 && ramp[i].0 < t {
        i += 1;
    }
    let (t0, c0) = ramp[i - 1];
    let (t1, c1) = ramp[i];
    let f = if t1 > t0 { (t - t0) / (t1 - t0) } else { 0.0 };
    let f = f.clamp(0.0, 1.0);
    [0, 1, 2].map(|k| c0[k] as f64 + (c1[k] as f64 - c0[k] as f64) * f)
}

/// The ramp called `name` (see [`RAMPS`]).
fn named_ramp(name: &str) -> Result<Ramp> {
    Ok(match name.to_ascii_lowercase().as_str() {
        "terrain" => TERRAIN,
        "viridis" => VIRIDIS,
        "grey" | "gray" => GREY,
        "magma" => MAGMA,
        _ => {
            return Err(Error::invalid(format!(
                "unknown colour ramp `{name}`; known ramps: {}",
                RAMPS.join(", ")
            )))
        }
    })
}

/// A 256-entry lookup table of the named ramp (entry i = colour at i/255),
/// for per-pixel colouring without interpolation cost.
pub fn ramp_lut(name: &str) -> Result<[[u8; 3]; 256]> {
    let r = named_ramp(name)?;
    let mut lut = [[0u8; 3]; 256];
    for (i, c) in lut.iter_mut().enumerate() {
        let v = ramp_rgb(r, i as f64 / 255.0);
        *c = v.map(|x| x.round().clamp(0.0, 255.0) as u8);
    }
    Ok(lut)
}

/// The first and last colour of a named ramp (for checks and legends).
pub fn ramp_ends(name: &str) -> Result<([u8; 3], [u8; 3])> {
    let r = named_ramp(name)?;
    Ok((r[0].1, r[r.len() - 1].1))
}

/// Render `src` to an RGBA PNG at `out` (written atomically). See the module
/// doc for the colouring; a raster without valid cells gives a fully
/// transparent image.
pub fn render_preview(
    src: &dyn RasterSource,
    out: &Path,
    opts: &RenderOptions,
) -> Result<RenderInfo> {
    let info = src.info();
    if opts.max_size == 0 {
        return Err(Error::invalid("render max_size must be at least 1"));
    }
    if info.width == 0 || info.height == 0 {
        return Err(Error::invalid(format!(
            "{}: empty raster",
            info.path.display()
        )));
    }
    if let Some((a, b)) = opts.range {
        if !(a.is_finite() && b.is_finite() && b > a) {
            return Err(Error::invalid(format!(
                "render range must be finite with max > min (got {a}..{b})"
            )));
        }
    }
    let ramp = match &opts.kind {
        RenderKind::Elevation => TERRAIN,
        RenderKind::Grey => GREY,
        RenderKind::Ramp(n) => named_ramp(n)?,
    };
    let factor = info.width.max(info.height).div_ceil(opts.max_size);
    let (small, dmin, dmax) = downsample_mean(src, factor)?;
    let (w, h) = (small.width(), small.height());
    let (lo, hi) = opts.range.unwrap_or((dmin, dmax));
    let elevation = opts.kind == RenderKind::Elevation;
    let sea = elevation && opts.sea && lo <= 0.0 && hi > 0.0;

    // Hillshade on the downsampled grid with the downsampled cell size.
    let shade = if elevation && lo.is_finite() {
        let mut g = info.georef.clone();
        if !g.georeferenced {
            let c = opts.cell_size_m.unwrap_or(1.0);
            g = GeoRef::north_up(0.0, 0.0, c, Default::default());
        }
        let k = factor as f64;
        for i in [1, 2, 4, 5] {
            g.transform[i] *= k;
        }
        let hs = Hillshade {
            azimuth: opts.azimuth,
            altitude: opts.altitude,
            z_factor: opts.z_factor,
            edge: EdgeMode::Compute,
        };
        Some(hillshade_grid(&small, &g, &hs))
    } else {
        None
    };
    // Shade of flat ground on gdaldem's 1..255 scale, mapped to s = 0.5.
    let flat = 1.0 + 254.0 * opts.altitude.to_radians().sin().max(1e-3);

    let legend = opts.legend && w >= 64 && lo.is_finite();
    let lh = if legend { LEGEND_H } else { 0 };
    let (iw, ih) = (w, h + lh);
    let mut rgba = vec![0u8; iw * ih * 4];
    let span = hi - lo;
    let colour = |v: f64| -> [f64; 3] {
        if sea && v <= 0.0 {
            let t = if lo < 0.0 { 1.0 - v / lo } else { 1.0 };
            ramp_rgb(SEA, t)
        } else {
            let base = if sea { 0.0 } else { lo };
            let t = if hi > base {
                (v - base) / (hi - base)
            } else {
                0.5
            };
            ramp_rgb(ramp, t)
        }
    };
    for y in 0..h {
        for x in 0..w {
            let v = small.get(x, y);
            if v.is_nan() {
                continue;
            }
            let mut c = colour(v as f64);
            if let Some(sh) = &shade {
                let s = (0.5 + SHADE_GAIN * (sh.get(x, y) as f64 / flat - 1.0)).clamp(0.0, 1.0);
                c = c.map(|c| {
                    let c = c / 255.0;
                    255.0 * ((1.0 - 2.0 * s) * c * c + 2.0 * s * c)
                });
            }
            let i = (y * iw + x) * 4;
            for k in 0..3 {
                rgba[i + k] = c[k].round().clamp(0.0, 255.0) as u8;
            }
            rgba[i + 3] = 255;
        }
    }
    if legend {
        let unit = if elevation { "m" } else { "" };
        draw_legend(&mut rgba, iw, h, lo, hi, span, unit, &colour);
    }
    let (Ok(w32), Ok(h32)) = (u32::try_from(iw), u32::try_from(ih)) else {
        return Err(Error::invalid("preview too large"));
    };
    let mut bytes = Vec::new();
    encode_png(&mut bytes, w32, h32, ::png::ColorType::Rgba, &rgba)
        .map_err(|e| Error::io(out, std::io::Error::other(e.to_string())))?;
    write_atomic(out, &bytes)?;
    Ok(RenderInfo {
        width: iw,
        height: ih,
        factor,
        data_min: dmin,
        data_max: dmax,
        range: (lo, hi),
        sea,
        legend,
    })
}

/// Contrast of the hillshade in the blend: s = 0.5 + gain·(shade/flat − 1).
/// 0.5 would be the plain ratio; a little more reads better at preview scale.
const SHADE_GAIN: f64 = 0.7;

/// Height of the legend strip in pixels.
const LEGEND_H: usize = 34;
/// Glyph scale of legend text (5-row glyphs drawn 2x: 10 px).
const FONT_SCALE: usize = 2;

/// A 5-row bitmap glyph: width in pixels and one bit mask per row (MSB = left).
fn glyph(c: char) -> Option<(usize, [u8; 5])> {
    Some(match c {
        '0' => (3, [0b111, 0b101, 0b101, 0b101, 0b111]),
        '1' => (3, [0b010, 0b110, 0b010, 0b010, 0b111]),
        '2' => (3, [0b111, 0b001, 0b111, 0b100, 0b111]),
        '3' => (3, [0b111, 0b001, 0b111, 0b001, 0b111]),
        '4' => (3, [0b101, 0b101, 0b111, 0b001, 0b001]),
        '5' => (3, [0b111, 0b100, 0b111, 0b001, 0b111]),
        '6' => (3, [0b111, 0b100, 0b111, 0b101, 0b111]),
        '7' => (3, [0b111, 0b001, 0b010, 0b010, 0b010]),
        '8' => (3, [0b111, 0b101, 0b111, 0b101, 0b111]),
        '9' => (3, [0b111, 0b101, 0b111, 0b001, 0b111]),
        '-' => (3, [0b000, 0b000, 0b111, 0b000, 0b000]),
        '.' => (1, [0b0, 0b0, 0b0, 0b0, 0b1]),
        'm' => (5, [0b00000, 0b11010, 0b10101, 0b10101, 0b10101]),
        _ => return None,
    })
}

/// Width in pixels of `s` drawn with [`draw_text`].
pub(crate) fn text_width(s: &str) -> usize {
    s.chars()
        .filter_map(glyph)
        .map(|(w, _)| (w + 1) * FONT_SCALE)
        .sum::<usize>()
        .saturating_sub(FONT_SCALE)
}

/// Draw `s` in dark grey with its top-left at (x, y); clipped to the image.
pub(crate) fn draw_text(rgba: &mut [u8], iw: usize, x: usize, y: usize, s: &str) {
    let ih = rgba.len() / 4 / iw;
    let mut cx = x;
    for ch in s.chars() {
        let Some((gw, rows)) = glyph(ch) else {
            continue;
        };
        for (r, bits) in rows.iter().enumerate() {
            for c in 0..gw {
                if bits >> (gw - 1 - c) & 1 == 0 {
                    continue;
                }
                for dy in 0..FONT_SCALE {
                    for dx in 0..FONT_SCALE {
                        let (px, py) = (cx + c * FONT_SCALE + dx, y + r * FONT_SCALE + dy);
                        if px < iw && py < ih {
                            let i = (py * iw + px) * 4;
                            rgba[i..i + 4].copy_from_slice(&[40, 40, 40, 255]);
                        }
                    }
                }
            }
        }
        cx += (gw + 1) * FONT_SCALE;
    }
}

/// Format a legend label with precision suited to the range's span.
fn label(v: f64, span: f64, unit: &str) -> String {
    let s = if span >= 100.0 {
        format!("{v:.0}")
    } else if span >= 1.0 {
        format!("{v:.1}")
    } else {
        format!("{v:.3}")
    };
    let s = if s == "-0" { "0".to_string() } else { s };
    format!("{s}{unit}")
}

/// Draw the legend strip below row `top`: white background, a colour bar
/// spanning the ramp, min label at the left and max label at the right.
#[allow(clippy::too_many_arguments)]
fn draw_legend(
    rgba: &mut [u8],
    iw: usize,
    top: usize,
    lo: f64,
    hi: f64,
    span: f64,
    unit: &str,
    colour: &dyn Fn(f64) -> [f64; 3],
) {
    for px in rgba[top * iw * 4..].chunks_exact_mut(4) {
        px.copy_from_slice(&[255, 255, 255, 255]);
    }
    let margin = 4;
    let bar_w = iw - 2 * margin;
    let (bar_y, bar_h) = (top + 4, 12);
    for bx in 0..bar_w {
        let v = lo + (hi - lo) * bx as f64 / (bar_w - 1).max(1) as f64;
        let c = colour(v);
        for y in bar_y..bar_y + bar_h {
            let i = (y * iw + margin + bx) * 4;
            for k in 0..3 {
                rgba[i + k] = c[k].round().clamp(0.0, 255.0) as u8;
            }
            rgba[i + 3] = 255;
        }
    }
    let ty = bar_y + bar_h + 3;
    let lo_s = label(lo, span, unit);
    let hi_s = label(hi, span, unit);
    draw_text(rgba, iw, margin, ty, &lo_s);
    let hw = text_width(&hi_s);
    if hw + margin < iw && text_width(&lo_s) + hw + 3 * margin <= iw {
        draw_text(rgba, iw, iw - margin - hw, ty, &hi_s);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn downsampling_follows_the_kind() {
        use crate::raster::{AnyGrid, MemRaster};
        // One 4 x 2 block pair: left block angles 350 and 10 (mean 0, not
        // 180), codes 1 and 128 (a code of the block, not their mean 64.5).
        let ang = Grid::from_vec(
            4,
            2,
            vec![350.0f32, 10.0, 90.0, 90.0, 350.0, 10.0, 90.0, 180.0],
        )
        .unwrap();
        let src = MemRaster::new(AnyGrid::F32(ang), GeoRef::pixel(), "a");
        let (g, lo, hi) = downsample(&src, 2, OutputKind::Angle).unwrap();
        assert!(
            g.get(0, 0).abs() < 1e-4 || (g.get(0, 0) - 360.0).abs() < 1e-4,
            "{}",
            g.get(0, 0)
        );
        assert!((g.get(1, 0) - 108.434_95).abs() < 1e-3, "{}", g.get(1, 0));
        assert_eq!((lo, hi), (10.0, 350.0));
        let (m, _, _) = downsample(&src, 2, OutputKind::Continuous).unwrap();
        assert_eq!(m.get(0, 0), 180.0);
        let codes =
            Grid::from_vec(4, 2, vec![1.0f32, 128.0, 4.0, 4.0, 1.0, 1.0, 8.0, 8.0]).unwrap();
        let src = MemRaster::new(AnyGrid::F32(codes), GeoRef::pixel(), "c");
        let (g, _, _) = downsample(&src, 2, OutputKind::Categorical).unwrap();
        // The centre cell of a 2 x 2 block is its (1, 1) cell.
        assert_eq!((g.get(0, 0), g.get(1, 0)), (1.0, 8.0));
    }

    #[test]
    fn ramp_ends_and_interpolation() {
        assert_eq!(ramp_rgb(TERRAIN, 0.0), [52.0, 118.0, 64.0]);
        assert_eq!(ramp_rgb(TERRAIN, 1.0), [255.0, 255.0, 255.0]);
        assert_eq!(ramp_rgb(GREY, 0.5), [127.5, 127.5, 127.5]);
        assert_eq!(ramp_rgb(GREY, -3.0), [0.0; 3]);
        assert!(named_ramp("nope").is_err());
    }

    #[test]
    fn labels() {
        assert_eq!(label(4810.2, 4356.0, "m"), "4810m");
        assert_eq!(label(-12.0, 2000.0, "m"), "-12m");
        assert_eq!(label(0.25, 0.5, ""), "0.250");
        assert_eq!(text_width("10"), (4 + 4) * FONT_SCALE - FONT_SCALE);
    }
}
