//! `orogen breach`: depression breaching (flood-order, selective hybrid,
//! least-cost), see `orogen::ops::breach`.

use anyhow::Result;
use clap::{Args, ValueEnum};
use orogen::ops::breach::{self, BreachOptions};

#[derive(Copy, Clone, PartialEq, Eq, ValueEnum)]
pub enum Method {
    /// Flood-order breaching: every depression is carved (in memory).
    Breach,
    /// Lindsay (2016) selective breaching: carve within --max-depth/--max-length, else fill (in memory).
    Hybrid,
    /// Least-cost breaching within --dist cells of each pit (across tiles).
    LeastCost,
}

#[derive(Args)]
#[command(
    after_help = "Examples:\n  orogen breach dem.tif -o breached.tif\n  orogen breach dem.tif --method hybrid --max-depth 2 --max-length 50 -o hybrid.tif\n  orogen breach dem.tiles --method least-cost --dist 100 --fill-remaining -o breached.tiles\nbreach and hybrid run in memory (about 32 bytes per cell; see --memory); least-cost runs\nacross tiles and is exact for any tile size (halo 2*dist+1). Nodata and the edge are outlets."
)]
pub struct BreachArgs {
    #[command(flatten)]
    pub input: crate::In,
    /// Breaching method.
    #[arg(long, value_enum, default_value_t = Method::Breach)]
    pub method: Method,
    /// Hybrid: deepest cut allowed below the input elevation (DEM units); deeper depressions are filled.
    #[arg(long)]
    pub max_depth: Option<f32>,
    /// Hybrid: most cells one carve may lower; longer channels are filled instead.
    #[arg(long)]
    pub max_length: Option<usize>,
    /// Least-cost: search distance around each pit, in cells (halo = 2·dist+1 across tiles).
    #[arg(long, default_value_t = 50)]
    pub dist: usize,
    /// Least-cost: fill the pits no channel within --dist could drain.
    #[arg(long)]
    pub fill_remaining: bool,
    /// Carve strictly descending channels (one f32 step per cell) and epsilon-fill.
    #[arg(long)]
    pub epsilon: bool,
    #[command(flatten)]
    pub out: crate::Out,
    #[command(flatten)]
    pub run: crate::Run,
}

/// Breach the input's depressions into the output (`ops::breach`).
pub fn run(a: BreachArgs) -> Result<()> {
    let opts = BreachOptions {
        method: match a.method {
            Method::Breach => breach::Method::Breach,
            Method::Hybrid => breach::Method::Hybrid,
            Method::LeastCost => breach::Method::LeastCost,
        },
        max_depth: a.max_depth,
        max_length: a.max_length,
        dist: a.dist,
        fill_remaining: a.fill_remaining,
        epsilon: a.epsilon,
    };
    // Checked before the input is opened (no georeference warning first).
    opts.resolve()?;
    let cfg = crate::engine(&a.run)?;
    let src = crate::open(&a.input)?;
    let t = crate::target(&a.out, &a.run)?;
    breach::run(src.as_ref(), &opts, &t, &cfg)?;
    crate::wrote(&a.out.output);
    Ok(())
}
