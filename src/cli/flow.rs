//! `orogen flow`: D8 or Rho8 flow directions, exact across tiles (`ops::flow`).

use crate::{engine, open, target, wrote, In, Out, Run};
use anyhow::Result;
use clap::Args;
use orogen::ops::flow::{self, FlowOptions};

/// Flow directions of the input into the output.
pub fn run(a: FlowArgs) -> Result<()> {
    let src = open(&a.input)?;
    let t = target(&a.out, &a.run)?;
    let cfg = engine(&a.run)?;
    let opts = FlowOptions {
        method: a.method.parse()?,
        seed: a.seed,
        sinks: a.sinks.clone(),
    };
    flow::run(src.as_ref(), &opts, &t, &cfg)?;
    wrote(&a.out.output);
    Ok(())
}

/// Arguments of `orogen flow`.
#[derive(Args)]
#[command(
    after_help = "Example:\n  orogen fill dem.tif -o filled.tif && orogen flow filled.tif -o d8.tif\n  orogen flow filled.tif --method rho8 --seed 7 -o rho8.tif\n  orogen fill dem.tif --sinks dead_sea.csv -o filled.tif && orogen flow filled.tif --sinks dead_sea.csv -o d8.tif\nFlats (sea, lakes) are drained exactly across tiles (Barnes, Lehman & Mulla 2014)."
)]
pub struct FlowArgs {
    #[command(flatten)]
    pub input: In,
    /// Routing: d8 (steepest descent) or rho8 (Fairfield & Leymarie 1991, stochastic, seeded).
    #[arg(long, default_value = "d8")]
    pub method: String,
    /// Rho8 seed (same seed, same directions, whatever the tiling).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Declared sinks, as given to `orogen fill --sinks`: their cells get
    /// no flow (0) and the flats around them drain into them (D8 only).
    #[arg(long, value_name = "FILE")]
    pub sinks: Option<std::path::PathBuf>,
    #[command(flatten)]
    pub out: Out,
    #[command(flatten)]
    pub run: Run,
}
