//! Terrain descriptors: pointwise metrics computed per tile with a halo.
//!
//! Every metric implements [`Metric`] (its descriptor — name, parameters
//! with defaults and ranges, units, description, citation, output kind —
//! its halo, the shared per-tile products it reads, its checks and its
//! kernel) and is listed once in [`registry::METRICS`]. Specs
//! (`slope,tpi:radius=500m`) are parsed and bound to a raster in [`spec`];
//! [`MultiMetric`] computes any list of them in one tiled pass, sharing the
//! products of [`tile::Tile`].
//!
//! ## Adding a metric
//! 1. Add its identifier to [`MetricKind`].
//! 2. Write its kernel and a `Metric` implementation in the file of its
//!    subject (a new file, or the family file whose paper defines it), with
//!    a `pub static` holding its [`MetricDef`] (`metric_def!`): name,
//!    parameters (shared ones in [`param`]), units, description and
//!    citation; override `halo`, `needs` (shared quadric, summed-area table,
//!    normals), `scratch`, `bind` (checks needing the raster) as it needs.
//! 3. List the static in [`registry::METRICS`] where `orogen metric list`
//!    should print it.
//!
//! The registry's unit tests check that every metric is listed once, with a
//! unique name, a citation, parseable defaults and a halo that covers its
//! radius.

pub mod horizon;
pub mod neighbourhood;
pub mod param;
pub mod quadric;
pub mod registry;
pub mod spec;
pub mod terrain;
pub mod tile;
pub mod windowed;

pub mod multi;

// Metric families, one subject per file.
pub mod asymmetry;
pub mod curvature;
pub mod directional;
pub mod dominance;
pub mod fractional;
pub mod fuzzy;
pub mod gradient;
pub mod landform;
pub mod local_stats;
pub mod morphology;
pub mod openness;
pub mod peak_dw;
pub mod relief_shape;
pub mod roughness;
pub mod shary;
pub mod solar;
pub mod table;
pub mod visibility;
pub mod xu;

pub use multi::{compute, output_paths, MultiMetric, METRIC_NODATA};
pub use neighbourhood::EdgeMode;
pub use param::MAX_RADIUS_CELLS;
pub use registry::{list, Metric, MetricDef, MetricKind, OutputKind};
pub use spec::{parse_specs, MetricSpec};
pub use terrain::{Aspect, Hillshade, Slope, SlopeUnits};
