//! `orogen info`: describe a raster (size, type, georeference, nodata and,
//! if asked, statistics from a global pass).

use super::choose_tile;
use crate::error::Result;
use crate::exec::{engine, Engine, EngineConfig, Run};
use crate::io;
use crate::raster::{DType, RasterSource, TileLayout};

/// Options of `orogen info`.
#[derive(Debug, Clone, Default, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct InfoOptions {
    /// Also compute min/max/mean (reads every cell).
    pub stats: bool,
    /// Report as JSON rather than text ([`report_text`]).
    pub json: bool,
}

/// Describe `src` ([`describe`] with the options of `orogen info`).
pub fn run(src: &dyn RasterSource, opts: &InfoOptions, cfg: &EngineConfig) -> Result<Description> {
    describe(src, opts.stats, cfg)
}

/// The report `orogen info` prints of `d`: pretty JSON with `json`, else
/// the text of [`describe_text`].
pub fn report_text(d: &Description, opts: &InfoOptions) -> Result<String> {
    if opts.json {
        serde_json::to_string_pretty(d)
            .map(|j| j + "\n")
            .map_err(|e| crate::error::Error::invalid(format!("info as JSON: {e}")))
    } else {
        Ok(describe_text(d))
    }
}

/// What `orogen info` reports.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Description {
    pub path: String,
    pub format: String,
    pub width: usize,
    pub height: usize,
    pub dtype: DType,
    pub transform: [f64; 6],
    pub epsg: Option<u32>,
    pub geographic: bool,
    /// The declared nodata: a JSON number, or the text `"nan"`, `"inf"`,
    /// `"-inf"` (JSON has no such numbers; `null` means no nodata).
    #[serde(serialize_with = "nodata_json")]
    pub nodata: Option<f64>,
    pub raster_type: crate::raster::RasterType,
    pub georeferenced: bool,
    /// Georeferencing the file holds that is not used (GCPs, RPCs).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub unused_georef: Option<String>,
    pub block: (usize, usize),
    /// The band's scale and offset, applied on read (`raw * scale + offset`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub scaling: Option<crate::raster::Scaling>,
    /// Cell size in metres at the middle row (east-west, north-south).
    pub cell_size_m: (f64, f64),
    pub stats: Option<crate::exec::stats::StatsSummary>,
}

/// `nodata` as JSON: a number when finite, else the GDAL_NODATA text of
/// the value, `null` when there is none.
fn nodata_json<S: serde::Serializer>(
    v: &Option<f64>,
    s: S,
) -> std::result::Result<S::Ok, S::Error> {
    match v {
        None => s.serialize_none(),
        Some(v) if v.is_finite() => s.serialize_f64(*v),
        Some(v) => s.serialize_str(&crate::io::geotiff::format_nodata(*v)),
    }
}

/// Describe a raster (and compute its statistics with a global pass if
/// asked); its first block is read either way, so an undecodable file is
/// an error here, not a description.
pub fn describe(src: &dyn RasterSource, stats: bool, cfg: &EngineConfig) -> Result<Description> {
    let info = src.info();
    let g = &info.georef;
    // The first block is decoded even without statistics: a file whose
    // pixels cannot be read is not reported as fine.
    if info.width > 0 && info.height > 0 {
        let side = |block: usize, n: usize| block.clamp(1, 256).min(n);
        let (w, h) = (
            side(info.block.0, info.width),
            side(info.block.1, info.height),
        );
        src.read_native(crate::raster::Window::new(0, 0, w, h))?;
    }
    let stats = if stats {
        let step = crate::exec::stats::Stats::new(-1e300, 1e300, 1)?;
        let info = src.info();
        let layout = TileLayout::new(info.width, info.height, choose_tile(src, None));
        Some(engine(cfg)?.run_global(&step, Run::solution_only(&[src], layout))?)
    } else {
        None
    };
    Ok(Description {
        path: info.path.display().to_string(),
        format: io::detect(&info.path)
            .map(|f| f.name())
            .unwrap_or("in memory")
            .to_string(),
        width: info.width,
        height: info.height,
        dtype: info.dtype,
        transform: g.transform,
        epsg: g.crs.epsg,
        geographic: g.crs.geographic,
        nodata: g.nodata,
        raster_type: g.raster_type,
        georeferenced: g.georeferenced,
        unused_georef: src.unused_georef().map(str::to_string),
        block: info.block,
        scaling: src.scaling(),
        cell_size_m: g.cell_size_m(info.height as i64 / 2),
        stats,
    })
}

/// Human-readable form of a [`Description`].
pub fn describe_text(d: &Description) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let _ = writeln!(s, "{}", d.path);
    let _ = writeln!(
        s,
        "  size        {} x {} cells, {}",
        d.width, d.height, d.dtype
    );
    let _ = writeln!(s, "  block       {} x {}", d.block.0, d.block.1);
    if let Some(u) = &d.unused_georef {
        let _ = writeln!(s, "  not used    {u}");
    }
    if let Some(sc) = &d.scaling {
        let _ = writeln!(
            s,
            "  scaling     raw * {} + {} (the band's scale and offset, applied on read)",
            sc.scale, sc.offset
        );
    }
    if d.georeferenced {
        let crs = match d.epsg {
            Some(e) => format!("EPSG:{e}"),
            None => "unknown CRS".into(),
        };
        let _ = writeln!(
            s,
            "  crs         {crs}{}",
            if d.geographic { " (geographic)" } else { "" }
        );
        let t = d.transform;
        let _ = writeln!(s, "  origin      ({}, {})", t[0], t[3]);
        let _ = writeln!(
            s,
            "  pixel size  ({}, {}), rotation ({}, {})",
            t[1], t[5], t[2], t[4]
        );
        let _ = writeln!(
            s,
            "  cell (m)    {:.3} x {:.3} at the middle row",
            d.cell_size_m.0, d.cell_size_m.1
        );
        let _ = writeln!(s, "  raster type {:?}", d.raster_type);
    } else {
        let _ = writeln!(s, "  no georeferencing (pixel coordinates)");
    }
    match d.nodata {
        Some(v) => {
            let _ = writeln!(s, "  nodata      {v}");
        }
        None => {
            let _ = writeln!(s, "  nodata      none");
        }
    }
    if let Some(st) = &d.stats {
        match (st.min, st.max, st.mean()) {
            (Some(lo), Some(hi), Some(m)) => {
                let _ = writeln!(
                    s,
                    "  stats       min {lo}, max {hi}, mean {m:.6}, {} valid cells, {} nodata",
                    st.count, st.nodata
                );
            }
            _ => {
                let _ = writeln!(s, "  stats       no valid cells ({} nodata)", st.nodata);
            }
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster::{GeoRef, Grid, MemRaster};

    #[test]
    fn json_writes_non_finite_nodata_as_text_not_null() {
        let cfg = EngineConfig::default();
        let opts = InfoOptions {
            json: true,
            ..Default::default()
        };
        for (nd, want) in [
            (Some(f64::NAN), "\"nodata\": \"nan\""),
            (Some(f64::NEG_INFINITY), "\"nodata\": \"-inf\""),
            (Some(-9999.0), "\"nodata\": -9999.0"),
            (None, "\"nodata\": null"),
        ] {
            let g = GeoRef {
                nodata: nd,
                ..GeoRef::pixel()
            };
            let src = MemRaster::from_grid(Grid::new(3, 2, 1.0f32), g);
            let d = describe(&src, false, &cfg).unwrap();
            let j = report_text(&d, &opts).unwrap();
            assert!(j.contains(want), "{want} in {j}");
        }
    }
}
