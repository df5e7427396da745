//! Criterion benches of the noise family: one 512x512 window per kind
//! (single thread, generation only: the f64 field, no output).
//! Run: `cargo bench --bench noise`.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use orogen::raster::Window;
use orogen::synth::{Noise, NoiseKind};

fn bench(c: &mut Criterion) {
    let n = 512;
    let win = Window::new(10_000, 20_000, n, n);
    let mut out = vec![0.0; n * n];
    let mut g = c.benchmark_group("noise_512x512");
    g.throughput(Throughput::Elements((n * n) as u64));
    g.sample_size(10);
    for kind in NoiseKind::ALL {
        let p = Noise {
            kind,
            octaves: 8,
            wavelength: 512.0,
            ..Default::default()
        };
        g.bench_function(kind.name(), |b| b.iter(|| p.field(win, &mut out)));
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
