//! Type map C_T (Argudo, Galin, Peytavie, Paris, Gain & Guérin 2019,
//! "Orometry-based terrain analysis and synthesis", ACM TOG 38(6), §5 and
//! §7): a raster of region labels stretched over the synthesis domain, each
//! label with its own [`SynthProfile`]. A peak placed in a region takes its
//! elevation, isolation and prominence/dominance targets from that region's
//! profile, and each region gets its profile's density × its area.
//!
//! Borders may be blended over a band (`TreeOptions::type_blend_m`, default
//! [`super::tree_synth::DEFAULT_TYPE_BLEND_M`] = 0, sharp): near a border the map is
//! a fine mosaic in which region r holds the share of r in the band-wide
//! square around each grain ([`TypeMap::blend_weight`], a box filter: it
//! ramps linearly across a straight border), a peak of region r is placed
//! only on r's grains, and its coarse elevation C_H there is r's. So peak
//! density, elevations and orometry change gradually across a border
//! instead of in one step (a departure from the paper, which does not say
//! how C_T borders behave).

use super::profile::SynthProfile;
use crate::error::{Error, Result};
use crate::raster::Grid;

/// Largest number of labelled regions.
pub const MAX_REGIONS: usize = 64;

/// Region labels (integers stored as f32; NaN = no peaks there) and the
/// profile of each listed label. Labels not listed use the synthesis's
/// main profile (region 0).
#[derive(Debug, Clone)]
pub struct TypeMap {
    labels: Grid<f32>,
    /// (label, profile); region k + 1 of the synthesis is `regions[k]`.
    pub regions: Vec<(i64, SynthProfile)>,
    /// Region index of every map cell (0: main profile; u8::MAX: none).
    cell_region: Vec<u8>,
}

impl TypeMap {
    /// Check the labels (integers or nodata) and the profiles.
    pub fn new(labels: Grid<f32>, regions: Vec<(i64, SynthProfile)>) -> Result<TypeMap> {
        if regions.len() > MAX_REGIONS {
            return Err(Error::invalid(format!(
                "the type map lists {} region profiles; at most {MAX_REGIONS}",
                regions.len()
            )));
        }
        for (k, (l, p)) in regions.iter().enumerate() {
            p.validate()
                .map_err(|e| Error::invalid(format!("profile of type-map label {l}: {e}")))?;
            if regions[..k].iter().any(|(m, _)| m == l) {
                return Err(Error::invalid(format!(
                    "type-map label {l} is given two profiles"
                )));
            }
        }
        let mut cell_region = Vec::with_capacity(labels.data().len());
        for &v in labels.data() {
            if !v.is_finite() {
                cell_region.push(u8::MAX);
                continue;
            }
            if v.fract() != 0.0 {
                return Err(Error::invalid(format!(
                    "the type map holds {v}: labels must be integers (region numbers)"
                )));
            }
            let l = v as i64;
            let r = regions
                .iter()
                .position(|(m, _)| *m == l)
                .map(|k| k + 1)
                .unwrap_or(0);
            cell_region.push(r as u8);
        }
        if cell_region.iter().all(|&r| r == u8::MAX) {
            return Err(Error::invalid(
                "the type map is nodata everywhere: no region may hold a peak",
            ));
        }
        Ok(TypeMap {
            labels,
            regions,
            cell_region,
        })
    }

    /// The label grid.
    pub fn labels(&self) -> &Grid<f32> {
        &self.labels
    }

    /// Region (0 = main profile, k + 1 = `regions[k]`) at the domain
    /// fraction (fx, fy) ∈ [0, 1)² (x east, y down), nearest map cell; None
    /// on nodata.
    pub fn region_at(&self, fx: f64, fy: f64) -> Option<usize> {
        let (w, h) = (self.labels.width(), self.labels.height());
        if !(fx.is_finite() && fy.is_finite()) {
            return None;
        }
        let c = ((fx * w as f64).max(0.0) as usize).min(w - 1);
        let r = ((fy * h as f64).max(0.0) as usize).min(h - 1);
        match self.cell_region[r * w + c] {
            u8::MAX => None,
            k => Some(k as usize),
        }
    }

    /// Share of `region` in the blend band around the domain fraction
    /// (fx, fy): of the points of a [`BLEND_LATTICE`]² lattice over the
    /// rectangle of sides (bx, by) (domain fractions) centred there, the
    /// fraction in `region`, counting only labelled points (a nodata area
    /// does not dilute its neighbours). 0 on nodata itself (no peak there,
    /// as without blending); with bx = by = 0, 1 in `region` and 0
    /// elsewhere (sharp borders). A box filter of the region indicator:
    /// across a straight border it ramps linearly over the band.
    pub fn blend_weight(&self, fx: f64, fy: f64, region: usize, bx: f64, by: f64) -> f64 {
        let Some(here) = self.region_at(fx, fy) else {
            return 0.0;
        };
        if !(bx > 0.0 || by > 0.0) || !(bx.is_finite() && by.is_finite()) {
            return if here == region { 1.0 } else { 0.0 };
        }
        let w = self.share(fx, fy, region, bx, by);
        if w == 0.0 && here == region {
            // No labelled lattice point (a band thinner than a map cell).
            return 1.0;
        }
        w
    }

    /// Region of the blended type map at (fx, fy): None on nodata; with
    /// a band (bx, by > 0, domain fractions) the band is cut into a mosaic
    /// of grains of side 1/[`BLEND_GRAINS`] of it and each grain goes to
    /// region r with probability [`TypeMap::blend_weight`] of r at its
    /// centre (a hash of `seed` and the grain: deterministic). Peaks are
    /// then placed only where the blended region is theirs, so each
    /// region's peak density near a border follows its share (a plain
    /// acceptance probability would not: the placement retries rejected
    /// proposals until one passes).
    pub fn region_blended(&self, fx: f64, fy: f64, bx: f64, by: f64, seed: u64) -> Option<usize> {
        let here = self.region_at(fx, fy)?;
        if !(bx > 0.0 && by > 0.0 && bx.is_finite() && by.is_finite()) {
            return Some(here);
        }
        let (gx, gy) = (bx / BLEND_GRAINS as f64, by / BLEND_GRAINS as f64);
        let (ix, iy) = ((fx / gx).floor(), (fy / gy).floor());
        let (cx, cy) = ((ix + 0.5) * gx, (iy + 0.5) * gy);
        let mut h = seed ^ 0x626c_656e_6400_0000;
        for v in [ix as i64 as u64, iy as i64 as u64] {
            h = (h ^ v).wrapping_mul(0x9e37_79b9_7f4a_7c15);
            h ^= h >> 29;
            h = h.wrapping_mul(0xbf58_476d_1ce4_e5b9);
            h ^= h >> 32;
        }
        let u = (h >> 11) as f64 / (1u64 << 53) as f64;
        let mut acc = 0.0;
        let mut last = here;
        for r in 0..=self.regions.len() {
            let w = self.share(cx, cy, r, bx, by);
            if w > 0.0 {
                acc += w;
                last = r;
                if u < acc {
                    return Some(r);
                }
            }
        }
        Some(last)
    }

    /// [`TypeMap::blend_weight`] without the test of the centre point.
    fn share(&self, fx: f64, fy: f64, region: usize, bx: f64, by: f64) -> f64 {
        let k = BLEND_LATTICE;
        let (mut hit, mut lab) = (0usize, 0usize);
        for j in 0..k {
            let v = fy + by * ((j as f64 + 0.5) / k as f64 - 0.5);
            for i in 0..k {
                let u = fx + bx * ((i as f64 + 0.5) / k as f64 - 0.5);
                if !(0.0..1.0).contains(&u) || !(0.0..1.0).contains(&v) {
                    continue;
                }
                if let Some(r) = self.region_at(u, v) {
                    lab += 1;
                    hit += usize::from(r == region);
                }
            }
        }
        if lab == 0 {
            return 0.0;
        }
        hit as f64 / lab as f64
    }

    /// Fraction of the map's cells in each region (index as
    /// [`TypeMap::region_at`]; nodata cells are in none).
    pub fn fractions(&self) -> Vec<f64> {
        let mut f = vec![0.0; self.regions.len() + 1];
        for &r in &self.cell_region {
            if r != u8::MAX {
                f[r as usize] += 1.0;
            }
        }
        let n = self.cell_region.len() as f64;
        f.iter_mut().for_each(|v| *v /= n);
        f
    }
}

/// Points per side of the lattice [`TypeMap::blend_weight`] averages over.
pub const BLEND_LATTICE: usize = 9;
/// Grains per band width of the mosaic of [`TypeMap::region_blended`].
pub const BLEND_GRAINS: usize = 16;

/// Largest GeoJSON type map read.
const MAX_GEOJSON_BYTES: u64 = 256 << 20;

/// Rasterise a GeoJSON type map: Polygon / MultiPolygon features with an
/// integer `label` property, in the output's metric frame (x east, y north
/// from the domain's bottom-left corner, as the rasters orogen writes and
/// `--fixed-peaks`), onto `cols` x `rows` cells over a `width_m` x
/// `height_m` domain. A cell takes the label of the last feature whose
/// polygon contains its centre (even–odd rule over all rings, so holes
/// work; Shimrat 1962, "Algorithm 112: position of point relative to
/// polygon", CACM 5(8)); cells in no polygon are nodata (no peaks).
pub fn rasterize_geojson(
    path: &std::path::Path,
    width_m: f64,
    height_m: f64,
    cols: usize,
    rows: usize,
) -> Result<Grid<f32>> {
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    if meta.len() > MAX_GEOJSON_BYTES {
        return Err(Error::too_large(path, "a type-map GeoJSON over 256 MiB"));
    }
    if cols == 0 || rows == 0 || cols.saturating_mul(rows) > 1 << 24 {
        return Err(Error::invalid("type map raster: 1..16M cells"));
    }
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let v: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| Error::corrupt(path, format!("not JSON: {e}")))?;
    let feats = v
        .get("features")
        .and_then(|f| f.as_array())
        .ok_or_else(|| Error::corrupt(path, "expected a GeoJSON FeatureCollection of polygons"))?;
    let mut out = vec![f32::NAN; cols * rows];
    for (k, f) in feats.iter().enumerate() {
        let bad = |m: &str| Error::corrupt(path, format!("feature {k}: {m}"));
        let label = f
            .pointer("/properties/label")
            .and_then(|l| l.as_i64())
            .ok_or_else(|| bad("needs an integer \"label\" property"))?;
        let geom = f.get("geometry").ok_or_else(|| bad("no geometry"))?;
        let coords = geom
            .get("coordinates")
            .ok_or_else(|| bad("no coordinates"))?;
        let polys: Vec<&serde_json::Value> = match geom.get("type").and_then(|t| t.as_str()) {
            Some("Polygon") => vec![coords],
            Some("MultiPolygon") => coords
                .as_array()
                .ok_or_else(|| bad("malformed MultiPolygon"))?
                .iter()
                .collect(),
            _ => {
                return Err(bad(
                    "only Polygon and MultiPolygon geometries are type regions",
                ))
            }
        };
        // Rings as flat (x, y) lists in cell units (y down).
        let mut rings: Vec<Vec<(f64, f64)>> = Vec::new();
        for p in polys {
            for ring in p.as_array().ok_or_else(|| bad("malformed polygon"))? {
                let pts = ring.as_array().ok_or_else(|| bad("malformed ring"))?;
                let mut r = Vec::with_capacity(pts.len());
                for q in pts {
                    let (Some(x), Some(y)) = (
                        q.get(0).and_then(|x| x.as_f64()),
                        q.get(1).and_then(|y| y.as_f64()),
                    ) else {
                        return Err(bad("a ring point is not two numbers"));
                    };
                    if !(x.is_finite() && y.is_finite()) {
                        return Err(bad("a ring point is not finite"));
                    }
                    r.push((
                        x / width_m * cols as f64,
                        (height_m - y) / height_m * rows as f64,
                    ));
                }
                if r.len() >= 3 {
                    rings.push(r);
                }
            }
        }
        // Bounding box in rows, then the even–odd test per cell centre.
        let (ymin, ymax) = rings
            .iter()
            .flatten()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(p.1), b.max(p.1))
            });
        if !ymin.is_finite() {
            continue;
        }
        let r0 = (ymin.floor().max(0.0) as usize).min(rows);
        let r1 = ((ymax.ceil().max(0.0)) as usize).min(rows);
        for r in r0..r1 {
            let py = r as f64 + 0.5;
            for c in 0..cols {
                let px = c as f64 + 0.5;
                let mut inside = false;
                for ring in &rings {
                    let n = ring.len();
                    let mut j = n - 1;
                    for i in 0..n {
                        let (xi, yi) = ring[i];
                        let (xj, yj) = ring[j];
                        if (yi > py) != (yj > py) && px < xj + (py - yj) / (yi - yj) * (xi - xj) {
                            inside = !inside;
                        }
                        j = i;
                    }
                }
                if inside {
                    out[r * cols + c] = label as f32;
                }
            }
        }
    }
    Grid::from_vec(cols, rows, out)
}
