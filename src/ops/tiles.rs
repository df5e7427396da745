//! `orogen tiles`: a web-map tile pyramid in Web Mercator
//! ([`crate::tiles::pyramid`]) cut into a `z/x/y` folder and packed into
//! MBTiles and/or PMTiles archives ([`crate::tiles::archive`]).

use crate::error::{Error, Result};
use crate::exec::EngineConfig;
use crate::raster::RasterSource;
use crate::store::scratch::ScratchDir;
use crate::tiles::{archive, build_pyramid, Encoding, PyramidInfo, PyramidOptions, Resampling};
use std::path::{Path, PathBuf};

/// Options of `orogen tiles`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TilesOptions {
    /// Tile encoding: terrain-rgb (Mapbox), terrarium, or color.
    pub encoding: String,
    /// Colour ramp of `color` tiles.
    pub ramp: String,
    /// Value range of `color` tiles (`None`: the data's min..max).
    #[serde(with = "range_text")]
    pub range: Option<(f64, f64)>,
    /// Lowest zoom (`None`: chosen from the raster's extent).
    pub min_zoom: Option<u8>,
    /// Highest zoom (`None`: chosen from the raster's resolution).
    pub max_zoom: Option<u8>,
    /// Resampling: bilinear or nearest.
    pub resampling: String,
}

impl Default for TilesOptions {
    fn default() -> Self {
        TilesOptions {
            encoding: "terrain-rgb".into(),
            ramp: "viridis".into(),
            range: None,
            min_zoom: None,
            max_zoom: None,
            resampling: "bilinear".into(),
        }
    }
}

/// `--range lo,hi` of `orogen tiles`.
pub fn parse_range(r: &str) -> Result<(f64, f64)> {
    let v: Vec<f64> = r
        .split(',')
        .map(|s| s.trim().parse::<f64>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|e| Error::invalid(format!("--range {r:?}: expected lo,hi: {e}")))?;
    if v.len() != 2 || v[0].partial_cmp(&v[1]) != Some(std::cmp::Ordering::Less) {
        return Err(Error::invalid(format!(
            "--range {r:?}: expected two numbers lo,hi with lo < hi"
        )));
    }
    Ok((v[0], v[1]))
}

/// Serde form of [`TilesOptions::range`]: `"lo,hi"` ([`parse_range`]) or
/// `[lo, hi]`; written as `[lo, hi]`.
mod range_text {
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Range {
        Pair(f64, f64),
        Text(String),
    }

    pub fn serialize<S: Serializer>(v: &Option<(f64, f64)>, s: S) -> Result<S::Ok, S::Error> {
        v.serialize(s)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<(f64, f64)>, D::Error> {
        match Option::<Range>::deserialize(d)? {
            None => Ok(None),
            Some(Range::Pair(lo, hi)) => super::parse_range(&format!("{lo},{hi}"))
                .map(Some)
                .map_err(serde::de::Error::custom),
            Some(Range::Text(t)) => super::parse_range(&t)
                .map(Some)
                .map_err(serde::de::Error::custom),
        }
    }
}

impl TilesOptions {
    /// Check the encoding and resampling and build the pyramid's options.
    pub fn pyramid_options(&self) -> Result<PyramidOptions> {
        let encoding = match self.encoding.as_str() {
            "terrain-rgb" | "terrainrgb" | "mapbox" => Encoding::TerrainRgb,
            "terrarium" => Encoding::Terrarium,
            "color" | "colour" => Encoding::Color {
                ramp: self.ramp.clone(),
                range: self.range,
            },
            e => {
                return Err(Error::invalid(format!(
                    "--encoding {e:?}: use terrain-rgb, terrarium or color"
                )))
            }
        };
        let resampling = match self.resampling.as_str() {
            "bilinear" => Resampling::Bilinear,
            "nearest" => Resampling::Nearest,
            r => {
                return Err(Error::invalid(format!(
                    "--resampling {r:?}: use bilinear or nearest"
                )))
            }
        };
        Ok(PyramidOptions {
            encoding,
            resampling,
            min_zoom: self.min_zoom,
            max_zoom: self.max_zoom,
        })
    }
}

/// What an output path of `orogen tiles` is, by its extension: `.mbtiles`,
/// `.pmtiles`, else a folder (checked by [`check_outputs`] first).
fn kind(p: &Path) -> &'static str {
    if ends_with_separator(p) {
        return "dir";
    }
    match p.extension().and_then(|e| e.to_str()) {
        Some(e) if e.eq_ignore_ascii_case("mbtiles") => "mbtiles",
        Some(e) if e.eq_ignore_ascii_case("pmtiles") => "pmtiles",
        _ => "dir",
    }
}

fn ends_with_separator(p: &Path) -> bool {
    let s = p.as_os_str().to_string_lossy();
    s.ends_with('/') || s.ends_with(std::path::MAIN_SEPARATOR)
}

/// Every output is a folder (no extension, or a path ending with `/`),
/// `.mbtiles` or `.pmtiles`, and a folder output is not an existing file:
/// `-o bad.png` is refused before any work instead of becoming a folder
/// named `bad.png`.
fn check_outputs(outputs: &[PathBuf]) -> Result<()> {
    for o in outputs {
        let ext = o.extension().and_then(|e| e.to_str());
        if kind(o) == "dir" {
            if let (Some(e), false) = (ext, ends_with_separator(o)) {
                return Err(Error::invalid(format!(
                    "{}: orogen tiles writes a folder of z/x/y tiles, a .mbtiles or a .pmtiles archive, not a .{e} file; for a folder whose name has a dot, end the path with /",
                    o.display()
                )));
            }
            if o.is_file() {
                return Err(Error::invalid(format!(
                    "{}: is a file; a folder output of orogen tiles must be a folder or a new path",
                    o.display()
                )));
            }
        }
    }
    Ok(())
}

/// Cut `src` into a pyramid and write it to every path of `outputs` (a
/// folder, `.mbtiles` or `.pmtiles`; without a folder output the tiles are
/// cut into a hidden scratch folder beside the first output, removed
/// afterwards). An earlier pyramid in the folder output is replaced.
/// `cfg.threads` > 0 sizes rayon's global pool (the pyramid recursion
/// runs on it). Returns what the pyramid holds.
pub fn run(
    src: &dyn RasterSource,
    outputs: &[PathBuf],
    opts: &TilesOptions,
    cfg: &EngineConfig,
) -> Result<PyramidInfo> {
    check_outputs(outputs)?;
    let popts = opts.pyramid_options()?;
    let data_range = if matches!(popts.encoding, Encoding::Color { range: None, .. }) {
        let d = super::describe(src, true, cfg)?;
        d.stats.and_then(|s| Some((s.min?, s.max?)))
    } else {
        None
    };
    if cfg.threads > 0 {
        // The pyramid recursion runs on rayon's global pool.
        let _ = rayon::ThreadPoolBuilder::new()
            .num_threads(cfg.threads)
            .build_global();
    }
    // The folder to cut into: the first folder output, else a scratch folder.
    let folder = outputs.iter().find(|p| kind(p) == "dir").cloned();
    let scratch = match &folder {
        Some(_) => None,
        None => {
            let first = outputs.first().ok_or_else(|| Error::invalid("no output"))?;
            let name = first
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            // Scratch folders of killed runs (their pid no longer runs) go first.
            let parent = match first.parent() {
                Some(d) if !d.as_os_str().is_empty() => d,
                _ => Path::new("."),
            };
            crate::io::atomic::remove_dead_pid_files(parent, &format!(".{name}.orogen-tiles-"));
            Some(ScratchDir::new(first.with_file_name(format!(
                ".{name}.orogen-tiles-{}",
                std::process::id()
            ))))
        }
    };
    let dir = folder
        .clone()
        .or_else(|| scratch.as_ref().map(|s| s.path().to_path_buf()))
        .ok_or_else(|| Error::invalid("no output"))?;
    if folder.is_some() && dir.join("metadata.json").exists() {
        std::fs::remove_dir_all(&dir).map_err(|e| {
            Error::invalid(format!(
                "replacing the earlier pyramid in {}: {e}",
                dir.display()
            ))
        })?;
    }
    let result = (|| -> Result<PyramidInfo> {
        let info = build_pyramid(src, &dir, &popts, data_range)?;
        for o in outputs {
            match kind(o) {
                "mbtiles" => {
                    archive::write_mbtiles(&dir, &info, o)?;
                }
                "pmtiles" => {
                    archive::write_pmtiles(&dir, &info, o)?;
                }
                _ => {}
            }
        }
        Ok(info)
    })();
    // The scratch folder (if any) is removed when dropped.
    drop(scratch);
    result
}

/// The one-line summary of a pyramid written by [`run`] (zooms, tiles,
/// bounds in degrees).
pub fn summary(info: &PyramidInfo) -> String {
    format!(
        "zooms {}..{}, {} tiles, bounds {:.5},{:.5},{:.5},{:.5}",
        info.min_zoom,
        info.max_zoom,
        info.tiles,
        info.bounds[0],
        info.bounds[1],
        info.bounds[2],
        info.bounds[3]
    )
}
