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
    /// Seeded, tileable noise terrain: fbm, ridged, billow, simplex, warped,
    /// diamond-square or spectral (--kind).
    #[command(
        after_help = "Examples:\n  orogen synth noise --size 4096x4096 --seed 7 -o noise.tif\n  orogen synth noise --kind warped --size 4096 --warp 120 -o warped.tif\n  orogen synth noise --kind spectral --beta 3.2 --wavelength 8192 --size 8192 -o s.tif\n  orogen synth noise --size 100000x100000 --cell 30 -o big.tiles --zstd"
    )]
    Noise(super::synth_noise::NoiseArgs),
    /// Example-based synthesis: patches of a real DEM arranged to follow a guide, with pit removal.
    #[command(
        after_help = "Examples:\n  orogen synth optimise --source alps.tif --guide sketch.tif --size 1000x1000 -o out.tif\n  orogen synth optimise --source src.tif --guide coarse.tif --pit fill --previews levels/ --stats -o out.tif"
    )]
    Optimise(super::synth_optimise::OptimiseArgs),
    /// River-network terrain (Génevaux et al. 2013): river trees grown upstream from the sea, every cell drains.
    #[command(
        after_help = "Examples:\n  orogen synth rivers --size 2048 --seed 3 -o rivers.tif --preview rivers.png\n  orogen synth rivers --size 1024 --coast configs/tectonic-map.geojson --cell 40 --network net.geojson -o r.tif"
    )]
    Rivers(super::synth_rivers::RiversArgs),
    /// Tectonic folds from a GeoJSON map of coastlines, rivers and peaks (before erosion).
    #[command(
        after_help = "Examples:\n  orogen synth tectonic --map configs/tectonic-map.geojson -o folds.tif --preview folds.png\n  orogen synth tectonic --map configs/tectonic-map.geojson --intermediates inter/ --preview p.png -o t.tif\nThe output is the terrain before hydraulic erosion, which is a separate step."
    )]
    Tectonic(super::synth_tectonic::TectonicArgs),
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
        SynthCmd::Optimise(a) => super::synth_optimise::run(a),
        SynthCmd::Rivers(a) => super::synth_rivers::run(a),
        SynthCmd::Tectonic(a) => super::synth_tectonic::run(a),
        SynthCmd::Profile(a) => super::synth_oro::run_profile(a),
        SynthCmd::DivideTree(a) => super::synth_oro::run_divide_tree(a),
        SynthCmd::FromTree(a) => super::synth_oro::run_from_tree(a),
        SynthCmd::Orometric(a) => super::synth_oro::run_orometric(a),
    }
}
