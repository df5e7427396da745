//! Criterion benches for horizons, visibility and solar metrics on one
//! 512x512 tile of fBm terrain (single-threaded kernels, no I/O): the exact
//! ray horizon against the line-sweep horizon at growing radii (the rays'
//! cost grows with r, the sweep's with log r), the visibility index, the
//! solar sums and the heat index; and the R3 point viewshed at two radii
//! (O(r³); rayon over rows).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use orogen::exec::LocalStep;
use orogen::metrics::horizon::{horizon_with, HorizonMethod, HorizonOut};
use orogen::metrics::visibility::{viewshed, ViewshedOptions};
use orogen::metrics::{parse_specs, MultiMetric};
use orogen::raster::{read_view, read_window, Grid, RasterSource, TileLayout, Window};
use orogen::synth::FbmSource;

fn bench(c: &mut Criterion) {
    let n = 512;
    let src = FbmSource::new(Default::default(), 3 * n, 3 * n, 30.0).unwrap();
    let layout = TileLayout::new(3 * n, 3 * n, n);
    let mut g = c.benchmark_group("vis_512x512");
    g.sample_size(10);
    g.throughput(Throughput::Elements((n * n) as u64));
    for r in [10usize, 50, 200] {
        // Tile 4 is the centre tile, so its halo is real terrain.
        let view = read_view::<f32>(&src, &layout, 4, r).unwrap();
        for (name, method) in [
            ("rays", HorizonMethod::Rays),
            ("sweep", HorizonMethod::Sweep),
        ] {
            let mut pos = Grid::new(n, n, 0f32);
            let mut neg = Grid::new(n, n, 0f32);
            g.bench_function(format!("openness_pos_neg_8dir_r{r}c_{name}"), |b| {
                b.iter(|| {
                    horizon_with(
                        &view,
                        r,
                        r as f64 * 30.0,
                        8,
                        method,
                        HorizonOut {
                            positive: Some(&mut pos),
                            negative: Some(&mut neg),
                            sky_view: None,
                        },
                    )
                })
            });
        }
    }
    for specs in [
        "visibility_index:radius=10c",
        "visibility_index:radius=50c",
        "accessibility:radius=50c:directions=16",
        "solar_direct:lat=46:hour=10:radius=50c",
        "solar_global:lat=46:radius=50c",
        "heat_index",
    ] {
        let specs_v = parse_specs(specs).unwrap();
        let step = MultiMetric::new(&specs_v, src.info()).unwrap();
        let view = read_view::<f32>(&src, &layout, 4, step.halo()).unwrap();
        let views = [view];
        let mut out: Vec<Grid<f32>> = specs_v.iter().map(|_| Grid::new(n, n, 0f32)).collect();
        g.bench_function(specs, |b| b.iter(|| step.run(&views, &mut out).unwrap()));
    }
    g.finish();

    let mut g = c.benchmark_group("viewshed_r3");
    g.sample_size(10);
    for r in [100usize, 250] {
        let side = 2 * r + 1;
        let dem = read_window::<f32>(&src, Window::new(0, 0, side, side)).unwrap();
        let o = ViewshedOptions {
            radius_m: r as f64 * 30.0,
            observer_height: 2.0,
            ..Default::default()
        };
        g.throughput(Throughput::Elements((side * side) as u64));
        g.bench_function(format!("radius_{r}c"), |b| {
            b.iter(|| viewshed(&dem, (30.0, 30.0), (r, r), &o).unwrap())
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
