//! Shared builders of the metric tests: a SplitMix64 generator, an
//! in-memory source in a projected CRS and a runner of metric specs through
//! the local engine at a given tile size and thread count.

#![allow(dead_code)] // each test binary uses a subset

use orogen::exec::run_local_to_memory;
use orogen::exec::{EngineConfig, LocalEngine};
use orogen::metrics::{parse_specs, MultiMetric};
use orogen::raster::{Crs, DType, GeoRef, Grid, MemRaster, RasterSource, TileLayout};

/// SplitMix64 (Steele, Lea & Flood 2014) for reproducible test data.
pub struct Rng(pub u64);
impl Rng {
    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    pub fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
}

pub const CELL: f64 = 10.0;

pub fn source(data: &[f32], w: usize, h: usize) -> MemRaster {
    let g = Grid::from_vec(w, h, data.to_vec()).unwrap();
    MemRaster::from_grid(
        g,
        GeoRef::north_up(500_000.0, 4_000_000.0, CELL, Crs::projected(32611)),
    )
}

pub fn run(src: &MemRaster, specs: &str, tile: usize, threads: usize) -> Vec<Vec<f32>> {
    let specs = parse_specs(specs).unwrap();
    let info = src.info();
    let step = MultiMetric::new(&specs, info).unwrap();
    let engine = LocalEngine::new(EngineConfig {
        threads,
        ..EngineConfig::default()
    });
    let layout = TileLayout::new(info.width, info.height, tile);
    let types = vec![(DType::F32, None); specs.len()];
    run_local_to_memory(&engine, &step, &[src as &dyn RasterSource], layout, &types)
        .unwrap()
        .iter()
        .map(|g| g.to_typed::<f32>(None).into_vec())
        .collect()
}

pub fn run1(src: &MemRaster, spec: &str) -> Vec<f32> {
    run(src, spec, 16, 2).remove(0)
}
