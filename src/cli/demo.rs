//! `orogen demo`: a seeded terrain and its analysis (`ops::demo`).

use crate::{engine, Run};
use anyhow::Result;
use clap::Args;
use orogen::ops::demo::{self, DemoOptions};
use std::path::PathBuf;

/// Run the demo and list the files it wrote.
pub fn run(a: DemoArgs) -> Result<()> {
    let opts = DemoOptions {
        size: a.size,
        seed: a.seed,
    };
    let files = demo::run(&a.output, &opts, &engine(&a.run)?)?;
    print!("{}", demo::listing(&a.output, &opts, &files));
    Ok(())
}

/// Arguments of `orogen demo`.
#[derive(Args)]
#[command(after_help = "Example:\n  orogen demo\n  orogen demo --size 4096 --seed 7 -o /tmp/demo")]
pub struct DemoArgs {
    /// Output folder.
    #[arg(short, long, default_value = "orogen-demo")]
    pub output: PathBuf,
    /// Size in cells (square).
    #[arg(long, default_value_t = 1024)]
    pub size: usize,
    /// Random seed.
    #[arg(long, default_value_t = 42)]
    pub seed: u64,
    #[command(flatten)]
    pub run: Run,
}
