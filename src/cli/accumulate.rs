//! `orogen accumulate`: D8, D-infinity or MFD flow accumulation (`ops::accumulate`).

use crate::{engine, open, target, wrote, In, Out, Run};
use anyhow::Result;
use clap::Args;
use orogen::ops::accumulate::{self, AccumulateOptions};
use std::path::PathBuf;

/// Accumulate flow over the input into the output.
pub fn run(a: AccumulateArgs) -> Result<()> {
    let opts = AccumulateOptions {
        method: a.method.parse()?,
        exponent: a.exponent,
        weights: a.weights.clone(),
        units: a.units.parse()?,
    };
    let src = open(&a.input)?;
    let t = target(&a.out, &a.run)?;
    let outcome = accumulate::run(src.as_ref(), &opts, &t, &engine(&a.run)?)?;
    if !a.run.quiet && outcome.rounds > 0 {
        eprintln!(
            "accumulate: {} rounds over tiles to the exact fixed point",
            outcome.rounds
        );
    }
    wrote(&a.out.output);
    Ok(())
}

/// Arguments of `orogen accumulate`.
#[derive(Args)]
#[command(
    after_help = "Examples:\n  orogen accumulate d8.tif -o acc.tif\n  orogen accumulate d8.tif --weights rain.tif -o acc.tif\n  orogen accumulate d8.tif --units km2 -o area_km2.tif\n  orogen accumulate filled.tif --method dinf -o acc_dinf.tif\n  orogen accumulate filled.tif --method holmgren --exponent 4 -o acc_mfd.tif\nMethods: d8 (input: D8 directions), dinf (Tarboton 1997), quinn (Quinn et al. 1991),\nholmgren (Holmgren 1994, --exponent), freeman (Freeman 1991): input a filled DEM.\nOn lat/lon grids every router uses true distances per row (WGS 84) and --units\nm2/km2/sca true cell areas per row."
)]
pub struct AccumulateArgs {
    /// D8 directions from `orogen flow` (method d8), or a filled DEM (other methods).
    #[command(flatten)]
    pub input: In,
    /// Routing: d8, dinf, quinn, holmgren, freeman.
    #[arg(long, default_value = "d8")]
    pub method: String,
    /// Holmgren's exponent.
    #[arg(long, default_value_t = 4.0)]
    pub exponent: f64,
    /// Weights raster (same size): accumulate its values instead of cells.
    #[arg(long)]
    pub weights: Option<PathBuf>,
    /// Units: cells (counts), m2 or km2 (true cell areas: per row on
    /// geographic grids, on the WGS 84 ellipsoid), or sca (specific
    /// catchment area, m² per m of contour width √(cell area)); with
    /// --weights, area × weight.
    #[arg(long, default_value = "cells")]
    pub units: String,
    #[command(flatten)]
    pub out: Out,
    #[command(flatten)]
    pub run: Run,
}
