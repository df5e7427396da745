//! Timings of the local erosion models (one substep on a 256 x 256 fBm
//! terrain, whole grid in one patch) and of the halo-exchange driver (the
//! same run cut into 64-cell tiles, exchange every 8 substeps), so the cost
//! of the ghost zones shows as a ratio. Run: `cargo bench --bench erosion`.

use criterion::{criterion_group, criterion_main, Criterion};
use orogen::erosion::tiled::{run_to_grids, run_untiled, Backend};
use orogen::erosion::{
    CellSize, Diffusion, DiffusionParams, Hydraulic, HydraulicParams, Thermal, ThermalParams,
};
use orogen::exec::EngineConfig;
use orogen::raster::{read_window, GeoRef, MemRaster, RasterSource, Window};
use orogen::synth::{Fbm, FbmSource};

const N: usize = 256;
const STEPS: u64 = 16;

fn terrain() -> orogen::raster::Grid<f64> {
    let fbm = Fbm {
        wavelength: 96.0,
        ..Default::default()
    };
    let src = FbmSource::new(fbm, N, N, 30.0).expect("fbm source");
    read_window::<f64>(&src as &dyn RasterSource, Window::full(N, N)).expect("fbm terrain")
}

fn bench(c: &mut Criterion) {
    let dem = terrain();
    let cell = CellSize::square(30.0);
    let hyd = Hydraulic::new(HydraulicParams::default(), STEPS, cell).expect("params");
    let th = Thermal::new(ThermalParams::default(), STEPS, cell).expect("params");
    let df = Diffusion::new(DiffusionParams::default(), STEPS, cell).expect("params");
    let mut g = c.benchmark_group("erosion_256x256_16_substeps");
    g.sample_size(10);
    g.bench_function("hydraulic_untiled", |b| b.iter(|| run_untiled(&hyd, &dem)));
    g.bench_function("thermal_untiled", |b| b.iter(|| run_untiled(&th, &dem)));
    g.bench_function("diffusion_untiled", |b| b.iter(|| run_untiled(&df, &dem)));
    let src = MemRaster::from_grid(dem.clone(), GeoRef::pixel());
    let cfg = EngineConfig {
        threads: 1,
        memory_budget: 1 << 30,
        progress: false,
        observer: None,
        engine: Default::default(),
    };
    g.bench_function("hydraulic_tiled_64_exchange_8_1thread", |b| {
        b.iter(|| run_to_grids(&hyd, &src, 64, 8, &Backend::Memory, &cfg).expect("run"))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
