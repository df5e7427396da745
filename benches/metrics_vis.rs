//! Criterion benches for horizons, visibility and solar metrics on one
//! 512x512 tile of fBm terrain (single-threaded kernels, no I/O): the exact
//! ray horizon against the line-sweep horizon at growing radii (the rays'
//! cost grows with r, the sweep's with log r), the visibility index, the
//! solar sums and the heat index; and the R3 point viewshed at two radii
//! (O(r³); rayon over rows).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use orogen::metrics::horizon::{horizon_with, HorizonMethod, HorizonOut};
use orogen::metrics::visibility::{viewshed, ViewshedOptions};
use orogen::raster::{read_view, read_window, Grid, Window};

mod metrics_tile;
use metrics_tile::{bench_passes, fbm_tiles, N};

fn bench(c: &mut Criterion) {
    let (src, layout) = fbm_tiles();
    let mut g = c.benchmark_group("vis_512x512");
    g.sample_size(10);
    g.throughput(Throughput::Elements((N * N) as u64));
    for r in [10usize, 50, 200] {
        // Tile 4 is the centre tile, so its halo is real terrain.
        let view = read_view::<f32>(&src, &layout, 4, r).unwrap();
        for (name, method) in [
            ("rays", HorizonMethod::Rays),
            ("sweep", HorizonMethod::Sweep),
        ] {
            let mut pos = Grid::new(N, N, 0f32);
            let mut neg = Grid::new(N, N, 0f32);
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
    let specs = [
        "visibility_index:radius=10c",
        "visibility_index:radius=50c",
        "accessibility:radius=50c:directions=16",
        "solar_direct:lat=46:hour=10:radius=50c",
        "solar_global:lat=46:radius=50c",
        "heat_index",
    ];
    bench_passes(&mut g, &src, &layout, &specs);
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
