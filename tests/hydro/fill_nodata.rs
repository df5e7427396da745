//! `ops::fill_nodata` (void filling by inverse-distance weighting along 16
//! rays, `orogen::hydro::fill_nodata`) against oracles that share no code
//! with it: a brute-force version of the stated method (every cell of the
//! grid tested for lying on each ray), a plane with a hole (closed form and
//! the stated error bound), a real SRTM crop against GDAL's gdal_fillnodata
//! output, and tiled runs against one tile.

use orogen::exec::EngineConfig;
use orogen::io::{open_raster, OpenOptions};
use orogen::ops::fill_nodata::{self, FillNodataOptions};
use orogen::ops::parse::Reach;
use orogen::ops::Target;
use orogen::raster::{read_window, AnyGrid, Crs, GeoRef, Grid, MemRaster, RasterSource, Window};

const ND: f32 = -9999.0;

fn cfg(threads: usize) -> EngineConfig {
    EngineConfig {
        threads,
        memory_budget: 1 << 30,
        progress: false,
        observer: None,
        engine: Default::default(),
    }
}

/// fill-nodata of `src` in memory with work tiles of `tile` (None: one
/// default tile) on `threads` threads.
fn fill(src: &dyn RasterSource, max: Reach, tile: Option<usize>, threads: usize) -> AnyGrid {
    let dir = tempfile::tempdir().unwrap();
    let mut t = Target::memory(dir.path());
    t.tile = tile;
    let opts = FillNodataOptions { max_distance: max };
    fill_nodata::run(src, &opts, &t, &cfg(threads)).unwrap();
    t.take_memory().expect("output kept in memory").0
}

fn f32s(g: &AnyGrid) -> Vec<f32> {
    match g {
        AnyGrid::F32(g) => g.data().to_vec(),
        other => panic!("expected f32 output, got {:?}", other.dtype()),
    }
}

/// The 16 ray steps of the stated method, built here from their
/// definition: the primitive integer vectors (gcd 1) of Chebyshev length
/// at most 2 (the 8 compass directions and the 8 knight moves).
fn rays() -> Vec<(i64, i64)> {
    fn gcd(a: i64, b: i64) -> i64 {
        if b == 0 {
            a
        } else {
            gcd(b, a % b)
        }
    }
    let mut r = Vec::new();
    for dy in -2i64..=2 {
        for dx in -2i64..=2 {
            if (dx, dy) != (0, 0) && gcd(dx.abs(), dy.abs()) == 1 {
                r.push((dx, dy));
            }
        }
    }
    assert_eq!(r.len(), 16);
    r
}

/// Metric cell size (east-west, north-south) of row `row` of a WGS84
/// geographic grid with origin latitude `lat0` (north edge) and square
/// cells of `deg` degrees: the ellipsoid's radii of curvature at the row's
/// centre latitude (prime vertical N cos φ, meridian M).
fn wgs84_cell_m(lat0: f64, deg: f64, row: usize) -> (f64, f64) {
    let (a, e2) = (6_378_137.0f64, 6.694_379_990_14e-3f64);
    let phi = (lat0 - (row as f64 + 0.5) * deg).to_radians();
    let w = (1.0 - e2 * phi.sin().powi(2)).sqrt();
    let n = a / w;
    let m = a * (1.0 - e2) / w.powi(3);
    let rad = deg.to_radians();
    (n * phi.cos() * rad, m * rad)
}

/// Brute force of the stated method on a `w` x `h` grid (`NaN` = void):
/// for each void cell and each ray, every cell of the grid is tested for
/// lying on the ray (`(x, y) = c + k s`, k >= 1); the valid one of smallest
/// k within `max` (distance `k |s|` in cells, or in metres with the void
/// cell's row size `cell(row)`) is the ray's sample; the value is
/// `Σ z / d² / Σ 1 / d²`, NaN when no ray has a sample.
fn brute_force(
    z: &[f32],
    w: usize,
    h: usize,
    max: f64,
    cell: impl Fn(usize) -> (f64, f64),
) -> Vec<f64> {
    let mut out = vec![f64::NAN; w * h];
    for y0 in 0..h {
        let (ew, ns) = cell(y0);
        for x0 in 0..w {
            let v = z[y0 * w + x0];
            if !v.is_nan() {
                out[y0 * w + x0] = v as f64;
                continue;
            }
            let (mut num, mut den) = (0.0, 0.0);
            for (sx, sy) in rays() {
                let mut best: Option<(i64, f64)> = None;
                for y in 0..h {
                    for x in 0..w {
                        let (dx, dy) = (x as i64 - x0 as i64, y as i64 - y0 as i64);
                        let k = if sx != 0 { dx / sx } else { dy / sy };
                        if k < 1 || (dx, dy) != (k * sx, k * sy) || z[y * w + x].is_nan() {
                            continue;
                        }
                        let len = ((sx as f64 * ew).powi(2) + (sy as f64 * ns).powi(2)).sqrt();
                        let d = k as f64 * len;
                        if d <= max && best.is_none_or(|(bk, _)| k < bk) {
                            best = Some((k, d));
                        }
                    }
                }
                if let Some((k, d)) = best {
                    let s = z[(y0 as i64 + k * sy) as usize * w + (x0 as i64 + k * sx) as usize];
                    num += s as f64 / (d * d);
                    den += 1.0 / (d * d);
                }
            }
            if den > 0.0 {
                out[y0 * w + x0] = num / den;
            }
        }
    }
    out
}

/// Rough terrain with voids of several sizes (blobs and single cells),
/// NaN-free except at the voids, which hold `ND`.
fn voided_terrain(w: usize, h: usize, seed: u64) -> Vec<f32> {
    let mut s = seed;
    let mut next = || {
        s = s.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut x = s;
        x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((x ^ (x >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut z: Vec<f32> = (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f64, (i / w) as f64);
            (100.0 + 20.0 * (x / 7.0).sin() * (y / 5.0).cos() + 0.5 * x - 0.3 * y) as f32
        })
        .collect();
    for v in z.iter_mut() {
        *v += (next() * 3.0) as f32;
    }
    for _ in 0..6 {
        let (cx, cy, r) = (next() * w as f64, next() * h as f64, 1.0 + next() * 7.0);
        for y in 0..h {
            for x in 0..w {
                if (x as f64 - cx).powi(2) + (y as f64 - cy).powi(2) <= r * r {
                    z[y * w + x] = ND;
                }
            }
        }
    }
    for _ in 0..20 {
        let i = (next() * (w * h) as f64) as usize;
        z[i.min(w * h - 1)] = ND;
    }
    z
}

fn mem(z: &[f32], w: usize, h: usize, georef: GeoRef) -> MemRaster {
    MemRaster::from_grid(
        Grid::from_vec(w, h, z.to_vec()).unwrap(),
        georef.with_nodata(Some(ND as f64)),
    )
}

/// `got` (f32 output, `ND` = nodata) equals `want` (f64, NaN = nodata):
/// the same cells stay void, and filled values agree to f32 rounding.
fn assert_matches(got: &[f32], want: &[f64], w: usize) {
    for (i, (&g, &e)) in got.iter().zip(want).enumerate() {
        let at = (i % w, i / w);
        if e.is_nan() {
            assert_eq!(g, ND, "cell {at:?} should stay nodata, got {g}");
        } else {
            assert!(
                (g as f64 - e).abs() <= 1e-6 * e.abs().max(1.0),
                "cell {at:?}: got {g}, brute force {e}"
            );
        }
    }
}

#[test]
fn equals_brute_force_in_cells() {
    let (w, h) = (53, 41);
    let z = voided_terrain(w, h, 7);
    let voids = z.iter().filter(|&&v| v == ND).count();
    assert!(voids > 100, "only {voids} voids");
    let nan: Vec<f32> = z
        .iter()
        .map(|&v| if v == ND { f32::NAN } else { v })
        .collect();
    for max in [3.0, 6.5, 100.0] {
        let got = f32s(&fill(
            &mem(&z, w, h, GeoRef::pixel()),
            Reach::Cells(max),
            None,
            2,
        ));
        let want = brute_force(&nan, w, h, max, |_| (1.0, 1.0));
        assert_matches(&got, &want, w);
        // Every void cell farther than `max` from all valid cells stays
        // nodata; valid cells are copied bit for bit.
        for y0 in 0..h {
            for x0 in 0..w {
                let i = y0 * w + x0;
                if z[i] != ND {
                    assert_eq!(got[i].to_bits(), z[i].to_bits());
                    continue;
                }
                let near = (0..w * h).any(|j| {
                    z[j] != ND
                        && ((j % w) as f64 - x0 as f64).hypot((j / w) as f64 - y0 as f64) <= max
                });
                if !near {
                    assert_eq!(got[i], ND, "({x0}, {y0}) is beyond {max} cells");
                }
            }
        }
        let left = got.iter().filter(|&&v| v == ND).count();
        if max == 3.0 {
            assert!(
                left > 0 && left < voids,
                "max 3: {left} of {voids} voids left"
            );
        } else if max == 100.0 {
            assert_eq!(left, 0);
        }
    }
}

#[test]
fn equals_brute_force_in_metres_with_per_row_cell_sizes() {
    // 0.01° cells from 70°N: a cell is 1113 m north-south but only 381 m
    // east-west at the top row and 388 m at the bottom one, so a 1150 m
    // reach spans 3 columns east-west at the top and 2 at the bottom: the
    // smallest cell alone would give another answer.
    let (w, h) = (40, 36);
    let (lat0, deg) = (70.0, 0.01);
    let z = voided_terrain(w, h, 11);
    let nan: Vec<f32> = z
        .iter()
        .map(|&v| if v == ND { f32::NAN } else { v })
        .collect();
    let georef = GeoRef::north_up(10.0, lat0, deg, Crs::wgs84());
    for max in [1150.0, 2500.0, 20_000.0] {
        let got = f32s(&fill(
            &mem(&z, w, h, georef.clone()),
            Reach::Metres(max),
            Some(17),
            2,
        ));
        let want = brute_force(&nan, w, h, max, |row| wgs84_cell_m(lat0, deg, row));
        assert_matches(&got, &want, w);
    }
    let (top, bottom) = (
        wgs84_cell_m(lat0, deg, 0).0,
        wgs84_cell_m(lat0, deg, h - 1).0,
    );
    assert_eq!(
        ((1150.0 / top).floor(), (1150.0 / bottom).floor()),
        (3.0, 2.0)
    );
}

#[test]
fn plane_with_a_hole_within_the_stated_bound() {
    // z = 500 + 0.8 x - 0.6 y (|∇z| = 1 per cell) with a disk hole of
    // radius R = 9 centred on cell (40, 35). The value at a void cell c is
    // z(c) + ∇z · Σ u_i / d_i / Σ 1 / d_i² over the rays' samples (unit
    // directions u_i, distances d_i). Every ray has its opposite in the
    // set, and for one opposite pair (a, b) the term is at most
    // |∇z| |b - a| / 2 (a b |b - a| / (a² + b²) <= |b - a| / 2), so the
    // error is at most |∇z| max |d_i - d_j| / 2 <= |∇z| (R + √5): a
    // sample lies one step (<= √5) past the last void cell of its ray, and
    // the last void cells of two opposite rays lie on one chord of the
    // hole (<= 2R apart), so |d_i - d_j| <= 2R + √5.
    // IDW does not reproduce a plane exactly; it does at the centre (every
    // pair symmetric), and the errors are odd about the centre, so their
    // mean over the hole is zero.
    let (w, h, cx, cy, r) = (81usize, 71usize, 40i64, 35i64, 9i64);
    let plane = |x: i64, y: i64| 500.0 + 0.8 * x as f64 - 0.6 * y as f64;
    let mut z = vec![0f32; w * h];
    let mut hole = Vec::new();
    for y in 0..h as i64 {
        for x in 0..w as i64 {
            let i = y as usize * w + x as usize;
            if (x - cx).pow(2) + (y - cy).pow(2) <= r * r {
                z[i] = ND;
                hole.push((x, y));
            } else {
                z[i] = plane(x, y) as f32;
            }
        }
    }
    let got = f32s(&fill(
        &mem(&z, w, h, GeoRef::pixel()),
        Reach::Cells(100.0),
        None,
        1,
    ));
    let bound = r as f64 + 5f64.sqrt();
    let (mut sum, mut worst) = (0.0f64, 0.0f64);
    for &(x, y) in &hole {
        let err = got[y as usize * w + x as usize] as f64 - plane(x, y);
        assert!(err.abs() <= bound, "({x}, {y}): error {err} > {bound}");
        sum += err;
        worst = worst.max(err.abs());
    }
    let centre = got[cy as usize * w + cx as usize] as f64 - plane(cx, cy);
    assert!(centre.abs() < 1e-3, "centre error {centre}");
    let mean = sum / hole.len() as f64;
    assert!(mean.abs() < 1e-3, "mean error {mean}");
    // Not a plane reproducer: some cell is off by more than rounding.
    assert!(worst > 0.1, "largest error {worst}");
}

/// The real SRTM crop of `tests/data/hydro` (int16, nodata -32767).
fn srtm_crop() -> Box<dyn RasterSource> {
    let p = super::common::test_data("hydro/srtm3_N46E008_voids_crop.tif");
    open_raster(&p, &OpenOptions::default()).unwrap()
}

fn i16s(g: &AnyGrid) -> Vec<i16> {
    match g {
        AnyGrid::I16(g) => g.data().to_vec(),
        other => panic!("expected i16 output, got {:?}", other.dtype()),
    }
}

#[test]
fn srtm_crop_against_gdal_fillnodata() {
    // gdal_fillnodata (GDAL 3.6.2, -md 100, no smoothing) on the same crop,
    // recorded once (tests/data/SOURCES.md). Both fill every void; they
    // differ inside the large voids because GDAL samples, in each of four
    // quadrant cones, the valid cell its row-by-row scan carries forward,
    // while orogen takes the first valid cell on each of 16 rays: different
    // boundary samples, different weights. On alpine relief (voids up to
    // ~60 cells across on steep slopes) that is tens of metres in the
    // middle of a void, less beside valid cells, where both give the
    // nearest neighbours most weight. On the same kind of terrain with
    // voids cut into valid data both are as far from the truth (hold-out
    // figures in docs/PERFORMANCE.md).
    let src = srtm_crop();
    let info = src.info().clone();
    let (w, h) = (info.width, info.height);
    let input = read_window::<f64>(src.as_ref(), Window::new(0, 0, w, h)).unwrap();
    let raw = i16s(&read_native(src.as_ref()));
    let ours = i16s(&fill(src.as_ref(), Reach::Cells(100.0), None, 2));
    let gdal_path = super::common::test_data("hydro/srtm3_N46E008_voids_crop_gdal_fillnodata.tif");
    let gdal = open_raster(&gdal_path, &OpenOptions::default()).unwrap();
    let theirs = i16s(&read_native(gdal.as_ref()));
    let nd = -32767i16;
    let mut diffs = Vec::new();
    let mut edge = Vec::new();
    for i in 0..w * h {
        if input.data()[i].is_finite() {
            assert_eq!(ours[i], raw[i], "valid cell {i} changed");
            continue;
        }
        assert_ne!(ours[i], nd, "void cell {i} left unfilled");
        assert_ne!(theirs[i], nd, "GDAL left void cell {i}");
        let d = (ours[i] as f64 - theirs[i] as f64).abs();
        diffs.push(d);
        // A void cell beside a valid one (8 neighbours).
        let (x, y) = ((i % w) as i64, (i / w) as i64);
        let beside = (-1..=1).any(|dy: i64| {
            (-1..=1).any(|dx: i64| {
                let (nx, ny) = (x + dx, y + dy);
                nx >= 0
                    && ny >= 0
                    && (nx as usize) < w
                    && (ny as usize) < h
                    && input.data()[ny as usize * w + nx as usize].is_finite()
            })
        });
        if beside {
            edge.push(d);
        }
    }
    assert_eq!(diffs.len(), 18_423, "void cells of the crop");
    let q = |v: &mut Vec<f64>, p: f64| {
        v.sort_by(f64::total_cmp);
        v[((v.len() - 1) as f64 * p).round() as usize]
    };
    let (median, p95) = (q(&mut diffs, 0.5), q(&mut diffs, 0.95));
    let edge_median = q(&mut edge, 0.5);
    // Measured: median 28 m, p95 135 m over all voids, median 18 m beside
    // valid cells (GDAL 3.6.2).
    assert!((20.0..=35.0).contains(&median), "median |diff| {median}");
    assert!((110.0..=160.0).contains(&p95), "p95 |diff| {p95}");
    assert!(
        (10.0..=25.0).contains(&edge_median) && edge_median < median,
        "median |diff| beside valid cells {edge_median}"
    );
}

fn read_native(src: &dyn RasterSource) -> AnyGrid {
    let i = src.info();
    src.read_native(Window::new(0, 0, i.width, i.height))
        .unwrap()
}

#[test]
fn tiled_equals_untiled_on_the_srtm_crop() {
    let src = srtm_crop();
    for max in [
        Reach::Cells(100.0),
        Reach::Cells(7.0),
        Reach::Metres(3000.0),
    ] {
        let one = fill(src.as_ref(), max, Some(1024), 1);
        for (tile, threads) in [(37, 1), (37, 2), (64, 2), (23, 2)] {
            let tiled = fill(src.as_ref(), max, Some(tile), threads);
            assert_eq!(
                tiled.as_le_bytes(),
                one.as_le_bytes(),
                "{max}: tile {tile}, {threads} threads"
            );
        }
    }
}

#[test]
fn tiled_equals_untiled_on_float_terrain() {
    let (w, h) = (131, 97);
    let z = voided_terrain(w, h, 3);
    let src = mem(
        &z,
        w,
        h,
        GeoRef::north_up(8.0, 46.5, 1.0 / 1200.0, Crs::wgs84()),
    );
    for max in [Reach::Cells(12.0), Reach::Metres(900.0)] {
        let one = fill(&src, max, Some(1000), 2);
        for tile in [37, 64, 5] {
            let tiled = fill(&src, max, Some(tile), 2);
            assert_eq!(tiled.as_le_bytes(), one.as_le_bytes(), "{max}: tile {tile}");
        }
    }
}

#[test]
fn absurd_distance_is_refused_before_any_output() {
    let src = srtm_crop();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.tif");
    for max in [
        Reach::Cells(1e12),
        Reach::Cells(30_000.0),
        Reach::Metres(1e9),
    ] {
        let opts = FillNodataOptions { max_distance: max };
        let err = fill_nodata::run(src.as_ref(), &opts, &Target::new(&out), &cfg(1))
            .unwrap_err()
            .to_string();
        assert!(err.contains("--max-distance"), "{max}: {err}");
        assert!(err.contains("smaller --max-distance"), "{max}: {err}");
        assert!(!out.exists());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }
}
