//! `orogen streams`: the stream network of D8 directions
//! ([`crate::hydro::streams`]): GeoJSON links with Strahler order, Shreve
//! magnitude, length and drainage area; a stream raster; Horton/Tokunaga
//! statistics; in memory.

use super::hydro_io::{full, guard, open_path, read_dirs, same_size, write_mem};
use super::Target;
use crate::error::{Error, Result};
use crate::exec::EngineConfig;
use crate::hydro::{streams, NODATA_DIR};
use crate::ops::parse::GeoJsonCrs;
use crate::raster::{read_window, DType, MemRaster, RasterSource};
use std::path::PathBuf;

/// Options of `orogen streams`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StreamsOptions {
    /// Channel threshold in cells of drainage area (default 1000 unless `area`/`slope_area`).
    pub threshold: Option<f64>,
    /// Channel threshold as drainage area in m².
    pub area: Option<f64>,
    /// Channel initiation A·s² > C (Montgomery & Dietrich), A in m², s = D8 slope; needs `dem`.
    pub slope_area: Option<f64>,
    /// Filled DEM (for `slope_area`).
    pub dem: Option<PathBuf>,
    /// Also write the stream raster (Strahler order, 0 = no stream, 255 nodata).
    pub raster: Option<PathBuf>,
    /// Also write network statistics (Horton ratios, Tokunaga numbers, Mueller sinuosity) as JSON.
    pub stats: Option<PathBuf>,
    /// Also write one CSV row per link.
    pub csv: Option<PathBuf>,
    /// Also write the network's nodes (heads, confluences, outlets) as GeoJSON Points.
    pub nodes: Option<PathBuf>,
    /// Half window (cells) of the valley-line smoothing for Mueller's valley length.
    pub valley_window: usize,
    /// Coordinates of the GeoJSON outputs: `wgs84` (longitude/latitude,
    /// RFC 7946) or `native` (the raster's CRS, named in a `crs` member);
    /// see [`crate::io::geojson`].
    pub geojson_crs: GeoJsonCrs,
}

impl Default for StreamsOptions {
    fn default() -> Self {
        StreamsOptions {
            threshold: None,
            area: None,
            slope_area: None,
            dem: None,
            raster: None,
            stats: None,
            csv: None,
            nodes: None,
            valley_window: 10,
            geojson_crs: GeoJsonCrs::Wgs84,
        }
    }
}

impl StreamsOptions {
    /// The channel rule (one of threshold, area, slope-area), checked.
    pub fn rule(&self) -> Result<streams::ChannelRule> {
        let given = [self.threshold, self.area, self.slope_area]
            .iter()
            .filter(|v| v.is_some())
            .count();
        if given > 1 {
            return Err(Error::invalid(
                "give only one of --threshold, --area, --slope-area",
            ));
        }
        let rule = if let Some(t) = self.area {
            streams::ChannelRule::Area(t)
        } else if let Some(c) = self.slope_area {
            streams::ChannelRule::SlopeArea(c)
        } else {
            streams::ChannelRule::Cells(self.threshold.unwrap_or(1000.0))
        };
        let t = match rule {
            streams::ChannelRule::Cells(t)
            | streams::ChannelRule::Area(t)
            | streams::ChannelRule::SlopeArea(t) => t,
        };
        if !(t.is_finite() && t > 0.0) {
            return Err(Error::invalid(format!(
                "the channel threshold must be a positive number, not {t}"
            )));
        }
        Ok(rule)
    }
}

/// What [`run`] extracted and wrote.
#[derive(Debug, Clone)]
pub struct StreamsOutcome {
    /// Links of the network.
    pub links: usize,
    /// Nodes of the network.
    pub nodes: usize,
    /// Highest Strahler order.
    pub max_order: u32,
    /// Files written, in order.
    pub files: Vec<PathBuf>,
    /// Warnings (a raster without a known CRS: GeoJSON in its own coordinates).
    pub warnings: Vec<String>,
}

/// Extract the stream network of the D8 directions `dirs` and write its
/// links to `target.path` (GeoJSON) and the other outputs `opts` names
/// (the stream raster with `target.options`).
pub fn run(
    dirs: &dyn RasterSource,
    opts: &StreamsOptions,
    target: &Target,
    cfg: &EngineConfig,
) -> Result<StreamsOutcome> {
    let a = opts;
    let rule = a.rule()?;
    guard(
        dirs,
        streams::NETWORK_BYTES_PER_CELL,
        "stream network extraction",
        cfg,
    )?;
    let info = dirs.info().clone();
    let coords = opts.geojson_crs.coords(&info.georef, &info.path)?;
    let d = read_dirs(dirs)?;
    let dem = match &a.dem {
        Some(p) => {
            let s = open_path(p)?;
            same_size(dirs, s.as_ref())?;
            Some(read_window::<f32>(s.as_ref(), full(s.as_ref()))?)
        }
        None => None,
    };
    if matches!(rule, streams::ChannelRule::SlopeArea(_)) && dem.is_none() {
        return Err(Error::invalid(
            "--slope-area needs the filled DEM: add --dem filled.tif",
        ));
    }
    let net = streams::extract_network(
        &d,
        dem.as_ref(),
        &info.georef,
        &streams::NetworkOptions {
            rule,
            valley_window: a.valley_window,
        },
    )?;
    net.write_geojson(&target.path, &coords)?;
    let mut files = vec![target.path.clone()];
    if let Some(p) = &a.csv {
        net.write_links_csv(p)?;
        files.push(p.clone());
    }
    if let Some(p) = &a.nodes {
        net.write_nodes_geojson(p, &coords)?;
        files.push(p.clone());
    }
    if let Some(p) = &a.stats {
        let s = serde_json::to_string_pretty(&net.stats_json())
            .map_err(|e| Error::invalid(e.to_string()))?;
        crate::io::atomic::write_file_atomic(p, s.as_bytes())?;
        files.push(p.clone());
    }
    if let Some(p) = &a.raster {
        let mem = MemRaster::from_grid(net.order.clone(), info.georef.clone());
        write_mem(
            mem,
            p,
            &target.options,
            target.tile,
            cfg,
            (DType::U8, Some(NODATA_DIR as f64)),
        )?;
        files.push(p.clone());
    }
    Ok(StreamsOutcome {
        links: net.links.len(),
        nodes: net.nodes.len(),
        max_order: net.links.iter().map(|l| l.strahler).max().unwrap_or(0),
        files,
        warnings: coords.warning().map(str::to_string).into_iter().collect(),
    })
}
