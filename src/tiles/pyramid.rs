//! Web-map tile pyramids (EPSG:3857, XYZ tiling as used by MapLibre and
//! OpenStreetMap) from a DEM or any raster, in bounded memory.
//!
//! The deepest zoom is sampled from the source: for each tile, a 17 x 17
//! grid of exact projections (tile pixel → Web Mercator → lon/lat → source
//! map coordinates → source cell) is interpolated bilinearly for the 256²
//! pixels between (error < 1e-3 cell at the zooms a DEM's resolution calls
//! for; tested), and the source is read for that tile's footprint only.
//! Values are bilinear between the four nearest cell centres (nearest cell
//! when one of them is nodata, or with [`Resampling::Nearest`]). Every
//! shallower zoom is the 2x2 mean (or top-left, for nearest) of its four
//! children, built depth-first so at most a few tiles per level are held.
//!
//! Encodings (RGBA PNG, nodata fully transparent):
//! - Mapbox Terrain-RGB: `h = -10000 + (R·65536 + G·256 + B) · 0.1`;
//! - Terrarium (Mapzen/AWS terrain tiles): `h = R·256 + G + B/256 − 32768`;
//! - colour: a named ramp over a value range (default: the data's exact
//!   min..max), for hillshades and descriptors.
//!
//! Tiles go to `DIR/{z}/{x}/{y}.png` with `DIR/metadata.json` (TileJSON
//! fields); [`super::archive`] packs them into MBTiles and PMTiles files.
//! Each tile is written to a temporary and renamed into place, and
//! `metadata.json` last: a killed run leaves complete tiles, temporaries
//! (removed by the next run) and no `metadata.json`.

use crate::error::{Error, Result};
use crate::raster::proj::{lonlat_to_merc, merc_to_lonlat, SourceCrs};
use crate::raster::{read_window, Grid, RasterSource, Window};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Pixels per tile side.
pub const TILE: usize = 256;
const HALF_WORLD: f64 = std::f64::consts::PI * crate::raster::proj::A_WGS84;

/// How tile pixels are encoded.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Encoding {
    /// Mapbox Terrain-RGB elevation (0.1 m steps from −10000 m).
    TerrainRgb,
    /// Terrarium elevation (1/256 m steps from −32768 m).
    Terrarium,
    /// A colour ramp over `range` (None: the data's min..max).
    Color {
        ramp: String,
        range: Option<(f64, f64)>,
    },
}

/// Cell resampling.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Resampling {
    Bilinear,
    Nearest,
}

/// Options of [`build_pyramid`].
#[derive(Debug, Clone)]
pub struct PyramidOptions {
    pub encoding: Encoding,
    pub resampling: Resampling,
    /// Zoom range (None: chosen from the raster's extent and resolution).
    pub min_zoom: Option<u8>,
    pub max_zoom: Option<u8>,
}

/// What a pyramid holds (also written as `metadata.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PyramidInfo {
    pub min_zoom: u8,
    pub max_zoom: u8,
    /// West, south, east, north (degrees).
    pub bounds: [f64; 4],
    pub encoding: Encoding,
    /// Tiles written (tiles without any valid pixel are left out).
    pub tiles: u64,
    /// Value range of colour encodings.
    pub range: Option<(f64, f64)>,
}

/// XYZ tile column and row of a longitude/latitude at zoom `z`.
pub fn tile_of(lon: f64, lat: f64, z: u8) -> (u32, u32) {
    let (mx, my) = lonlat_to_merc(lon, lat);
    let n = (1u64 << z) as f64;
    let x = ((mx + HALF_WORLD) / (2.0 * HALF_WORLD) * n).floor();
    let y = ((HALF_WORLD - my) / (2.0 * HALF_WORLD) * n).floor();
    (x.clamp(0.0, n - 1.0) as u32, y.clamp(0.0, n - 1.0) as u32)
}

/// Web Mercator coordinates of the centre of pixel (px, py) of tile (z, x, y).
pub fn pixel_merc(z: u8, x: u32, y: u32, px: f64, py: f64) -> (f64, f64) {
    let res = 2.0 * HALF_WORLD / ((1u64 << z) as f64 * TILE as f64);
    (
        -HALF_WORLD + (x as f64 * TILE as f64 + px + 0.5) * res,
        HALF_WORLD - (y as f64 * TILE as f64 + py + 0.5) * res,
    )
}

/// Source geometry: the map projection and the inverse geotransform.
struct Geometry {
    crs: SourceCrs,
    inv: [f64; 6],
    width: usize,
    height: usize,
}

impl Geometry {
    fn new(src: &dyn RasterSource) -> Result<Geometry> {
        let info = src.info();
        let crs = SourceCrs::of(&info.georef, &info.path)?;
        let t = info.georef.transform;
        let det = t[1] * t[5] - t[2] * t[4];
        if det == 0.0 || !det.is_finite() {
            return Err(Error::unsupported(&info.path, "degenerate geotransform"));
        }
        // col = inv0 + inv1*X + inv2*Y, row = inv3 + inv4*X + inv5*Y.
        let (a, b, c, d) = (t[5] / det, -t[2] / det, -t[4] / det, t[1] / det);
        let inv = [-(a * t[0] + b * t[3]), a, b, -(c * t[0] + d * t[3]), c, d];
        Ok(Geometry {
            crs,
            inv,
            width: info.width,
            height: info.height,
        })
    }

    /// Fractional source cell coordinates (col, row; cell centres at +0.5)
    /// of a Web Mercator point.
    fn cell_of(&self, mx: f64, my: f64) -> (f64, f64) {
        let (lon, lat) = merc_to_lonlat(mx, my);
        let (x, y) = self.crs.from_lonlat(lon, lat);
        (
            self.inv[0] + self.inv[1] * x + self.inv[2] * y,
            self.inv[3] + self.inv[4] * x + self.inv[5] * y,
        )
    }

    /// Longitude/latitude bounds, from 64 points along each edge.
    fn bounds(&self, georef: &crate::raster::GeoRef) -> [f64; 4] {
        let t = georef.transform;
        let mut b = [
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        ];
        let (w, h) = (self.width as f64, self.height as f64);
        for i in 0..=64 {
            let f = i as f64 / 64.0;
            for (c, r) in [(f * w, 0.0), (f * w, h), (0.0, f * h), (w, f * h)] {
                let x = t[0] + c * t[1] + r * t[2];
                let y = t[3] + c * t[4] + r * t[5];
                let (lon, lat) = self.crs.to_lonlat(x, y);
                b[0] = b[0].min(lon);
                b[1] = b[1].min(lat);
                b[2] = b[2].max(lon);
                b[3] = b[3].max(lat);
            }
        }
        b[1] = b[1].max(-85.05);
        b[3] = b[3].min(85.05);
        b
    }
}

/// Deepest zoom whose pixels are no larger than the raster's cells (at the
/// centre latitude), and shallowest zoom at which the raster fits in about
/// one tile.
pub fn auto_zooms(bounds: [f64; 4], cell_m: f64) -> (u8, u8) {
    let lat = ((bounds[1] + bounds[3]) / 2.0).to_radians();
    let world = 2.0 * HALF_WORLD * lat.cos();
    let mut zmax = 0u8;
    while zmax < 22 && world / ((1u64 << zmax) as f64 * TILE as f64) > cell_m {
        zmax += 1;
    }
    let mut zmin = zmax;
    while zmin > 0 {
        let (x0, y0) = tile_of(bounds[0], bounds[3], zmin);
        let (x1, y1) = tile_of(bounds[2], bounds[1], zmin);
        if x1 - x0 <= 1 && y1 - y0 <= 1 {
            break;
        }
        zmin -= 1;
    }
    (zmin, zmax)
}

/// Bilinear (or nearest) sample of `g` at fractional cell coordinates
/// relative to the window origin (cell centres at +0.5).
#[inline]
fn sample(g: &Grid<f32>, fx: f64, fy: f64, nearest: bool) -> f32 {
    let (w, h) = (g.width() as f64, g.height() as f64);
    if !(fx >= 0.0 && fy >= 0.0 && fx < w && fy < h) {
        return f32::NAN;
    }
    let near = g.get(fx as usize, fy as usize);
    if nearest {
        return near;
    }
    let (x, y) = (fx - 0.5, fy - 0.5);
    let (x0, y0) = (x.floor(), y.floor());
    if x0 < 0.0 || y0 < 0.0 || x0 + 1.0 >= w || y0 + 1.0 >= h {
        return near;
    }
    let (i, j) = (x0 as usize, y0 as usize);
    let (a, b, c, d) = (
        g.get(i, j),
        g.get(i + 1, j),
        g.get(i, j + 1),
        g.get(i + 1, j + 1),
    );
    if !(a.is_finite() && b.is_finite() && c.is_finite() && d.is_finite()) {
        return near;
    }
    let (tx, ty) = ((x - x0) as f32, (y - y0) as f32);
    let top = a + (b - a) * tx;
    let bot = c + (d - c) * tx;
    top + (bot - top) * ty
}

/// Sample tile (z, x, y) from the source; None when it has no valid pixel.
fn sample_tile(
    src: &dyn RasterSource,
    geo: &Geometry,
    z: u8,
    x: u32,
    y: u32,
    nearest: bool,
) -> Result<Option<Vec<f32>>> {
    const CTRL: usize = 17;
    let step = TILE as f64 / (CTRL - 1) as f64;
    let mut ctrl = [(0.0f64, 0.0f64); CTRL * CTRL];
    let (mut c0, mut r0, mut c1, mut r1) = (
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    );
    for j in 0..CTRL {
        for i in 0..CTRL {
            let (mx, my) = pixel_merc(z, x, y, i as f64 * step - 0.5, j as f64 * step - 0.5);
            let p = geo.cell_of(mx, my);
            c0 = c0.min(p.0);
            r0 = r0.min(p.1);
            c1 = c1.max(p.0);
            r1 = r1.max(p.1);
            ctrl[j * CTRL + i] = p;
        }
    }
    if c1 < -1.0 || r1 < -1.0 || c0 > geo.width as f64 + 1.0 || r0 > geo.height as f64 + 1.0 {
        return Ok(None);
    }
    let wx0 = (c0.floor() as i64 - 2).max(-1);
    let wy0 = (r0.floor() as i64 - 2).max(-1);
    let wx1 = (c1.ceil() as i64 + 2).min(geo.width as i64 + 1);
    let wy1 = (r1.ceil() as i64 + 2).min(geo.height as i64 + 1);
    let (ww, wh) = ((wx1 - wx0).max(1) as usize, (wy1 - wy0).max(1) as usize);
    if ww > 8192 || wh > 8192 {
        return Err(Error::invalid(format!(
            "zoom {z} is too coarse for sampling the source directly ({ww} x {wh} cells per tile); raise the maximum zoom"
        )));
    }
    let win = read_window::<f32>(src, Window::new(wx0, wy0, ww, wh))?;
    let mut out = vec![f32::NAN; TILE * TILE];
    let mut any = false;
    for py in 0..TILE {
        let gy = (py as f64 + 0.5) / step;
        let j = (gy as usize).min(CTRL - 2);
        let ty = gy - j as f64;
        for px in 0..TILE {
            let gx = (px as f64 + 0.5) / step;
            let i = (gx as usize).min(CTRL - 2);
            let tx = gx - i as f64;
            let p00 = ctrl[j * CTRL + i];
            let p10 = ctrl[j * CTRL + i + 1];
            let p01 = ctrl[(j + 1) * CTRL + i];
            let p11 = ctrl[(j + 1) * CTRL + i + 1];
            let fx = (p00.0 * (1.0 - tx) + p10.0 * tx) * (1.0 - ty)
                + (p01.0 * (1.0 - tx) + p11.0 * tx) * ty;
            let fy = (p00.1 * (1.0 - tx) + p10.1 * tx) * (1.0 - ty)
                + (p01.1 * (1.0 - tx) + p11.1 * tx) * ty;
            let v = sample(&win, fx - wx0 as f64, fy - wy0 as f64, nearest);
            if v.is_finite() {
                any = true;
            }
            out[py * TILE + px] = v;
        }
    }
    Ok(any.then_some(out))
}

/// The parent tile of four children (NW, NE, SW, SE; None = empty).
fn reduce(children: &[Option<Vec<f32>>; 4], nearest: bool) -> Option<Vec<f32>> {
    if children.iter().all(|c| c.is_none()) {
        return None;
    }
    let mut out = vec![f32::NAN; TILE * TILE];
    let half = TILE / 2;
    let mut any = false;
    for (k, c) in children.iter().enumerate() {
        let Some(c) = c else { continue };
        let (ox, oy) = ((k % 2) * half, (k / 2) * half);
        for y in 0..half {
            for x in 0..half {
                let s = |dx: usize, dy: usize| c[(2 * y + dy) * TILE + 2 * x + dx];
                let v = if nearest {
                    s(0, 0)
                } else {
                    let (mut sum, mut n) = (0.0f32, 0u32);
                    for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                        let v = s(dx, dy);
                        if v.is_finite() {
                            sum += v;
                            n += 1;
                        }
                    }
                    if n == 0 {
                        f32::NAN
                    } else {
                        sum / n as f32
                    }
                };
                any |= v.is_finite();
                out[(oy + y) * TILE + ox + x] = v;
            }
        }
    }
    any.then_some(out)
}

/// RGBA pixels of a tile under `enc` (colour ramps use `lut` and `range`).
pub fn encode_pixels(
    v: &[f32],
    enc: &Encoding,
    lut: &[[u8; 3]; 256],
    range: (f64, f64),
) -> Vec<u8> {
    let mut rgba = vec![0u8; v.len() * 4];
    for (i, &h) in v.iter().enumerate() {
        if !h.is_finite() {
            continue;
        }
        let px: [u8; 4] = match enc {
            Encoding::TerrainRgb => {
                let code = (((h as f64 + 10000.0) * 10.0).round()).clamp(0.0, 16_777_215.0) as u32;
                [(code >> 16) as u8, (code >> 8) as u8, code as u8, 255]
            }
            Encoding::Terrarium => {
                let v = (h as f64 + 32768.0).clamp(0.0, 65535.996);
                let i = v.floor();
                let frac = ((v - i) * 256.0).floor().min(255.0);
                [
                    (i as u32 >> 8) as u8,
                    (i as u32 & 255) as u8,
                    frac as u8,
                    255,
                ]
            }
            Encoding::Color { .. } => {
                let t = if range.1 > range.0 {
                    ((h as f64 - range.0) / (range.1 - range.0)).clamp(0.0, 1.0)
                } else {
                    0.5
                };
                let c = lut[(t * 255.0).round() as usize];
                [c[0], c[1], c[2], 255]
            }
        };
        rgba[i * 4..i * 4 + 4].copy_from_slice(&px);
    }
    rgba
}

/// Decode a Terrain-RGB pixel to metres.
pub fn decode_terrain_rgb(r: u8, g: u8, b: u8) -> f64 {
    -10000.0 + ((r as u32) << 16 | (g as u32) << 8 | b as u32) as f64 * 0.1
}

/// Decode a Terrarium pixel to metres.
pub fn decode_terrarium(r: u8, g: u8, b: u8) -> f64 {
    r as f64 * 256.0 + g as f64 + b as f64 / 256.0 - 32768.0
}

/// PNG bytes of an RGBA tile.
///
/// DEFLATE at zlib level 2 with adaptive filters: profiling the Poland
/// Terrain-RGB pyramid showed about three quarters of the time in the match
/// search of the png crate's default (level 6); level 2 takes 3.9x less
/// CPU for 17% larger files, the png crate's fdeflate (`Compression::Fast`)
/// 6.5x less for 42% larger ones (`docs/design/compare.md#features-and-distances`).
pub fn png_bytes(rgba: &[u8]) -> Result<Vec<u8>> {
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, TILE as u32, TILE as u32);
        enc.set_color(png::ColorType::Rgba);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_deflate_compression(png::DeflateCompression::Level(2));
        enc.set_filter(png::Filter::Adaptive);
        let mut w = enc
            .write_header()
            .map_err(|e| Error::invalid(format!("PNG encoding failed: {e}")))?;
        w.write_image_data(rgba)
            .map_err(|e| Error::invalid(format!("PNG encoding failed: {e}")))?;
    }
    Ok(out)
}

struct Ctx<'a> {
    src: &'a dyn RasterSource,
    geo: Geometry,
    opts: &'a PyramidOptions,
    lut: [[u8; 3]; 256],
    range: (f64, f64),
    zmin: u8,
    zmax: u8,
    /// Tile ranges per zoom (x0, y0, x1, y1), inclusive.
    ranges: Vec<(u32, u32, u32, u32)>,
    dir: &'a Path,
    written: std::sync::atomic::AtomicU64,
}

impl Ctx<'_> {
    fn inside(&self, z: u8, x: u32, y: u32) -> bool {
        let (x0, y0, x1, y1) = self.ranges[z as usize];
        (x0..=x1).contains(&x) && (y0..=y1).contains(&y)
    }

    /// Build tile (z, x, y) and everything below it; returns its values.
    fn build(&self, z: u8, x: u32, y: u32) -> Result<Option<Vec<f32>>> {
        let nearest = self.opts.resampling == Resampling::Nearest;
        let vals = if z == self.zmax {
            sample_tile(self.src, &self.geo, z, x, y, nearest)?
        } else {
            let kids: Vec<Result<Option<Vec<f32>>>> = {
                use rayon::prelude::*;
                (0..4u32)
                    .into_par_iter()
                    .map(|k| {
                        let (cx, cy) = (2 * x + k % 2, 2 * y + k / 2);
                        if self.inside(z + 1, cx, cy) {
                            self.build(z + 1, cx, cy)
                        } else {
                            Ok(None)
                        }
                    })
                    .collect()
            };
            let mut arr: [Option<Vec<f32>>; 4] = [None, None, None, None];
            for (k, r) in kids.into_iter().enumerate() {
                arr[k] = r?;
            }
            reduce(&arr, nearest)
        };
        if let (Some(v), true) = (&vals, z >= self.zmin) {
            let rgba = encode_pixels(v, &self.opts.encoding, &self.lut, self.range);
            let png = png_bytes(&rgba)?;
            let d = self.dir.join(z.to_string()).join(x.to_string());
            std::fs::create_dir_all(&d).map_err(|e| Error::io(&d, e))?;
            // Temporary + rename: a killed run never leaves a torn tile under
            // its final name (issue 12).
            let p = d.join(format!("{y}.png"));
            crate::io::atomic::replace_file(&p, &png, "tile")?;
            self.written
                .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        }
        Ok(vals)
    }
}

/// Cut `src` into a pyramid of PNG tiles under `dir` (created; must not
/// hold another pyramid's tiles). `data_range` is the data's min..max,
/// needed only for colour encodings without an explicit range.
pub fn build_pyramid(
    src: &dyn RasterSource,
    dir: &Path,
    opts: &PyramidOptions,
    data_range: Option<(f64, f64)>,
) -> Result<PyramidInfo> {
    let info = src.info();
    let geo = Geometry::new(src)?;
    let bounds = geo.bounds(&info.georef);
    let cs = info.georef.cell_size_m((info.height / 2) as i64);
    let cell_m = cs.0.abs().min(cs.1.abs()).max(1e-9);
    let (az0, az1) = auto_zooms(bounds, cell_m);
    let zmax = opts.max_zoom.unwrap_or(az1);
    let zmin = opts.min_zoom.unwrap_or(az0.min(zmax));
    if zmax > 24 || zmin > zmax {
        return Err(Error::invalid(format!(
            "zoom range {zmin}..{zmax}: use 0 <= min <= max <= 24"
        )));
    }
    let (lut, range) = match &opts.encoding {
        Encoding::Color { ramp, range } => {
            let lut = crate::tiles::render::ramp_lut(ramp)?;
            let r = range.or(data_range).ok_or_else(|| {
                Error::invalid("a colour encoding needs a value range (give one, or the data's)")
            })?;
            (lut, r)
        }
        _ => ([[0u8; 3]; 256], (0.0, 1.0)),
    };
    let ranges = (0..=zmax)
        .map(|z| {
            let (x0, y0) = tile_of(bounds[0], bounds[3], z);
            let (x1, y1) = tile_of(bounds[2], bounds[1], z);
            (x0, y0, x1, y1)
        })
        .collect();
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    remove_dead_tile_temps(dir, zmax);
    let ctx = Ctx {
        src,
        geo,
        opts,
        lut,
        range,
        zmin,
        zmax,
        ranges,
        dir,
        written: 0.into(),
    };
    // Roots: the tiles of zoom 0 covering the raster; levels above zmin are
    // built but not written.
    ctx.build(0, 0, 0)?;
    let pinfo = PyramidInfo {
        min_zoom: zmin,
        max_zoom: zmax,
        bounds,
        encoding: opts.encoding.clone(),
        tiles: ctx.written.load(std::sync::atomic::Ordering::Relaxed),
        range: matches!(opts.encoding, Encoding::Color { .. }).then_some(range),
    };
    let meta = dir.join("metadata.json");
    let text = serde_json::to_string_pretty(&pinfo)
        .map_err(|e| Error::invalid(format!("metadata: {e}")))?;
    // Written last and atomically (fsynced): its presence marks a complete
    // pyramid.
    crate::io::atomic::write_file_atomic(&meta, text.as_bytes())?;
    Ok(pinfo)
}

/// Remove the tile temporaries (`z/x/.y.png.orogen-tmp-PID`) a killed run
/// left in `dir`; tiles it completed are complete (renamed into place) and
/// are rewritten by this run.
fn remove_dead_tile_temps(dir: &Path, zmax: u8) {
    for z in 0..=zmax {
        let Ok(xs) = std::fs::read_dir(dir.join(z.to_string())) else {
            continue;
        };
        for xe in xs.flatten() {
            crate::io::atomic::remove_dead_temps(&xe.path());
        }
    }
}
