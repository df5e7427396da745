//! `orogen synth <method>`: terrain synthesis. Each method lives in its own
//! file `src/cli/synth_<method>.rs` (a clap `Args` struct and a `run`); this
//! file holds one `SynthCmd` variant and one match arm per method.

use anyhow::Result;
use clap::{Args, Subcommand};

/// Arguments of `orogen synth`.
#[derive(Args)]
pub struct SynthArgs {
    #[command(subcommand)]
    pub method: SynthCmd,
}

/// The synthesis methods.
#[derive(Subcommand)]
pub enum SynthCmd {
    /// Seeded, tileable procedural noise terrain (fBm with domain warping).
    #[command(
        after_help = "Examples:\n  orogen synth noise --size 4096x4096 --seed 7 -o noise.tif\n  orogen synth noise --size 100000x100000 --cell 30 -o big.tiles --zstd"
    )]
    Noise(super::synth_noise::NoiseArgs),
    /// Orometry profile of a real DEM (target distributions for synthesis), or edit one.
    #[command(
        after_help = "Examples:\n  orogen synth profile alps.tif --min-prominence 30 -o alps.json\n  orogen synth profile alps.json --scale-prominence 2 -o alps_x2.json"
    )]
    Profile(super::synth_oro::ProfileArgs),
    /// Divide-tree synthesis only: an editable JSON tree (and GeoJSON).
    #[command(
        after_help = "Example:\n  orogen synth divide-tree --profile alps.json --size 3000x3000 --cell 30 -o tree.json --geojson tree.geojson"
    )]
    DivideTree(super::synth_oro::DivideTreeArgs),
    /// Terrain from a (possibly edited) divide tree.
    #[command(
        after_help = "Example:\n  orogen synth from-tree tree.json -o terrain.tif --preview terrain.png"
    )]
    FromTree(super::synth_oro::FromTreeArgs),
    /// Orometric terrain synthesis: profile -> divide tree -> terrain.
    #[command(
        after_help = "Examples:\n  orogen synth orometric --profile configs/profiles/alps.json --size 3000x3000 --cell 30 -o alps_synth.tif\n  orogen synth orometric --profile alps.json --size 30000x30000 --cell 30 -o big.tiles --zstd"
    )]
    Orometric(super::synth_oro::OrometricArgs),
}

/// Dispatch to the chosen method.
pub fn run(args: SynthArgs) -> Result<()> {
    match args.method {
        SynthCmd::Noise(a) => super::synth_noise::run(a),
        SynthCmd::Profile(a) => super::synth_oro::run_profile(a),
        SynthCmd::DivideTree(a) => super::synth_oro::run_divide_tree(a),
        SynthCmd::FromTree(a) => super::synth_oro::run_from_tree(a),
        SynthCmd::Orometric(a) => super::synth_oro::run_orometric(a),
    }
}
