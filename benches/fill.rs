//! Timings of the depression fill: `hydro::fill` (region-growing
//! Priority-Flood, Zhou, Sun & Fu 2016) against `fill::fill_reference`
//! (Barnes et al. 2014, Alg. 2), same DEM, same run, results compared bit
//! for bit (±0 merged). Run in release:
//!
//! ```text
//! gdal_translate -of ENVI -ot Float32 poland_N49-55_E014-025.tif /tmp/poland.f32
//! OROGEN_FILL_DEM=/tmp/poland.f32:13201:7201:-32768 cargo bench --bench fill
//! ```
//! Without `OROGEN_FILL_DEM` it uses a synthetic 2000 x 2000 rough terrain
//! (sum of integer-hash value noise octaves, so it has many pits).

use orogen::hydro::fill;
use orogen::hydro::fill::fill_reference;
use orogen::raster::{AnyGrid, DType, Grid};
use std::time::Instant;

fn hash(x: u64, y: u64, s: u64) -> f32 {
    let mut h = x.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ y.wrapping_mul(0xC2B2_AE3D_27D4_EB4F) ^ s;
    h ^= h >> 29;
    h = h.wrapping_mul(0xBF58_476D_1CE4_E5B9);
    h ^= h >> 32;
    (h & 0xFFFF) as f32 / 65535.0
}

fn synthetic(w: usize, h: usize) -> Grid<f32> {
    Grid::from_fn(w, h, |x, y| {
        let mut z = 0.0;
        let mut amp = 400.0;
        let mut cell = 256usize;
        let mut s = 1u64;
        while cell >= 1 {
            // bilinear value noise on a lattice of `cell` cells
            let (gx, gy) = (x / cell, y / cell);
            let (fx, fy) = (
                (x % cell) as f32 / cell as f32,
                (y % cell) as f32 / cell as f32,
            );
            let v = |a: usize, b: usize| hash(a as u64, b as u64, s);
            let top = v(gx, gy) * (1.0 - fx) + v(gx + 1, gy) * fx;
            let bot = v(gx, gy + 1) * (1.0 - fx) + v(gx + 1, gy + 1) * fx;
            z += amp * (top * (1.0 - fy) + bot * fy);
            amp *= 0.5;
            cell /= 2;
            s += 1;
        }
        (z * 10.0).round() / 10.0
    })
}

fn load(spec: &str) -> Grid<f32> {
    let parts: Vec<&str> = spec.split(':').collect();
    assert_eq!(parts.len(), 4, "OROGEN_FILL_DEM=path:width:height:nodata");
    let (w, h): (usize, usize) = (parts[1].parse().unwrap(), parts[2].parse().unwrap());
    let nodata: f32 = parts[3].parse().unwrap();
    let bytes = std::fs::read(parts[0]).unwrap();
    // Raw little-endian f32 cells (the size is checked); `nodata` becomes NaN.
    AnyGrid::from_le_bytes(DType::F32, w, h, &bytes)
        .expect("raw file size")
        .to_typed::<f32>(Some(nodata.into()))
}

fn main() {
    // `cargo bench` passes --bench; `cargo test --benches` does not run us long
    if std::env::args().any(|a| a == "--list") {
        return;
    }
    let g = match std::env::var("OROGEN_FILL_DEM") {
        Ok(spec) => load(&spec),
        Err(_) => synthetic(2000, 2000),
    };
    let mc = (g.width() * g.height()) as f64 / 1e6;
    eprintln!("DEM {}x{} = {mc:.1} Mcells", g.width(), g.height());
    let t = Instant::now();
    let r = fill_reference(&g).unwrap();
    let t_ref = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let f = fill(&g).unwrap();
    let t_new = t.elapsed().as_secs_f64();
    let differ = f
        .data()
        .iter()
        .zip(r.data())
        .filter(|(a, b)| !(a.to_bits() == b.to_bits() || **a == **b || (a.is_nan() && b.is_nan())))
        .count();
    assert_eq!(differ, 0, "fill differs from fill_reference");
    eprintln!(
        "fill-bench reference_s={t_ref:.3} zhou_s={t_new:.3} speedup={:.2} ({:.1} vs {:.1} Mcells/s)",
        t_ref / t_new,
        mc / t_ref,
        mc / t_new
    );
}
