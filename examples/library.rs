//! orogen as a library: the operations the CLI runs, called with their
//! Options structs (`orogen::ops::<operation>`), no clap involved.
//!
//! `cargo run --release --example library -- DEM.tif OUT_DIR`
//!
//! Fills the DEM's depressions, routes D8 flow, accumulates it, computes
//! slope and lists the peaks of at least 30 m prominence, writing each
//! result into OUT_DIR; every step runs tile by tile within the default
//! memory budget, exactly as `orogen fill|flow|accumulate|slope|peaks` do.

use orogen::exec::EngineConfig;
use orogen::io::{open_raster, OpenOptions};
use orogen::ops::{accumulate, fill, flow, peaks, slope, Target};
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() != 3 {
        eprintln!("usage: library DEM.tif OUT_DIR");
        std::process::exit(2);
    }
    let out = PathBuf::from(&args[2]);
    std::fs::create_dir_all(&out)?;
    let cfg = EngineConfig::default();
    let open = |p: &std::path::Path| open_raster(p, &OpenOptions::default());

    let dem = open(args[1].as_ref())?;
    fill::run(
        dem.as_ref(),
        &fill::FillOptions::default(),
        &Target::new(out.join("filled.tif")),
        &cfg,
    )?;
    let filled = open(&out.join("filled.tif"))?;
    flow::run(
        filled.as_ref(),
        &flow::FlowOptions::default(),
        &Target::new(out.join("d8.tif")),
        &cfg,
    )?;
    let d8 = open(&out.join("d8.tif"))?;
    accumulate::run(
        d8.as_ref(),
        &accumulate::AccumulateOptions::default(),
        &Target::new(out.join("acc.tif")),
        &cfg,
    )?;
    slope::run(
        dem.as_ref(),
        &slope::SlopeOptions::default(),
        &Target::new(out.join("slope.tif")),
        &cfg,
    )?;
    let opts = peaks::PeaksOptions {
        min_prominence: 30.0,
        ..Default::default()
    };
    let found = peaks::run(dem.as_ref(), &out.join("peaks"), &opts, &cfg)?;
    println!(
        "{} peaks of at least 30 m prominence; results in {}",
        found.peaks,
        out.display()
    );
    Ok(())
}
