//! Terrain descriptors: pointwise metrics computed per tile with a halo.

pub mod horizon;
pub mod landform;
pub mod multi;
pub mod neighbourhood;
pub mod quadric;
pub mod registry;
pub mod terrain;
pub mod windowed;
// visibility & solar
pub mod solar;
pub mod visibility;

pub use multi::{compute, output_paths, MultiMetric, METRIC_NODATA};
pub use neighbourhood::EdgeMode;
pub use registry::{list, parse_specs, MetricKind, MetricSpec};
pub use terrain::{Aspect, Hillshade, Slope, SlopeUnits};
// more descriptors
pub mod asymmetry;
pub mod directional;
pub mod fractional;
pub mod fuzzy;
pub mod relief_shape;
pub mod shary;
pub mod table;
// last descriptors
pub mod dominance;
// descr4
pub mod peak_dw;
pub mod xu;
