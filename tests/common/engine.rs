//! The engine of the global-step tests and a tile summary they share.

use orogen::exec::{EngineConfig, LocalEngine};
use orogen::raster::TileView;

/// A local engine on `threads` threads with a 4 MiB budget, no progress bar.
pub fn engine(threads: usize) -> LocalEngine {
    LocalEngine::new(EngineConfig {
        threads,
        memory_budget: 1 << 22,
        progress: false,
        observer: None,
        engine: Default::default(),
    })
}

/// The smallest valid value of the first input's view (core and halo), or
/// None if all are nodata.
pub fn tile_min(inputs: &[TileView<f32>]) -> Option<f32> {
    inputs[0]
        .grid
        .data()
        .iter()
        .copied()
        .filter(|v| !v.is_nan())
        .reduce(f32::min)
}
