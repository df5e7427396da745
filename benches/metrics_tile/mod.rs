//! The fixture of the metric benches: the centre tile of a 3x3-tile raster
//! of fBm terrain (so that its halo is real terrain), and the bench of one
//! metric pass over it (single-threaded kernel cost, no I/O).

use criterion::measurement::WallTime;
use criterion::BenchmarkGroup;
use orogen::exec::LocalStep;
use orogen::metrics::{parse_specs, MultiMetric};
use orogen::raster::{read_view, Grid, RasterSource, TileLayout};
use orogen::synth::FbmSource;

/// Side of the benched tile (cells).
pub const N: usize = 512;

/// The raster of 3x3 tiles of `N` cells and its layout (30 m cells).
pub fn fbm_tiles() -> (FbmSource, TileLayout) {
    let src = FbmSource::new(Default::default(), 3 * N, 3 * N, 30.0).unwrap();
    (src, TileLayout::new(3 * N, 3 * N, N))
}

/// One bench per entry of `specs`: one pass of those metrics over the
/// centre tile (tile 4) with the halo they need.
pub fn bench_passes(
    g: &mut BenchmarkGroup<'_, WallTime>,
    src: &FbmSource,
    layout: &TileLayout,
    specs: &[&str],
) {
    for &specs in specs {
        let specs_v = parse_specs(specs).unwrap();
        let step = MultiMetric::new(&specs_v, src.info()).unwrap();
        let view = read_view::<f32>(src, layout, 4, step.halo()).unwrap();
        let views = [view];
        let mut out: Vec<Grid<f32>> = specs_v.iter().map(|_| Grid::new(N, N, 0f32)).collect();
        g.bench_function(specs, |b| b.iter(|| step.run(&views, &mut out).unwrap()));
    }
}
