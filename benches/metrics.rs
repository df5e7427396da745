//! Criterion benches for the descriptor families on one 512x512 tile of fBm
//! terrain (single-threaded kernel cost, no I/O). The windowed statistics
//! (SAT) and relief (van Herk/Gil-Werman) are run at two radii to show that
//! their cost per cell does not grow with the radius; the horizon scan's does
//! (O(r) per direction). The disk descriptors (fractional Laplacian, ORS,
//! jut, rut) cost O(r²) per cell; average slope and hillslope asymmetry
//! use summed-area tables (radius-independent).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};

mod metrics_tile;
use metrics_tile::{bench_passes, fbm_tiles, N};

fn bench(c: &mut Criterion) {
    let (src, layout) = fbm_tiles();
    let mut g = c.benchmark_group("metrics_512x512");
    g.sample_size(10);
    g.throughput(Throughput::Elements((N * N) as u64));
    let specs = [
        "slope",
        "mean_curvature,profile_curvature,plan_curvature,gaussian_curvature",
        "tri,rugosity",
        "mean_curvature:radius=5c,profile_curvature:radius=5c",
        "tpi:radius=5c",
        "tpi:radius=100c",
        "mean:radius=5c,stdev:radius=5c,tpi:radius=5c,ntpi:radius=5c",
        "tpi:radius=5c:shape=disk",
        "tpi:radius=50c:shape=disk",
        "percentile:radius=5c",
        "tophat_white:radius=5c",
        "tophat_white:radius=100c",
        "relief:radius=5c",
        "relief:radius=100c",
        "roughness:radius=5c",
        "roughness:radius=100c",
        "openness:radius=10c,sky_view:radius=10c",
        "openness:radius=50c,sky_view:radius=50c",
        // more descriptors: one group per family
        "directional_slope:azimuth=30",
        "average_slope:radius=5c",
        "average_slope:radius=100c",
        "hillslope_asymmetry:radius=5c",
        "hillslope_asymmetry:radius=100c",
        "fractional_laplacian:radius=5c",
        "fractional_laplacian:radius=20c",
        "shary_landform",
        "shary_landform:radius=5c",
        "ors:radius=10c",
        "jut:radius=10c,rut:radius=10c",
        "fuzzy_landform:class=ridge:scales=1/2/4",
        // last descriptors (disk, O(r²) per cell)
        "dominance:radius=10c,submission:radius=10c",
        "peakedness:radius=10c",
        "domination:radius=10c",
        // descr3: exact sliding medians, O(r log n) per cell
        "asymmetry_index:radius=5c",
        "asymmetry_index:radius=50c",
        // descr4: Xu's forms on a sphere (plumb-line heights)
        "jut:radius=10c:planet=6371,rut:radius=10c:planet=6371",
        "dominance:radius=10c:planet=6371,submission:radius=10c:planet=6371",
    ];
    bench_passes(&mut g, &src, &layout, &specs);
    g.finish();

    // Deng & Wilson multi-scale peakedness: whole-raster statistics, so it runs
    // as two global passes over a 3x3-tile raster (engine on one thread).
    let mut g = c.benchmark_group("peakedness_dw_1536x1536");
    g.sample_size(10);
    g.throughput(Throughput::Elements((9 * N * N) as u64));
    let cfg = orogen::exec::EngineConfig {
        threads: 1,
        ..Default::default()
    };
    g.bench_function("peakedness_dw+peak_prototypicality", |b| {
        b.iter(|| {
            orogen::metrics::peak_dw::run_to_memory(&src, 0.2, layout, &cfg, true, true).unwrap()
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
