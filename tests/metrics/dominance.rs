//! The last pointwise descriptors (dominance and submission of Xu,
//! peakedness, geographical domination) against oracles that share no code
//! with them: direct loops over the disk written from the definitions on
//! random grids with nodata holes, closed forms on an isolated cone and a
//! spike, tiled == untiled bit for bit at odd tile sizes, bad parameters.

#![allow(clippy::needless_range_loop)] // index loops read like the definitions

use orogen::raster::{Crs, GeoRef, Grid, MemRaster, RasterSource};

use crate::common::{
    check_abs as check, random_terrain, run, run_bits, source, spec_err as err, CELL,
};

/// Random terrain (smooth + noise, values rounded to 1/2, with ties) with nodata holes.
fn random_grid(w: usize, h: usize, seed: u64, holes: f64) -> Vec<f32> {
    random_terrain(w, h, seed, holes, 2.0)
}

/// Direct evaluation of the four definitions at every cell: all cells of
/// the raster at distance 0 < d ≤ radius (metres) are visited.
fn brute(d: &[f32], w: usize, h: usize, radius: f64) -> [Vec<f64>; 4] {
    let mut out = [
        vec![f64::NAN; w * h],
        vec![f64::NAN; w * h],
        vec![f64::NAN; w * h],
        vec![f64::NAN; w * h],
    ];
    for y in 0..h {
        for x in 0..w {
            let z = d[y * w + x] as f64;
            if z.is_nan() {
                continue;
            }
            let (mut dom, mut sub) = (0.0f64, 0.0f64);
            let (mut lower, mut n) = (0usize, 0usize);
            let mut near = radius;
            for yy in 0..h {
                for xx in 0..w {
                    let dist = CELL
                        * (((xx as f64 - x as f64).powi(2) + (yy as f64 - y as f64).powi(2))
                            .sqrt());
                    if dist == 0.0 || dist > radius + 1e-9 {
                        continue;
                    }
                    let v = d[yy * w + xx] as f64;
                    if v.is_nan() {
                        continue;
                    }
                    n += 1;
                    if v < z {
                        lower += 1;
                        dom = dom.max(z - v);
                    }
                    if v > z {
                        sub = sub.max(v - z);
                        near = near.min(dist);
                    }
                }
            }
            let i = y * w + x;
            out[0][i] = dom;
            out[1][i] = sub;
            out[2][i] = if n == 0 {
                f64::NAN
            } else {
                lower as f64 / n as f64
            };
            out[3][i] = near;
        }
    }
    out
}

const NAMES: [&str; 4] = ["dominance", "submission", "peakedness", "domination"];

#[test]
fn brute_force_on_random_grids() {
    for (seed, (w, h)) in [(1u64, (23usize, 19usize)), (2, (31, 12))] {
        let data = random_grid(w, h, seed, 0.08);
        let src = source(&data, w, h);
        for (spec_r, radius) in [("3c", 30.0), ("45m", 45.0), ("5c", 50.0)] {
            let specs = NAMES
                .iter()
                .map(|n| format!("{n}:radius={spec_r}"))
                .collect::<Vec<_>>()
                .join(",");
            let got = run(&src, &specs, 8, 2);
            let want = brute(&data, w, h, radius);
            for k in 0..4 {
                check(NAMES[k], &got[k], &want[k], w, 1e-4);
            }
        }
    }
}

#[test]
fn isolated_cone_closed_forms() {
    // Cone of height H and slope s around (c, c), on a flat base at 0.
    let (n, c) = (41usize, 20usize);
    let (hgt, s) = (100.0f64, 0.5f64);
    let data: Vec<f32> = (0..n * n)
        .map(|i| {
            let (x, y) = ((i % n) as f64, (i / n) as f64);
            let d = CELL * ((x - c as f64).powi(2) + (y - c as f64).powi(2)).sqrt();
            (hgt - s * d).max(0.0) as f32
        })
        .collect();
    let src = source(&data, n, n);
    let r = 8usize;
    let specs = NAMES
        .iter()
        .map(|m| format!("{m}:radius={r}c"))
        .collect::<Vec<_>>()
        .join(",");
    let got = run(&src, &specs, 13, 2);
    let apex = c * n + c;
    // The apex drops s·R to the cells exactly R away; it is the highest cell:
    // submission 0, peakedness 1 (every other cell is lower), domination = cutoff.
    let rm = r as f64 * CELL;
    assert!(
        (got[0][apex] as f64 - s * rm).abs() < 1e-4,
        "{}",
        got[0][apex]
    );
    assert_eq!(got[1][apex], 0.0);
    assert_eq!(got[2][apex], 1.0);
    assert!((got[3][apex] as f64 - rm).abs() < 1e-4);
    // A flank cell 5 cells east of the apex: the apex is within the cutoff,
    // so submission = H - z; the nearest higher cell is its western neighbour.
    let f = c * n + c + 5;
    let zf = hgt - s * 5.0 * CELL;
    assert!(
        (got[1][f] as f64 - (hgt - zf)).abs() < 1e-4,
        "{}",
        got[1][f]
    );
    assert!((got[3][f] as f64 - CELL).abs() < 1e-4, "{}", got[3][f]);
    // Its lowest cell in the disk is 8 cells further east (13 from the apex).
    assert!(
        (got[0][f] as f64 - s * 8.0 * CELL).abs() < 1e-4,
        "{}",
        got[0][f]
    );
    // The corner cell: the cone's foot (20 cells from the apex) is 28.3 - 20
    // > 8 cells away, so the disk is flat: nothing lower or higher.
    let b = 0;
    assert_eq!(got[0][b], 0.0);
    assert_eq!(got[1][b], 0.0);
    assert_eq!(got[2][b], 0.0);
    assert!((got[3][b] as f64 - rm).abs() < 1e-4);
}

#[test]
fn spike_on_a_plane() {
    let (w, h) = (15usize, 15usize);
    let mut data = vec![3.0f32; w * h];
    data[7 * w + 7] = 53.0;
    data[2 * w + 2] = f32::NAN;
    let src = source(&data, w, h);
    let got = run(
        &src,
        "dominance:radius=3c,submission:radius=3c,peakedness:radius=3c,domination:radius=3c",
        7,
        1,
    );
    let s = 7 * w + 7;
    assert_eq!(got[0][s], 50.0);
    assert_eq!(got[1][s], 0.0);
    assert_eq!(got[2][s], 1.0);
    assert_eq!(got[3][s], 30.0);
    // A neighbour at distance 2 cells: the spike is 50 above, 20 m away.
    let q = 7 * w + 9;
    assert_eq!(got[0][q], 0.0);
    assert_eq!(got[1][q], 50.0);
    assert_eq!(got[2][q], 0.0);
    assert_eq!(got[3][q], 20.0);
    // Nodata stays nodata.
    for k in 0..4 {
        assert!(got[k][2 * w + 2].is_nan());
    }
    // Beyond the cutoff the spike is not seen.
    let far = 7 * w + 11;
    assert_eq!(got[1][far], 0.0);
    assert_eq!(got[3][far], 30.0);
}

#[test]
fn tiled_equals_untiled_bit_for_bit() {
    let (w, h) = (61usize, 47usize);
    let data = random_grid(w, h, 9, 0.05);
    let src = source(&data, w, h);
    let specs =
        "dominance:radius=6c,submission:radius=45m,peakedness:radius=5c,domination:radius=7c";
    let whole = run(&src, specs, 64, 1);
    for tile in [7usize, 13, 37] {
        for threads in [1usize, 2] {
            let t = run(&src, specs, tile, threads);
            for k in 0..whole.len() {
                assert_eq!(whole[k].len(), t[k].len());
                for (a, b) in whole[k].iter().zip(&t[k]) {
                    assert_eq!(a.to_bits(), b.to_bits(), "metric {k}, tile {tile}");
                }
            }
        }
    }
}

#[test]
fn bad_parameters_are_clear_errors() {
    let e = err("dominance:radius=-3c");
    assert!(e.contains("out of range") && e.contains("1c..="), "{e}");
    let e = err("submission:radius=50c");
    assert!(
        e.contains("beyond the raster") && e.contains("submission"),
        "{e}"
    );
    let e = err("peakedness:radius=0m");
    assert!(e.contains("positive"), "{e}");
    let e = err("domination:radius=3");
    assert!(e.contains("not a length"), "{e}");
    let e = err("domination:azimuth=3");
    assert!(e.contains("no parameter") && e.contains("radius"), "{e}");
    let e = err("dominanse");
    assert!(
        e.contains("unknown metric") && e.contains("dominance"),
        "{e}"
    );
}

/// Tiled == untiled on a real DEM and on a geographic raster (true-metre
/// disks that change with the row).
#[test]
fn tiled_equals_untiled_real_and_geographic() {
    use orogen::io::{open_raster, OpenOptions};
    let real = open_raster(
        std::path::Path::new("tests/data/whitebox_DEM.tif"),
        &OpenOptions::default(),
    )
    .unwrap();
    let (w, h) = (53usize, 41usize);
    let d = 1.0 / 1200.0;
    let mut gr = GeoRef::north_up(10.0, 60.0, d, Crs::wgs84());
    gr.transform[5] = -d;
    let geo = MemRaster::from_grid(
        Grid::from_vec(w, h, random_grid(w, h, 4, 0.03)).unwrap(),
        gr,
    );
    let specs =
        "dominance:radius=200m,submission:radius=5c,peakedness:radius=150m,domination:radius=6c";
    let runt = |src: &dyn RasterSource, tile: usize| run_bits(src, specs, tile, 2);
    for src in [real.as_ref(), &geo as &dyn RasterSource] {
        let whole = runt(src, 512);
        // Something was computed: not all nodata, dominance not all zero.
        assert!(whole[0]
            .iter()
            .any(|&b| b != u32::MAX && f32::from_bits(b) > 0.0));
        for tile in [7, 13, 37] {
            assert!(runt(src, tile) == whole, "tile {tile}");
        }
    }
}
