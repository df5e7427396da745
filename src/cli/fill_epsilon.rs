//! `orogen fill-epsilon`: depression filling with a strictly draining
//! epsilon surface, exact across tiles (`orogen::ops::fill_epsilon`).

use crate::{engine, open, target, wrote, In, Out, Run};
use anyhow::Result;
use clap::Args;
use orogen::ops::fill_epsilon::{self, FillEpsilonOptions};

/// Arguments of `orogen fill-epsilon`.
#[derive(Args)]
#[command(
    after_help = "Example:\n  orogen fill-epsilon dem.tif -o eps.tif\nErrors (instead of raising terrain) where a flat is too wide for f32 steps;\nthen use fill + flow."
)]
pub struct FillEpsilonArgs {
    #[command(flatten)]
    pub input: In,
    #[command(flatten)]
    pub out: Out,
    #[command(flatten)]
    pub run: Run,
}

/// Fill the input to an epsilon surface into the output (`ops::fill_epsilon`).
pub fn run(a: FillEpsilonArgs) -> Result<()> {
    let src = open(&a.input)?;
    let cfg = engine(&a.run)?;
    let t = target(&a.out, &a.run)?;
    fill_epsilon::run(src.as_ref(), &FillEpsilonOptions::default(), &t, &cfg)?;
    wrote(&a.out.output);
    Ok(())
}
