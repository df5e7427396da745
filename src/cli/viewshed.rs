//! `orogen viewshed`: the R3 viewshed of one observer (u8: 1 visible, 0 not,
//! 255 beyond the radius or nodata), the cumulative viewshed of several
//! (u16 count of observers seeing each cell), or Fisher's fuzzy viewshed
//! (f32 sum of distance-decay memberships); see `orogen::metrics::visibility`.
//!
//! See `orogen::ops::viewshed`.

use anyhow::Result;
use clap::Args;
use orogen::ops::viewshed::{self, ViewshedOptions};
use std::path::PathBuf;

/// Arguments of `orogen viewshed`.
#[derive(Args)]
#[command(
    after_help = "Examples:\n  orogen viewshed dem.tif --at 352000,4590000 --observer-height 1.7 --radius 10km -o vis.tif\n  orogen viewshed srtm.tif --at=-105.2,39.7 --curvature -o vis.tif\n  orogen viewshed dem.tif --points towers.csv --radius 5km -o count.tif\n  orogen viewshed dem.tif --at 352000,4590000 --fuzzy 1000,2000 -o fuzzy.tif\nOne observer: u8, 1 visible, 0 hidden, 255 beyond the radius or nodata. Several: u16 count\nof observers seeing each cell. --fuzzy: f32 sum of memberships. The output covers the\nobservers' radius, clipped to the DEM. Coordinates are in the DEM's CRS (--pixel: col,row)."
)]
pub struct ViewshedArgs {
    #[command(flatten)]
    input: crate::In,
    /// Observer position X,Y in the DEM's coordinates (lon,lat on geographic DEMs);
    /// repeat for a cumulative viewshed.
    #[arg(long = "at", value_name = "X,Y", allow_hyphen_values = true)]
    at: Vec<String>,
    /// Observers from a CSV file (header with x,y or lon,lat columns) or a
    /// GeoJSON file of Point features, in the DEM's coordinates (a GeoJSON
    /// "crs" member is honoured: CRS84/EPSG:4326 means lon/lat).
    #[arg(long)]
    points: Option<PathBuf>,
    /// Read --at as COL,ROW cell indices instead of coordinates.
    #[arg(long)]
    pixel: bool,
    /// Eye height above the ground (m).
    #[arg(long, default_value_t = 1.7)]
    observer_height: f64,
    /// Target height above the ground (m).
    #[arg(long, default_value_t = 0.0)]
    target_height: f64,
    /// Largest distance from the observer: 500m, 10km or cells (25c).
    #[arg(long, default_value = "10km")]
    radius: String,
    /// Apply earth curvature and refraction.
    #[arg(long)]
    curvature: bool,
    /// Refraction coefficient with --curvature.
    #[arg(long, default_value_t = 0.13)]
    refraction: f64,
    /// Fuzzy viewshed (Fisher 1994): B1,B2 in metres; membership 1 up to B1,
    /// then 1/(1+((d-B1)/B2)^2).
    #[arg(long, value_name = "B1,B2")]
    fuzzy: Option<String>,
    #[command(flatten)]
    out: crate::Out,
    #[command(flatten)]
    run: crate::Run,
}

/// The viewshed of the observers into the output (`ops::viewshed`).
pub fn run(a: ViewshedArgs) -> Result<()> {
    let src = crate::open(&a.input)?;
    let cfg = crate::engine(&a.run)?;
    let mut at = Vec::with_capacity(a.at.len());
    for s in &a.at {
        at.push(viewshed::parse_pair(s, "--at")?);
    }
    let fuzzy = match &a.fuzzy {
        Some(s) => Some(viewshed::parse_pair(s, "--fuzzy")?),
        None => None,
    };
    let opts = ViewshedOptions {
        at,
        points: a.points.clone(),
        pixel: a.pixel,
        observer_height: a.observer_height,
        target_height: a.target_height,
        radius: a.radius.clone(),
        curvature: a.curvature,
        refraction: a.refraction,
        fuzzy,
    };
    let t = crate::target(&a.out, &a.run)?;
    viewshed::run(src.as_ref(), &opts, &t, &cfg)?;
    crate::wrote(&a.out.output);
    Ok(())
}
