//! GeoTIFF georeferencing: from the model tags and GeoKeys to a [`GeoRef`]
//! and back, and GDAL_NODATA text.
//!
//! Sources: GeoTIFF 1.1 (OGC 19-008r4) for tags 33550/33922/34264 and the key
//! directory (header `[1, 1, minor, n]`, entries `[id, location, count, value]`,
//! location 0 = inline value, 34736 = index into the doubles, 34737 = offset
//! into the ASCII params); GDAL's documented behaviour for PixelIsPoint (the
//! geotransform it reports is shifted by half a cell so it always describes
//! cell corners) and for the GDAL_NODATA tag (42113, ASCII).

use crate::raster::{Crs, GeoKeys, GeoRef, RasterType};

/// GeoKey ids used here.
pub(crate) const GT_MODEL_TYPE: u16 = 1024;
pub(crate) const GT_RASTER_TYPE: u16 = 1025;
pub(crate) const GEOGRAPHIC_TYPE: u16 = 2048;
pub(crate) const PROJECTED_CS_TYPE: u16 = 3072;
pub(crate) const PROJ_LINEAR_UNITS: u16 = 3076;
pub(crate) const PROJ_LINEAR_UNIT_SIZE: u16 = 3077;

/// Metres per US survey foot.
const US_FOOT_M: f64 = 1200.0 / 3937.0;

/// Parse a GDAL_NODATA string ("-9999", "nan", "-3.4028234663852886e+38").
/// Returns None for text that is not a number.
pub fn parse_nodata(s: &str) -> Option<f64> {
    let t = s.trim_matches(|c: char| c == '\0' || c.is_whitespace());
    t.parse::<f64>().ok().or_else(|| {
        // What MSVC's printf wrote for infinities and NaN, which GDAL reads
        // (CPLAtof): "1.#INF", "-1.#INF", "1.#QNAN", "-1.#IND".
        let (neg, body) = match t.strip_prefix('-') {
            Some(b) => (true, b),
            None => (false, t.strip_prefix('+').unwrap_or(t)),
        };
        let body = body.to_ascii_uppercase();
        let inf = if neg {
            f64::NEG_INFINITY
        } else {
            f64::INFINITY
        };
        match body.as_str() {
            "1.#INF" | "1.#INF0" | "1.#INF00" => Some(inf),
            "1.#QNAN" | "1.#IND" | "1.#SNAN" | "1.#QNAN0" | "1.#IND00" => Some(f64::NAN),
            _ => None,
        }
    })
}

/// Format a nodata value as GDAL writes GDAL_NODATA: integers without
/// decimals, NaN as "nan", other floats as the shortest text that reads back
/// to the same f64.
pub fn format_nodata(v: f64) -> String {
    if v.is_nan() {
        "nan".to_string()
    } else if v.is_infinite() {
        if v > 0.0 { "inf" } else { "-inf" }.to_string()
    } else if v.fract() == 0.0 && v.abs() < 1e15 {
        format!("{}", v as i64)
    } else if v.abs() >= 1e-4 && v.abs() < 1e15 {
        format!("{v}")
    } else {
        let s = format!("{v:e}");
        // Rust prints "1.5e38"; C-style "1.5e+38" is what GDAL itself writes.
        match s.find('e') {
            Some(i) if !s[i + 1..].starts_with('-') => format!("{}e+{}", &s[..i], &s[i + 1..]),
            _ => s,
        }
    }
}

/// Value of key `id` in a GeoKey directory, if stored inline (location 0).
pub(crate) fn key_short(dir: &[u16], id: u16) -> Option<u16> {
    key_entry(dir, id).and_then(|e| if e[1] == 0 { Some(e[3]) } else { None })
}

/// Double value of key `id` (location 34736), if present.
fn key_double(keys: &GeoKeys, id: u16) -> Option<f64> {
    let e = key_entry(&keys.directory, id)?;
    if e[1] != 34736 {
        return None;
    }
    keys.doubles.get(e[3] as usize).copied()
}

fn key_entry(dir: &[u16], id: u16) -> Option<[u16; 4]> {
    let n = *dir.get(3)? as usize;
    (0..n).find_map(|k| {
        let e = dir.get(4 + 4 * k..8 + 4 * k)?;
        if e[0] == id {
            Some([e[0], e[1], e[2], e[3]])
        } else {
            None
        }
    })
}

/// CRS facts from the GeoKeys: GTModelType decides `geographic`, the EPSG
/// code comes from ProjectedCSType (projected) or GeographicType
/// (geographic); 32767 (user-defined) gives no code.
pub(crate) fn crs_from_keys(keys: GeoKeys) -> Crs {
    let dir = &keys.directory;
    let model = key_short(dir, GT_MODEL_TYPE);
    let geographic = model == Some(2);
    let code = if geographic {
        key_short(dir, GEOGRAPHIC_TYPE)
    } else {
        key_short(dir, PROJECTED_CS_TYPE)
    };
    let epsg = code.filter(|&c| c != 0 && c != 32767).map(u32::from);
    let linear_unit_m = match key_short(dir, PROJ_LINEAR_UNITS) {
        Some(9001) => 1.0,
        Some(9002) => 0.3048,
        Some(9003) => US_FOOT_M,
        _ => key_double(&keys, PROJ_LINEAR_UNIT_SIZE)
            .filter(|v| v.is_finite() && *v > 0.0)
            .unwrap_or(1.0),
    };
    Crs {
        epsg,
        geographic,
        linear_unit_m,
        geokeys: Some(keys),
    }
}

/// Raster type from the keys (default area).
pub(crate) fn raster_type_from_keys(keys: Option<&GeoKeys>) -> RasterType {
    match keys.and_then(|k| key_short(&k.directory, GT_RASTER_TYPE)) {
        Some(2) => RasterType::Point,
        _ => RasterType::Area,
    }
}

/// GDAL-order transform from ModelTransformation (16 doubles, row-major 4x4).
pub(crate) fn transform_from_matrix(m: &[f64]) -> Option<[f64; 6]> {
    if m.len() < 16 {
        return None;
    }
    Some([m[3], m[0], m[1], m[7], m[4], m[5]])
}

/// GDAL-order transform from ModelPixelScale (sx, sy, sz) and the first
/// ModelTiepoint (i, j, k, x, y, z): raster point (i, j) is at map (x, y).
pub(crate) fn transform_from_scale_tiepoint(scale: &[f64], tie: &[f64]) -> Option<[f64; 6]> {
    if scale.len() < 2 || tie.len() < 6 {
        return None;
    }
    let (sx, sy) = (scale[0], scale[1]);
    Some([
        tie[3] - tie[0] * sx,
        sx,
        0.0,
        tie[4] + tie[1] * sy,
        0.0,
        -sy,
    ])
}

/// Shift a transform by `sign` half cells along both axes (PixelIsPoint:
/// sign -1 when reading, as GDAL does; +1 when writing, to undo it).
pub(crate) fn half_cell_shift(t: &mut [f64; 6], sign: f64) {
    t[0] += sign * 0.5 * (t[1] + t[2]);
    t[3] += sign * 0.5 * (t[4] + t[5]);
}

/// The GeoKey set to write for `georef`: the original keys when present (with
/// GTRasterTypeGeoKey set per `raster_type`), otherwise a minimal set from the
/// EPSG code.
pub(crate) fn keys_for_write(georef: &GeoRef) -> GeoKeys {
    let raster_type: u16 = match georef.raster_type {
        RasterType::Area => 1,
        RasterType::Point => 2,
    };
    if let Some(k) = &georef.crs.geokeys {
        if k.directory.len() >= 4 {
            let mut keys = k.clone();
            set_short_key(&mut keys.directory, GT_RASTER_TYPE, raster_type);
            return keys;
        }
    }
    let crs = &georef.crs;
    // A raster with no known CRS (no EPSG code, not geographic, no keys:
    // an .asc without .prj) gets no GTModelType, as GDAL writes it;
    // GTRasterType alone when it is PixelIsPoint (GDAL's default is
    // PixelIsArea), and no directory at all otherwise.
    if crs.epsg.is_none() && !crs.geographic {
        let entries: &[u16] = if raster_type == 2 {
            &[1, 1, 0, 1, GT_RASTER_TYPE, 0, 1, 2]
        } else {
            &[1, 1, 0, 0]
        };
        return GeoKeys {
            directory: entries.to_vec(),
            doubles: Vec::new(),
            ascii: String::new(),
        };
    }
    let mut entries: Vec<[u16; 4]> = vec![
        [GT_MODEL_TYPE, 0, 1, if crs.geographic { 2 } else { 1 }],
        [GT_RASTER_TYPE, 0, 1, raster_type],
    ];
    if let Some(code) = crs.epsg.and_then(|c| u16::try_from(c).ok()) {
        if crs.geographic {
            entries.push([GEOGRAPHIC_TYPE, 0, 1, code]);
        } else {
            entries.push([PROJECTED_CS_TYPE, 0, 1, code]);
            let unit = crs.linear_unit_m;
            let code = if unit == 1.0 {
                Some(9001)
            } else if unit == 0.3048 {
                Some(9002)
            } else if (unit - US_FOOT_M).abs() < 1e-12 {
                Some(9003)
            } else {
                None
            };
            if let Some(u) = code {
                entries.push([PROJ_LINEAR_UNITS, 0, 1, u]);
            }
        }
    }
    let mut directory = vec![1, 1, 0, entries.len() as u16];
    for e in entries {
        directory.extend_from_slice(&e);
    }
    GeoKeys {
        directory,
        doubles: Vec::new(),
        ascii: String::new(),
    }
}

/// Set (or insert, keeping ids sorted) an inline short key.
fn set_short_key(dir: &mut Vec<u16>, id: u16, value: u16) {
    let n = dir[3] as usize;
    let n = n.min((dir.len() - 4) / 4);
    for k in 0..n {
        let at = 4 + 4 * k;
        if dir[at] == id {
            dir[at + 1] = 0;
            dir[at + 2] = 1;
            dir[at + 3] = value;
            return;
        }
    }
    let pos = (0..n).find(|&k| dir[4 + 4 * k] > id).unwrap_or(n);
    let at = 4 + 4 * pos;
    dir.splice(at..at, [id, 0, 1, value]);
    dir[3] = (n + 1) as u16;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn msvc_infinity_and_nan_texts_are_read_as_gdal_reads_them() {
        assert_eq!(parse_nodata("1.#INF"), Some(f64::INFINITY));
        assert_eq!(parse_nodata("-1.#INF\0"), Some(f64::NEG_INFINITY));
        assert!(parse_nodata("-1.#IND").is_some_and(f64::is_nan));
        assert!(parse_nodata("1.#QNAN").is_some_and(f64::is_nan));
        assert_eq!(parse_nodata("1.#INFINITE"), None);
        assert_eq!(parse_nodata("-32768"), Some(-32768.0));
    }

    #[test]
    fn nodata_text_round_trips_like_gdal() {
        assert_eq!(format_nodata(-9999.0), "-9999");
        assert_eq!(format_nodata(-32768.0), "-32768");
        assert_eq!(format_nodata(f64::NAN), "nan");
        let f32min = f32::MIN as f64;
        assert_eq!(format_nodata(f32min), "-3.4028234663852886e+38");
        assert_eq!(format_nodata(0.1), "0.1");
        assert_eq!(format_nodata(1.5e-7), "1.5e-7");
        assert_eq!(parse_nodata("-3.4028234663852886e+38"), Some(f32min));
        assert!(parse_nodata("nan").is_some_and(f64::is_nan));
        assert!(parse_nodata("NaN\0").is_some_and(f64::is_nan));
        assert_eq!(parse_nodata(" -9999 "), Some(-9999.0));
        assert_eq!(parse_nodata("abc"), None);
    }

    #[test]
    fn raster_type_key_is_set_or_inserted_in_order() {
        let mut dir = vec![1, 1, 0, 2, 1024, 0, 1, 2, 2048, 0, 1, 4326];
        set_short_key(&mut dir, GT_RASTER_TYPE, 2);
        assert_eq!(
            dir,
            vec![1, 1, 0, 3, 1024, 0, 1, 2, 1025, 0, 1, 2, 2048, 0, 1, 4326]
        );
        set_short_key(&mut dir, GT_RASTER_TYPE, 1);
        assert_eq!(key_short(&dir, GT_RASTER_TYPE), Some(1));
        assert_eq!(dir[3], 3);
    }

    #[test]
    fn scale_tiepoint_and_matrix_agree_with_hand_computation() {
        // Raster point (2, 3) at map (1000, 5000), 10 x 20 m cells.
        let t = transform_from_scale_tiepoint(
            &[10.0, 20.0, 0.0],
            &[2.0, 3.0, 0.0, 1000.0, 5000.0, 0.0],
        );
        assert_eq!(t, Some([980.0, 10.0, 0.0, 5060.0, 0.0, -20.0]));
        let m = [
            1.0, 2.0, 0.0, 100.0, 3.0, -4.0, 0.0, 200.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0,
        ];
        assert_eq!(
            transform_from_matrix(&m),
            Some([100.0, 1.0, 2.0, 200.0, 3.0, -4.0])
        );
        let mut t = [100.0, 2.0, 0.0, 50.0, 0.0, -2.0];
        half_cell_shift(&mut t, -1.0);
        assert_eq!(t, [99.0, 2.0, 0.0, 51.0, 0.0, -2.0]);
    }
}
