//! `orogen tiles`: web-map pyramids (z/x/y folder, MBTiles, PMTiles).

use anyhow::{bail, Context, Result};
use clap::Args;
use orogen::tiles::{archive, build_pyramid, Encoding, PyramidOptions, Resampling};
use std::path::{Path, PathBuf};

/// Arguments of `orogen tiles`.
#[derive(Args, Clone)]
pub struct TilesArgs {
    #[command(flatten)]
    pub input: crate::In,
    /// Output: a folder (z/x/y.png), FILE.mbtiles or FILE.pmtiles; repeat -o for several.
    #[arg(short, long, required = true)]
    pub output: Vec<PathBuf>,
    /// Tile encoding: terrain-rgb, terrarium (elevation) or color (any raster, with --ramp).
    #[arg(long, default_value = "terrain-rgb")]
    pub encoding: String,
    /// Colour ramp for --encoding color: terrain, viridis, grey, magma.
    #[arg(long, default_value = "viridis")]
    pub ramp: String,
    /// Value range mapped onto the ramp, "lo,hi" (default: the data's min and max).
    #[arg(long)]
    pub range: Option<String>,
    /// Shallowest zoom (default: where the raster fits in about one tile).
    #[arg(long)]
    pub min_zoom: Option<u8>,
    /// Deepest zoom (default: the first whose pixels are no larger than the raster's cells).
    #[arg(long)]
    pub max_zoom: Option<u8>,
    /// Resampling: bilinear (continuous data) or nearest (classes).
    #[arg(long, default_value = "bilinear")]
    pub resampling: String,
    #[command(flatten)]
    pub run: crate::Run,
}

fn kind(p: &Path) -> &'static str {
    match p.extension().and_then(|e| e.to_str()) {
        Some("mbtiles") => "mbtiles",
        Some("pmtiles") => "pmtiles",
        _ => "dir",
    }
}

pub fn run(a: TilesArgs) -> Result<()> {
    let src = crate::open(&a.input)?;
    let cfg = crate::engine(&a.run)?;
    let range = match &a.range {
        None => None,
        Some(r) => {
            let v: Vec<f64> = r
                .split(',')
                .map(|s| s.trim().parse::<f64>())
                .collect::<std::result::Result<_, _>>()
                .with_context(|| format!("--range {r:?}: expected lo,hi"))?;
            if v.len() != 2 || v[0].partial_cmp(&v[1]) != Some(std::cmp::Ordering::Less) {
                bail!("--range {r:?}: expected two numbers lo,hi with lo < hi");
            }
            Some((v[0], v[1]))
        }
    };
    let encoding = match a.encoding.as_str() {
        "terrain-rgb" | "terrainrgb" | "mapbox" => Encoding::TerrainRgb,
        "terrarium" => Encoding::Terrarium,
        "color" | "colour" => Encoding::Color {
            ramp: a.ramp.clone(),
            range,
        },
        e => bail!("--encoding {e:?}: use terrain-rgb, terrarium or color"),
    };
    let resampling = match a.resampling.as_str() {
        "bilinear" => Resampling::Bilinear,
        "nearest" => Resampling::Nearest,
        r => bail!("--resampling {r:?}: use bilinear or nearest"),
    };
    let data_range = if matches!(encoding, Encoding::Color { range: None, .. }) {
        let d = orogen::ops::describe(src.as_ref(), true, &cfg)?;
        d.stats.and_then(|s| Some((s.min?, s.max?)))
    } else {
        None
    };
    let opts = PyramidOptions {
        encoding,
        resampling,
        min_zoom: a.min_zoom,
        max_zoom: a.max_zoom,
    };
    if cfg.threads > 0 {
        // The pyramid recursion runs on rayon's global pool.
        let _ = rayon::ThreadPoolBuilder::new()
            .num_threads(cfg.threads)
            .build_global();
    }
    // The folder to cut into: the first folder output, else a scratch folder.
    let folder = a.output.iter().find(|p| kind(p) == "dir").cloned();
    let scratch = match &folder {
        Some(_) => None,
        None => {
            let first = &a.output[0];
            let name = first
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            // Scratch folders of killed runs (their pid no longer runs) go first.
            let parent = match first.parent() {
                Some(d) if !d.as_os_str().is_empty() => d,
                _ => Path::new("."),
            };
            orogen::io::atomic::remove_dead_pid_files(parent, &format!(".{name}.orogen-tiles-"));
            Some(first.with_file_name(format!(".{name}.orogen-tiles-{}", std::process::id())))
        }
    };
    let dir = folder.clone().or(scratch.clone()).context("no output")?;
    if folder.is_some() && dir.join("metadata.json").exists() {
        std::fs::remove_dir_all(&dir)
            .with_context(|| format!("replacing the earlier pyramid in {}", dir.display()))?;
    }
    let result = (|| -> Result<()> {
        let info = build_pyramid(src.as_ref(), &dir, &opts, data_range)?;
        eprintln!(
            "zooms {}..{}, {} tiles, bounds {:.5},{:.5},{:.5},{:.5}",
            info.min_zoom,
            info.max_zoom,
            info.tiles,
            info.bounds[0],
            info.bounds[1],
            info.bounds[2],
            info.bounds[3]
        );
        for o in &a.output {
            match kind(o) {
                "mbtiles" => {
                    archive::write_mbtiles(&dir, &info, o)?;
                }
                "pmtiles" => {
                    archive::write_pmtiles(&dir, &info, o)?;
                }
                _ => {}
            }
            crate::wrote(o);
        }
        Ok(())
    })();
    if let Some(s) = scratch {
        let _ = std::fs::remove_dir_all(s);
    }
    result
}
