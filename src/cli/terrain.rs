//! `orogen slope`, `orogen aspect` and `orogen hillshade` (Horn 1981, as
//! gdaldem): `ops::slope`, `ops::aspect`, `ops::hillshade`.

use crate::cli::args::{run_one, InOut};
use anyhow::Result;
use clap::{Args, ValueEnum};
use orogen::metrics::SlopeUnits;
use orogen::ops::{aspect, hillshade, slope};

/// `--units` of `orogen slope`.
#[derive(Copy, Clone, ValueEnum)]
pub enum UnitsArg {
    Degrees,
    Percent,
}

/// Slope of the input.
pub fn run_slope(a: SlopeArgs) -> Result<()> {
    let opts = slope::SlopeOptions {
        units: match a.units {
            UnitsArg::Degrees => SlopeUnits::Degrees,
            UnitsArg::Percent => SlopeUnits::Percent,
        },
        z_factor: a.z_factor,
        compute_edges: a.compute_edges,
    };
    run_one(&a.io, &opts, slope::run)
}

/// Aspect of the input.
pub fn run_aspect(a: AspectArgs) -> Result<()> {
    let opts = aspect::AspectOptions {
        zero_for_flat: a.zero_for_flat,
        compute_edges: a.compute_edges,
    };
    run_one(&a.io, &opts, aspect::run)
}

/// Hillshade of the input.
pub fn run_hillshade(a: HillshadeArgs) -> Result<()> {
    let opts = hillshade::HillshadeOptions {
        azimuth: a.azimuth,
        altitude: a.altitude,
        z_factor: a.z_factor,
        compute_edges: a.compute_edges,
    };
    // Checked before the input is opened (no georeference warning first).
    opts.validate()?;
    run_one(&a.io, &opts, hillshade::run)
}

/// Arguments of `orogen slope`.
#[derive(Args)]
#[command(
    after_help = "Example:\n  orogen slope dem.tif -o slope.tif\n  orogen slope dem.tiles -o slope.tiles --units percent"
)]
pub struct SlopeArgs {
    #[arg(long, value_enum, default_value_t = UnitsArg::Degrees)]
    pub units: UnitsArg,
    /// Vertical exaggeration.
    #[arg(long, default_value_t = 1.0)]
    pub z_factor: f64,
    /// Compute edge cells with missing neighbours (gdaldem -compute_edges).
    #[arg(long)]
    pub compute_edges: bool,
    #[command(flatten)]
    pub(crate) io: InOut,
}

/// Arguments of `orogen aspect`.
#[derive(Args)]
#[command(after_help = "Example:\n  orogen aspect dem.tif -o aspect.tif --zero-for-flat")]
pub struct AspectArgs {
    /// Flat cells get 0 instead of nodata.
    #[arg(long)]
    pub zero_for_flat: bool,
    #[arg(long)]
    pub compute_edges: bool,
    #[command(flatten)]
    pub(crate) io: InOut,
}

/// Arguments of `orogen hillshade`.
#[derive(Args)]
#[command(
    after_help = "Example:\n  orogen hillshade dem.tif -o shade.tif --azimuth 315 --altitude 45"
)]
pub struct HillshadeArgs {
    #[arg(long, default_value_t = 315.0)]
    pub azimuth: f64,
    #[arg(long, default_value_t = 45.0)]
    pub altitude: f64,
    #[arg(long, default_value_t = 1.0)]
    pub z_factor: f64,
    #[arg(long)]
    pub compute_edges: bool,
    #[command(flatten)]
    pub(crate) io: InOut,
}
