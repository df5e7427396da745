//! The stream-power flags of `orogen erode --model stream-power` (see
//! `orogen::ops::erode::stream_power`): [`StreamPowerArgs`] holds every
//! model flag and no input/output option, so it is `#[command(flatten)]`ed
//! into `orogen erode` as it is.

use clap::{Args, ValueEnum};
use orogen::ops::erode::{BaseLevelHeight, DepressionRouting, ErodeOptions};
use std::path::PathBuf;

/// Depression routing choices.
#[derive(Copy, Clone, PartialEq, Eq, ValueEnum)]
pub enum DepressionsArg {
    /// Priority-flood filling: lakes drain through their spill point.
    Fill,
    /// Cordonnier, Bovy & Braun (2019) basin graph (minimum spanning tree of passes).
    BasinGraph,
    /// No routing: pits are local base levels.
    None,
}

/// Base-level height choices.
#[derive(Copy, Clone, PartialEq, Eq, ValueEnum)]
pub enum BaseHeightArg {
    /// Keep the input elevation of the base-level cells.
    Initial,
    /// Set base-level cells to 0.
    Zero,
}

/// The stream-power model options (no input or output: flatten it anywhere).
#[derive(Args, Clone)]
pub struct StreamPowerArgs {
    /// Erodibility K (for n = 1: m^(1-2m)/yr) [default 1e-5].
    #[arg(long = "k")]
    pub k: Option<f64>,
    /// Drainage-area exponent m [default 0.4].
    #[arg(long = "m")]
    pub m: Option<f64>,
    /// Slope exponent n (n != 1 is solved by Newton iteration) [default 1].
    #[arg(long = "n")]
    pub n: Option<f64>,
    /// Uniform uplift rate in m/yr [default 0].
    #[arg(long, conflicts_with = "uplift_map")]
    pub uplift: Option<f64>,
    /// Uplift rate map (m/yr), a raster of the DEM's size.
    #[arg(long)]
    pub uplift_map: Option<PathBuf>,
    /// Depression routing [default fill].
    #[arg(long, value_enum)]
    pub depressions: Option<DepressionsArg>,
    /// Base-level borders: all, none, or a list of north,south,east,west
    /// [default all]. Cells next to nodata are always base levels.
    #[arg(long)]
    pub base_level: Option<String>,
    /// Height of the base-level cells [default initial].
    #[arg(long, value_enum)]
    pub base_height: Option<BaseHeightArg>,
    /// Force the tiled (out-of-core) solve, which is otherwise chosen when the
    /// DEM does not fit in --memory; same result bit for bit.
    #[arg(long)]
    pub tiled: bool,
    /// Fixed points to keep (constrained erosion): CSV with col,row columns
    /// (orogen's peaks.csv; its saddle_x/saddle_y columns are kept too) or x,y
    /// map coordinates, or GeoJSON (Point, MultiPoint, LineString vertices) in
    /// the DEM's CRS unless the file has a "crs" member (CRS84/EPSG:4326:
    /// lon/lat; orogen's --geojson-crs native outputs read back as they are).
    #[arg(long)]
    pub fixed_points: Option<PathBuf>,
    /// Radius of the compensating uplift around each fixed point, in metres.
    #[arg(long)]
    pub radius: Option<f64>,
    /// Constrained erosion: steps between two compensations.
    #[arg(long, default_value_t = 10)]
    pub compensate_every: usize,
    /// Coarse-to-fine cell sizes in metres, e.g. 100,50,30.
    #[arg(long, value_delimiter = ',')]
    pub levels: Vec<f64>,
    /// Cell size in metres (default: from the georeference).
    #[arg(long)]
    pub cell: Option<f64>,
}

impl StreamPowerArgs {
    /// Copy these flags into the operation's options.
    pub fn apply(&self, o: &mut ErodeOptions) {
        o.k = self.k;
        o.m = self.m;
        o.n = self.n;
        o.uplift = self.uplift;
        o.uplift_map = self.uplift_map.clone();
        o.depressions = self.depressions.map(|d| match d {
            DepressionsArg::Fill => DepressionRouting::Fill,
            DepressionsArg::BasinGraph => DepressionRouting::BasinGraph,
            DepressionsArg::None => DepressionRouting::None,
        });
        o.base_level = self.base_level.clone();
        o.base_height = self.base_height.map(|b| match b {
            BaseHeightArg::Initial => BaseLevelHeight::Initial,
            BaseHeightArg::Zero => BaseLevelHeight::Zero,
        });
        o.tiled = self.tiled;
        o.fixed_points = self.fixed_points.clone();
        o.radius = self.radius;
        o.compensate_every = self.compensate_every;
        o.levels = self.levels.clone();
        o.cell = self.cell;
    }
}
