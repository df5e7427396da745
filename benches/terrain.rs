//! Criterion benches for the 3x3 terrain metrics on one 1024x1024 tile
//! (single-threaded kernel cost, no I/O).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use orogen::exec::LocalStep;
use orogen::metrics::{Aspect, Hillshade, Slope};
use orogen::raster::{read_view, Grid, TileLayout};
use orogen::synth::FbmSource;

fn bench(c: &mut Criterion) {
    let n = 1024;
    let src = FbmSource::new(Default::default(), n, n, 30.0).unwrap();
    let layout = TileLayout::new(n, n, n);
    let view = read_view::<f32>(&src, &layout, 0, 1).unwrap();
    let views = [view];
    let mut g = c.benchmark_group("terrain_1024x1024");
    g.throughput(Throughput::Elements((n * n) as u64));
    let mut out = vec![Grid::new(n, n, 0f32)];
    g.bench_function("slope", |b| {
        b.iter(|| Slope::default().run(&views, &mut out).unwrap())
    });
    g.bench_function("aspect", |b| {
        b.iter(|| Aspect::default().run(&views, &mut out).unwrap())
    });
    let mut out8 = vec![Grid::new(n, n, 0u8)];
    g.bench_function("hillshade", |b| {
        b.iter(|| Hillshade::default().run(&views, &mut out8).unwrap())
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
