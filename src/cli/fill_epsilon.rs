//! `orogen fill-epsilon`: depression filling with a strictly draining
//! epsilon surface, exact across tiles (`orogen::ops::fill_epsilon`).

use crate::cli::args::{run_one, InOut};
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
    pub(crate) io: InOut,
}

/// Fill the input to an epsilon surface into the output (`ops::fill_epsilon`).
pub fn run(a: FillEpsilonArgs) -> Result<()> {
    let opts = FillEpsilonOptions::default();
    run_one(&a.io, &opts, fill_epsilon::run)
}
