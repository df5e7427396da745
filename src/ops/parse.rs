//! The one parser of each value a user writes as text, shared by the CLI
//! (its clap arguments call these) and job files (`ops::job`): byte sizes
//! ("512MiB"), distances ("10km", "500m"), and the run and output-format
//! settings every raster command takes ([`RunOptions`], [`FormatOptions`]).

use crate::error::{Error, Result};
use crate::exec::{EngineConfig, EngineKind};
use crate::io::geotiff::{Compression, Resampling, WriteOptions};
use crate::io::{OpenOptions, OutputOptions, Overviews};

/// `--geojson-crs` of every command writing GeoJSON (`peaks`, `ridges`,
/// `streams`, `basins --metrics`) and their job steps' `geojson_crs`.
pub use crate::io::geojson::GeoJsonCrs;

/// `--geojson-crs wgs84|native` ([`GeoJsonCrs`]).
pub fn geojson_crs(s: &str) -> Result<GeoJsonCrs> {
    GeoJsonCrs::parse(s)
}

pub use crate::hydro::fill_nodata::Reach;

/// A byte size such as `512MiB`, `2GiB` or `1048576` (binary units: K, M, G,
/// T with or without `B`/`iB`, any case); at least 16 MiB, the smallest
/// budget the engine works in.
pub fn bytes(s: &str) -> Result<u64> {
    let t = s.trim();
    let split = t
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(t.len());
    let (num, unit) = t.split_at(split);
    let v: f64 = num.parse().map_err(|_| {
        Error::invalid(format!(
            "--memory {s:?}: expected a size like 512MiB or 2GiB"
        ))
    })?;
    let mult = match unit.trim().to_ascii_lowercase().as_str() {
        "" | "b" => 1.0,
        "k" | "kb" | "kib" => 1024.0,
        "m" | "mb" | "mib" => 1024.0 * 1024.0,
        "g" | "gb" | "gib" => 1024.0 * 1024.0 * 1024.0,
        "t" | "tb" | "tib" => 1024.0f64.powi(4),
        u => {
            return Err(Error::invalid(format!(
                "--memory {s:?}: unknown unit {u:?} (use KiB, MiB, GiB)"
            )))
        }
    };
    let b = v * mult;
    if b.is_nan() || b < 16.0 * 1024.0 * 1024.0 {
        return Err(Error::invalid(format!(
            "--memory {s:?} is too small: give at least 16MiB"
        )));
    }
    Ok(b as u64)
}

/// A positive distance in metres: `10km`, `500m` or a bare number of
/// metres (any case). The error names the value, not the option: callers
/// prefix it with the option's name.
pub fn distance(s: &str) -> Result<f64> {
    let t = s.trim().to_ascii_lowercase();
    let (num, mult) = if let Some(v) = t.strip_suffix("km") {
        (v, 1000.0)
    } else if let Some(v) = t.strip_suffix('m') {
        (v, 1.0)
    } else {
        (t.as_str(), 1.0)
    };
    let v: f64 = num.trim().parse().map_err(|e| {
        Error::invalid(format!("{s:?}: expected a distance like 10km or 500m: {e}"))
    })?;
    let d = v * mult;
    if !(d.is_finite() && d > 0.0) {
        return Err(Error::invalid(format!("{s:?}: give a positive distance")));
    }
    Ok(d)
}

/// A maximum distance in cells or with a unit: `100` or `100c` (cells, as
/// gdal_fillnodata's `-md`), `500m`, `3km` (metres). The error names the
/// value, not the option.
pub fn reach(s: &str) -> Result<Reach> {
    let t = s.trim().to_ascii_lowercase();
    let bad = |why: &str| {
        Error::invalid(format!(
            "{s:?}: {why}; write cells (100 or 100c) or metres (500m, 3km)"
        ))
    };
    let (num, unit) = if let Some(v) = t.strip_suffix("km") {
        (v, Some(1000.0))
    } else if let Some(v) = t.strip_suffix('m') {
        (v, Some(1.0))
    } else if let Some(v) = t.strip_suffix('c') {
        (v, None)
    } else {
        (t.as_str(), None)
    };
    let v: f64 = num.trim().parse().map_err(|_| bad("expected a distance"))?;
    if !(v.is_finite() && v > 0.0) {
        return Err(bad("give a positive, finite distance"));
    }
    Ok(match unit {
        Some(m) => Reach::Metres(v * m),
        None => Reach::Cells(v),
    })
}

/// Serde form of a [`Reach`]: a number of cells (`max_distance = 100`) or
/// text parsed by [`reach`] (`max_distance = "3km"`); written as text.
pub mod serde_reach {
    use super::Reach;
    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(v: &Reach, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&match v {
            Reach::Cells(c) => format!("{c}"),
            Reach::Metres(m) => format!("{m}m"),
        })
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Reach, D::Error> {
        match super::NumberOrText::deserialize(d)? {
            super::NumberOrText::Number(v) => super::reach(&v.to_string()),
            super::NumberOrText::Text(t) => super::reach(&t),
        }
        .map_err(serde::de::Error::custom)
    }
}

/// A number or text, as a job file may write a distance.
#[derive(serde::Deserialize)]
#[serde(untagged)]
enum NumberOrText {
    Number(f64),
    Text(String),
}

impl NumberOrText {
    fn distance<E: serde::de::Error>(self) -> std::result::Result<f64, E> {
        match self {
            NumberOrText::Number(v) if v.is_finite() && v > 0.0 => Ok(v),
            NumberOrText::Number(v) => Err(E::custom(format!("{v}: give a positive distance"))),
            NumberOrText::Text(t) => distance(&t).map_err(E::custom),
        }
    }
}

/// Serde form of a distance field: metres as a number, or text parsed by
/// [`distance`] (`radius = "10km"`); written as metres.
pub mod serde_distance {
    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_f64(*v)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
        super::NumberOrText::deserialize(d)?.distance()
    }
}

/// [`serde_distance`] for an optional distance.
pub mod serde_distance_opt {
    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(v: &Option<f64>, s: S) -> Result<S::Ok, S::Error> {
        match v {
            Some(v) => s.serialize_some(v),
            None => s.serialize_none(),
        }
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
        Option::<super::NumberOrText>::deserialize(d)?
            .map(|v| v.distance())
            .transpose()
    }
}

/// Run settings of every command (`--threads --memory --tile --quiet
/// --engine`; a job's `threads`, `memory`, `tile`, `engine`).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RunOptions {
    /// Worker threads (0 = all cores).
    pub threads: usize,
    /// Memory budget for tiles in flight, e.g. 512MiB, 2GiB.
    pub memory: String,
    /// Work-tile size in cells (default: the input store's, else 1024).
    pub tile: Option<usize>,
    /// No progress bar.
    pub quiet: bool,
    /// Engine (None: the one this process runs on).
    pub engine: Option<EngineKind>,
    /// Told of the run's progress (a library caller's; never a key).
    #[serde(skip)]
    pub observer: Option<crate::exec::Observer>,
}

impl Default for RunOptions {
    fn default() -> Self {
        RunOptions {
            threads: 0,
            memory: "1GiB".into(),
            tile: None,
            quiet: false,
            engine: None,
            observer: None,
        }
    }
}

impl RunOptions {
    /// The engine settings: the engine named is made the process's engine
    /// first (MPI starts here), then the process's current one is used; a
    /// progress bar when not quiet and `terminal`.
    ///
    /// `tile = 0` is refused; more threads than the machine has cores are
    /// clamped to its cores (the results are the same bytes for any thread
    /// count; thousands of threads only make a run crawl).
    pub fn engine_config(&self, terminal: bool) -> Result<EngineConfig> {
        if self.tile == Some(0) {
            return Err(Error::invalid(
                "--tile 0: a work tile needs at least 1 cell (default: the input store's tile, else 1024)",
            ));
        }
        if let Some(e) = self.engine {
            crate::exec::select_engine(e)?;
        }
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        Ok(EngineConfig {
            threads: self.threads.min(cores),
            memory_budget: bytes(&self.memory)?,
            progress: !self.quiet && terminal,
            observer: self.observer.clone(),
            engine: EngineKind::current(),
        })
    }
}

/// GeoTIFF compression of `--compress`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Compress {
    /// No compression.
    None,
    /// DEFLATE, level 6.
    #[default]
    Deflate,
    /// LZW.
    Lzw,
    /// Zstandard, level 9.
    Zstd,
}

/// Output format settings of every command writing rasters (`--compress
/// --predictor --block --bigtiff --store-tile --zstd --overwrite --cog
/// --overviews`), checked and turned into [`OutputOptions`] by
/// [`FormatOptions::output_options`].
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FormatOptions {
    /// GeoTIFF compression.
    pub compress: Compress,
    /// GeoTIFF predictor (1 none, 2 horizontal, 3 floating point; None: automatic).
    pub predictor: Option<u16>,
    /// GeoTIFF block (tile) size.
    pub block: usize,
    /// BigTIFF: yes, no or auto (auto: when the file could pass 4 GiB).
    pub bigtiff: String,
    /// Tile-store tile size (for .tiles outputs).
    pub store_tile: usize,
    /// Compress tile-store tiles with zstd.
    pub zstd: bool,
    /// Replace an existing output tile store instead of resuming it.
    pub overwrite: bool,
    /// Write .tif outputs as Cloud-Optimized GeoTIFFs (internal overviews).
    pub cog: bool,
    /// COG overview resampling: auto (by what each output holds: nearest
    /// for classes, codes and angles, average otherwise), average or nearest.
    pub overviews: String,
    /// PNG heightmap outputs: metres per PNG unit (None: the data's range
    /// over 0..65535).
    pub png_out_scale: Option<f64>,
    /// PNG heightmap outputs: elevation of PNG value 0 (None: the data's minimum).
    pub png_out_offset: Option<f64>,
}

impl Default for FormatOptions {
    fn default() -> Self {
        FormatOptions {
            compress: Compress::Deflate,
            predictor: None,
            block: 256,
            bigtiff: "auto".into(),
            store_tile: 1024,
            zstd: false,
            overwrite: false,
            cog: false,
            overviews: "auto".into(),
            png_out_scale: None,
            png_out_offset: None,
        }
    }
}

impl FormatOptions {
    /// Check the settings and build the writers' options.
    pub fn output_options(&self) -> Result<OutputOptions> {
        let bad = |m: String| Err(Error::invalid(m));
        let compression = match self.compress {
            Compress::None => Compression::None,
            Compress::Deflate => Compression::Deflate { level: 6 },
            Compress::Lzw => Compression::Lzw,
            Compress::Zstd => Compression::Zstd { level: 9 },
        };
        let bigtiff = match self.bigtiff.as_str() {
            "auto" => None,
            "yes" | "true" => Some(true),
            "no" | "false" => Some(false),
            b => return bad(format!("--bigtiff {b:?}: use yes, no or auto")),
        };
        if let Some(p) = self.predictor {
            if !(1..=3).contains(&p) {
                return bad(format!(
                    "--predictor {p}: use 1 (none), 2 (horizontal) or 3 (floating point)"
                ));
            }
        }
        if self.block < 16 || !self.block.is_multiple_of(16) {
            return bad(format!(
                "--block {}: GeoTIFF tiles must be a multiple of 16 (e.g. 256, 512)",
                self.block
            ));
        }
        if self.store_tile < 16 {
            return bad(format!(
                "--store-tile {}: use at least 16 (e.g. 1024)",
                self.store_tile
            ));
        }
        let tiff = WriteOptions {
            compression,
            predictor: self.predictor,
            block: self.block,
            bigtiff,
        };
        let mut store = crate::store::StoreOptions::default();
        store.tile = self.store_tile;
        store.compression = if self.zstd {
            crate::store::Compression::Zstd { level: 3 }
        } else {
            crate::store::Compression::None
        };
        store.overwrite = self.overwrite;
        let cog = if self.cog {
            Some(match self.overviews.as_str() {
                "auto" => Overviews::ByKind,
                "average" => Overviews::Fixed(Resampling::Average),
                "nearest" => Overviews::Fixed(Resampling::Nearest),
                r => {
                    return bad(format!(
                        "--overviews {r:?}: use auto (by what the output holds), average (continuous data) or nearest (classes)"
                    ))
                }
            })
        } else {
            None
        };
        for (flag, v) in [
            ("--png-out-scale", self.png_out_scale),
            ("--png-out-offset", self.png_out_offset),
        ] {
            if v.is_some_and(|v| !v.is_finite() || (flag == "--png-out-scale" && v <= 0.0)) {
                return bad(format!(
                    "{flag} {}: give a finite number (a scale > 0)",
                    v.unwrap_or(f64::NAN)
                ));
            }
        }
        Ok(OutputOptions {
            tiff,
            store,
            cog,
            memory: None,
            png_scale: self.png_out_scale,
            png_offset: self.png_out_offset,
        })
    }
}

/// How raster inputs are read: the band of a multi-band GeoTIFF
/// (`--band`), the PNG heightmap scaling (`--png-scale --png-offset`), the
/// nodata value (`--nodata`), the sea masked as nodata (`--sea-level`), a
/// mask (`--mask`) and whether a sparse mosaic is built (`--allow-sparse`).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct InputOptions {
    /// The band read from a multi-band GeoTIFF (1-based).
    pub band: usize,
    /// Metres per PNG unit (None: the mapping the PNG records, else 1).
    pub png_scale: Option<f64>,
    /// Elevation of PNG value 0 (None: the recorded one, else 0).
    pub png_offset: Option<f64>,
    /// The input's nodata value (replaces the file's, or assigns one).
    pub nodata: Option<f64>,
    /// Cells at or below this elevation are nodata (the sea is an outlet).
    pub sea_level: Option<f64>,
    /// A raster on the input's grid: where it is 0 or nodata, the input is nodata.
    pub mask: Option<std::path::PathBuf>,
    /// Build a mosaic (several inputs, a folder, a `.vrt`) whose sources
    /// leave more than half of its extent uncovered (refused otherwise).
    pub allow_sparse: bool,
}

impl Default for InputOptions {
    fn default() -> Self {
        InputOptions {
            band: 1,
            png_scale: None,
            png_offset: None,
            nodata: None,
            sea_level: None,
            mask: None,
            allow_sparse: false,
        }
    }
}

impl InputOptions {
    /// The readers' options.
    pub fn open_options(&self) -> OpenOptions {
        OpenOptions {
            band: self.band,
            png_scale: self.png_scale,
            png_offset: self.png_offset,
            nodata: self.nodata,
            sea_level: self.sea_level,
            mask: self.mask.clone(),
            allow_sparse: self.allow_sparse,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_and_distances() {
        assert_eq!(bytes("512MiB").unwrap(), 512 << 20);
        assert_eq!(bytes("2g").unwrap(), 2 << 30);
        assert!(bytes("1MiB").is_err());
        assert!(bytes("ten").is_err());
        assert_eq!(distance("10km").unwrap(), 10_000.0);
        assert_eq!(distance("500M").unwrap(), 500.0);
        assert!(distance("ten km").is_err());
        assert!(distance("-5m").is_err());
    }

    #[test]
    fn format_checks() {
        assert!(FormatOptions::default().output_options().is_ok());
        let f = FormatOptions {
            block: 100,
            ..Default::default()
        };
        assert!(f.output_options().is_err());
        let f = FormatOptions {
            cog: true,
            overviews: "cubic".into(),
            ..Default::default()
        };
        assert!(f.output_options().is_err());
    }
}
