//! Shared builders of the metric tests: a SplitMix64 generator, an
//! in-memory source in a projected CRS and a runner of metric specs through
//! the local engine at a given tile size and thread count.

#![allow(dead_code)] // each test binary uses a subset

pub mod cli;
pub mod engine;
pub mod hydro;
pub mod job;
pub mod store;

use orogen::exec::run_local_to_memory;
use orogen::exec::{EngineConfig, LocalEngine};
use orogen::metrics::{parse_specs, MultiMetric};
use orogen::oro::stats::SplitMix64;
use orogen::raster::{Crs, DType, GeoRef, Grid, MemRaster, RasterSource, TileLayout};

/// A file of the repository's `tests/data`.
pub fn test_data(name: &str) -> std::path::PathBuf {
    std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

/// Reproducible test data from the library's SplitMix64
/// ([`orogen::oro::stats::SplitMix64`]), seeded as `Rng(seed)`.
pub struct Rng(pub u64);
impl Rng {
    /// Run `f` on the generator at this state and keep the state it leaves.
    fn with<T>(&mut self, f: impl FnOnce(&mut SplitMix64) -> T) -> T {
        let mut g = SplitMix64(self.0);
        let v = f(&mut g);
        self.0 = g.0;
        v
    }
    pub fn next(&mut self) -> u64 {
        self.with(SplitMix64::next_u64)
    }
    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        self.with(SplitMix64::unit)
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

/// Run the metrics of `specs` with square tiles of `tile` on `threads`
/// threads; one grid per metric.
pub fn run(src: &dyn RasterSource, specs: &str, tile: usize, threads: usize) -> Vec<Vec<f32>> {
    let specs = parse_specs(specs).unwrap();
    let info = src.info();
    let step = MultiMetric::new(&specs, info).unwrap();
    let engine = LocalEngine::new(EngineConfig {
        threads,
        ..EngineConfig::default()
    });
    let layout = TileLayout::new(info.width, info.height, tile);
    let types = vec![(DType::F32, None); specs.len()];
    run_local_to_memory(&engine, &step, &[src], layout, &types)
        .unwrap()
        .iter()
        .map(|g| g.to_typed::<f32>(None).into_vec())
        .collect()
}

pub fn run1(src: &MemRaster, spec: &str) -> Vec<f32> {
    run(src, spec, 16, 2).remove(0)
}

/// [`run`] as bit patterns, every NaN as `u32::MAX` (to compare bit for bit).
pub fn run_bits(src: &dyn RasterSource, specs: &str, tile: usize, threads: usize) -> Vec<Vec<u32>> {
    run(src, specs, tile, threads)
        .iter()
        .map(|g| {
            g.iter()
                .map(|v| if v.is_nan() { u32::MAX } else { v.to_bits() })
                .collect()
        })
        .collect()
}

/// Random terrain (smooth + noise, values rounded to multiples of `1/q`)
/// with a fraction `holes` of nodata cells.
pub fn random_terrain(w: usize, h: usize, seed: u64, holes: f64, q: f64) -> Vec<f32> {
    random_terrain_by(w, h, seed, holes, q, |x, y| {
        40.0 * (x * 0.3).sin() + 25.0 * (y * 0.21).cos()
    })
}

/// [`random_terrain`] with another smooth part `smooth(x, y)` (the noise,
/// the rounding and the holes as there).
pub fn random_terrain_by(
    w: usize,
    h: usize,
    seed: u64,
    holes: f64,
    q: f64,
    smooth: impl Fn(f64, f64) -> f64,
) -> Vec<f32> {
    let mut rng = Rng(seed);
    (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f64, (i / w) as f64);
            if rng.unit() < holes {
                f32::NAN
            } else {
                let z = smooth(x, y) + 8.0 * rng.unit();
                ((z * q).round() / q) as f32
            }
        })
        .collect()
}

/// The error of a metric spec that must be refused, by the parser or when
/// the metrics are built for a 10 x 10 source.
pub fn spec_err(s: &str) -> String {
    match parse_specs(s) {
        Ok(v) => {
            let src = source(&[0f32; 100], 10, 10);
            match MultiMetric::new(&v, src.info()) {
                Ok(_) => panic!("{s} accepted"),
                Err(e) => e.to_string(),
            }
        }
        Err(e) => e.to_string(),
    }
}

/// Every metric of `specs` has more than `min_valid` valid cells in one
/// whole-grid tile, and tiles of 1, 7, 13 and 16 cells (1 or 2 threads) give
/// the same bits (any NaN equals any NaN).
pub fn assert_tiled_equals_untiled(src: &MemRaster, specs: &str, min_valid: usize) {
    let whole = run(src, specs, 64, 1);
    for (k, g) in whole.iter().enumerate() {
        assert!(
            g.iter().filter(|v| !v.is_nan()).count() > min_valid,
            "metric {k} mostly nodata"
        );
    }
    for (tile, threads) in [(1, 2), (7, 2), (13, 1), (16, 2)] {
        let got = run(src, specs, tile, threads);
        for (k, (a, b)) in whole.iter().zip(&got).enumerate() {
            assert_eq!(a.len(), b.len(), "metric {k} tile {tile}");
            for (i, (x, y)) in a.iter().zip(b).enumerate() {
                assert!(
                    x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()),
                    "metric {k} tile {tile} cell {i}: {x} vs {y}"
                );
            }
        }
    }
}

/// Cell `(x, y)` of a `w` x `h` grid as f64, NaN outside it.
pub fn get(d: &[f32], w: usize, h: usize, x: i64, y: i64) -> f64 {
    if x < 0 || y < 0 || x >= w as i64 || y >= h as i64 {
        f64::NAN
    } else {
        d[y as usize * w + x as usize] as f64
    }
}

/// Horn's gradient written out from the paper's weights (east, north), NaN
/// if any of the 9 cells is missing.
pub fn horn(d: &[f32], w: usize, h: usize, x: i64, y: i64) -> (f64, f64) {
    let z = |dx: i64, dy: i64| get(d, w, h, x + dx, y + dy);
    let east = z(1, -1) + 2.0 * z(1, 0) + z(1, 1);
    let west = z(-1, -1) + 2.0 * z(-1, 0) + z(-1, 1);
    let north = z(-1, -1) + 2.0 * z(0, -1) + z(1, -1);
    let south = z(-1, 1) + 2.0 * z(0, 1) + z(1, 1);
    if z(0, 0).is_nan() {
        // Horn's weights skip the centre, but a nodata cell has no slope.
        return (f64::NAN, f64::NAN);
    }
    ((east - west) / (8.0 * CELL), (north - south) / (8.0 * CELL))
}

/// Asserts `got` equals `want` cell by cell: NaN where `want` is NaN, else
/// within `tol(want)`; `w` (the grid width) places a failing cell.
fn check_tol(name: &str, got: &[f32], want: &[f64], w: usize, tol: impl Fn(f64) -> f64) {
    assert_eq!(got.len(), want.len());
    for (i, (g, e)) in got.iter().zip(want).enumerate() {
        let ok = if e.is_nan() {
            g.is_nan()
        } else {
            (*g as f64 - e).abs() <= tol(*e)
        };
        assert!(ok, "{name}: cell ({}, {}) got {g}, want {e}", i % w, i / w);
    }
}

/// [`check_tol`] within `abs + rel·|want|`.
pub fn check(name: &str, got: &[f32], want: &[f64], w: usize, rel: f64, abs: f64) {
    check_tol(name, got, want, w, |e| abs + rel * e.abs());
}

/// [`check_tol`] within `abs`.
pub fn check_abs(name: &str, got: &[f32], want: &[f64], w: usize, abs: f64) {
    check_tol(name, got, want, w, |_| abs);
}

/// An east-west ridge on row `crest`: slopes `gn` on the north side and `gs`
/// on the south side (rise per metre towards the crest).
pub fn ridge(w: usize, h: usize, crest: usize, gn: f64, gs: f64) -> Vec<f32> {
    (0..w * h)
        .map(|i| {
            let y = (i / w) as f64;
            let d = (y - crest as f64) * CELL; // positive to the south
            (if d < 0.0 { gn * d } else { -gs * d }) as f32
        })
        .collect()
}

/// Every file of `dir` (not recursive) as (name, bytes), by name.
pub fn dir_bytes(dir: &std::path::Path) -> Vec<(String, Vec<u8>)> {
    let mut v: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let e = e.unwrap();
            (
                e.file_name().to_string_lossy().into_owned(),
                std::fs::read(e.path()).unwrap(),
            )
        })
        .collect();
    v.sort();
    v
}

/// Ingest a `w x h` u16 raster (cell (x, y) = 100 x + y) into the tile store
/// `dir` (tiles of 16 cells, `compression`, no sync); returns the source.
pub fn u16_store(
    dir: &std::path::Path,
    w: usize,
    h: usize,
    compression: orogen::store::Compression,
) -> MemRaster {
    let g = Grid::from_fn(w, h, |x, y| (x * 100 + y) as u16);
    let src = MemRaster::new(orogen::raster::AnyGrid::U16(g), GeoRef::pixel(), "u16.mem");
    let opts = orogen::store::StoreOptions {
        tile: 16,
        compression,
        sync: false,
        ..Default::default()
    };
    orogen::exec::ingest(&src, dir, opts, &EngineConfig::default()).unwrap();
    src
}

/// Steps `a` and `b` (dx east, dy south in rows), then both turned
/// clockwise by one, two and three quarter turns, interleaved.
const fn quarter_turns(a: (i64, i64), b: (i64, i64)) -> [(i64, i64); 8] {
    let mut out = [(0, 0); 8];
    let (mut a, mut b) = (a, b);
    let mut q = 0;
    while q < 4 {
        out[2 * q] = a;
        out[2 * q + 1] = b;
        a = (-a.1, a.0);
        b = (-b.1, b.0);
        q += 1;
    }
    out
}

/// The 8 neighbour steps clockwise from north: N, NE, E, SE, S, SW, W, NW.
pub const COMPASS8: [(i64, i64); 8] = quarter_turns((0, -1), (1, -1));

/// The 8 neighbour steps clockwise from east: E, SE, S, SW, W, NW, N, NE.
pub const EAST8: [(i64, i64); 8] = quarter_turns((1, 0), (1, 1));

/// The 16 lattice rays of the horizon metrics: [`COMPASS8`], then the
/// knight moves clockwise from north-north-east.
pub const RAYS16: [(i64, i64); 16] = {
    let knights = quarter_turns((1, -2), (2, -1));
    let mut out = [(0, 0); 16];
    let mut i = 0;
    while i < 8 {
        out[i] = COMPASS8[i];
        out[8 + i] = knights[i];
        i += 1;
    }
    out
};

/// Aspect (azimuth of steepest descent, clockwise from north, degrees) of
/// the gradient `(p, q)` = (dz/dx east, dz/dy north).
pub fn aspect_deg(p: f64, q: f64) -> f64 {
    let a = (-p).atan2(-q).to_degrees();
    if a < 0.0 {
        a + 360.0
    } else {
        a
    }
}

/// The Horn gradient norms of the cells of the square of half-side `r`
/// around (x, y) that face `az` ± `tol` degrees and those that face the
/// opposite way, among the cells steeper than 5 % (the split of the
/// hillslope asymmetry of Poulos et al. 2012), in row-major order.
#[allow(clippy::too_many_arguments)]
pub fn facing_gradients(
    d: &[f32],
    w: usize,
    h: usize,
    (x, y): (i64, i64),
    r: i64,
    az: f64,
    tol: f64,
) -> (Vec<f64>, Vec<f64>) {
    let (mut toward, mut away) = (Vec::new(), Vec::new());
    for yy in y - r..=y + r {
        for xx in x - r..=x + r {
            let (p, q) = horn(d, w, h, xx, yy);
            let g = (p * p + q * q).sqrt();
            if g.is_nan() || g <= 0.05 {
                continue;
            }
            let a = aspect_deg(p, q);
            let dist = |t: f64| {
                let d = (a - t).abs() % 360.0;
                d.min(360.0 - d)
            };
            if dist(az) < tol {
                toward.push(g);
            } else if dist(az + 180.0) < tol {
                away.push(g);
            }
        }
    }
    (toward, away)
}

/// Write an ESRI ASCII grid of `w` x `h` cells to `path`: lower-left corner
/// and cell size `(xll, yll, cell)`, value `f(x, y)` of each cell (row 0 the
/// north row), `None` as the nodata value -9999.
pub fn write_esri_ascii(
    path: &std::path::Path,
    (w, h): (usize, usize),
    (xll, yll, cell): (f64, f64, f64),
    f: impl Fn(usize, usize) -> Option<f64>,
) {
    let mut s = format!(
        "ncols {w}\nnrows {h}\nxllcorner {xll}\nyllcorner {yll}\ncellsize {cell}\nNODATA_value -9999\n"
    );
    for y in 0..h {
        let row: Vec<String> = (0..w)
            .map(|x| f(x, y).map_or("-9999".to_string(), |v| v.to_string()))
            .collect();
        s.push_str(&row.join(" "));
        s.push('\n');
    }
    std::fs::write(path, s).unwrap();
}
