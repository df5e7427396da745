//! `--sea-level` and `--nodata` on a real coastal DEM: SRTM3 N43E007 (Nice
//! to Sanremo; the Mediterranean is 0 m in SRTM). Without the mask the sea
//! is one flat that D8 drains across, gathering the coast's rivers into
//! channels on the sea; with `--sea-level 0` the sea is nodata, an outlet.
//!
//! Oracles that share nothing with the reader's option: a copy of the
//! `.hgt` whose sea cells the test sets to SRTM's void value −32768 (big
//! endian, written here) gives the same bytes; every land cell drains to
//! exactly one terminal (the sea, the edge, or a pit of the unfilled DEM),
//! so the accumulation summed over the cells draining into one equals the
//! number of land cells; no cell at or below 0 m keeps a value.

use super::common::cli::{data, fails, ok, orogen, s};
use orogen::io::{open_raster, OpenOptions};
use orogen::raster::{read_window, Grid, Window};
use std::path::Path;

fn grid(p: &Path) -> Grid<f64> {
    let src = open_raster(p, &OpenOptions::default()).unwrap();
    let i = src.info();
    read_window(src.as_ref(), Window::full(i.width, i.height)).unwrap()
}

/// The heights of an SRTM3 `.hgt` (1201 x 1201 big-endian i16), read here.
fn hgt(p: &Path) -> Vec<i16> {
    std::fs::read(p)
        .unwrap()
        .chunks_exact(2)
        .map(|b| i16::from_be_bytes([b[0], b[1]]))
        .collect()
}

/// Equal cell by cell, NaN equal to NaN.
fn same_bits(a: &Grid<f64>, b: &Grid<f64>) -> bool {
    a.data().len() == b.data().len()
        && a.data()
            .iter()
            .zip(b.data())
            .all(|(x, y)| x.to_bits() == y.to_bits())
}

const NB: [(i64, i64, u8); 8] = [
    (1, 0, 1),
    (1, 1, 2),
    (0, 1, 4),
    (-1, 1, 8),
    (-1, 0, 16),
    (-1, -1, 32),
    (0, -1, 64),
    (1, -1, 128),
];

#[test]
fn the_sea_is_an_outlet_on_a_coastal_srtm_tile() {
    let dem = data("srtm/N43E007.hgt");
    let z = hgt(&dem);
    let n = 1201usize;
    let sea = z.iter().filter(|&&v| v <= 0 && v != -32768).count();
    assert!(sea > 200_000, "{sea} sea cells: the tile is the wrong one");
    let d = tempfile::tempdir().unwrap();
    let run = |name: &str, input: &Path, extra: &[&str]| -> (Grid<f64>, Grid<f64>) {
        let d8 = d.path().join(format!("{name}_d8.tif"));
        let acc = d.path().join(format!("{name}_acc.tif"));
        let mut c = orogen();
        c.args(["flow", s(input), "-o", s(&d8), "-q"]).args(extra);
        ok(&mut c);
        ok(orogen().args(["accumulate", s(&d8), "-o", s(&acc), "-q"]));
        (grid(&d8), grid(&acc))
    };
    // Today's default: the sea is crossed.
    let (_, acc_plain) = run("plain", &dem, &[]);
    let on_sea = (0..n * n)
        .filter(|&i| z[i] <= 0 && z[i] != -32768)
        .map(|i| acc_plain.data()[i])
        .fold(0.0, f64::max);
    assert!(
        on_sea > 10_000.0,
        "largest accumulation on the sea {on_sea}"
    );

    // --sea-level 0: tiled with odd tiles too.
    let (d8, acc) = run("sea", &dem, &["--sea-level", "0"]);
    let (d8t, acct) = run("sea_tiled", &dem, &["--sea-level", "0", "--tile", "333"]);
    assert!(same_bits(&d8, &d8t), "tiled D8 differs");
    assert!(same_bits(&acc, &acct), "tiled accumulation differs");
    let mut land = 0usize;
    let mut at_outlets = 0.0;
    for y in 0..n {
        for x in 0..n {
            let i = y * n + x;
            if z[i] <= 0 {
                assert!(
                    d8.data()[i].is_nan() && acc.data()[i].is_nan(),
                    "({x}, {y}) at {} m keeps a value",
                    z[i]
                );
                continue;
            }
            land += 1;
            let code = d8.data()[i] as u8;
            if code == 0 {
                // a pit of the unfilled DEM: its own terminal
                at_outlets += acc.data()[i];
                continue;
            }
            let (dx, dy, _) = NB
                .iter()
                .find(|k| k.2 == code)
                .copied()
                .unwrap_or_else(|| panic!("({x}, {y}): code {code}"));
            let (nx, ny) = (x as i64 + dx, y as i64 + dy);
            let off = nx < 0 || ny < 0 || nx >= n as i64 || ny >= n as i64;
            if off || z[ny as usize * n + nx as usize] <= 0 {
                at_outlets += acc.data()[i];
            }
        }
    }
    assert_eq!(
        at_outlets, land as f64,
        "every land cell drains to one outlet"
    );

    // The same as the sea written as voids into the file itself.
    let masked = d.path().join("N43E007.hgt");
    let bytes: Vec<u8> = z
        .iter()
        .flat_map(|&v| (if v <= 0 { -32768i16 } else { v }).to_be_bytes())
        .collect();
    std::fs::write(&masked, bytes).unwrap();
    let (d8m, accm) = run("masked", &masked, &[]);
    assert!(
        same_bits(&d8m, &d8),
        "D8 differs from the pre-masked file's"
    );
    assert!(
        same_bits(&accm, &acc),
        "accumulation differs from the pre-masked file's"
    );
}

#[test]
fn nodata_is_assigned_or_replaced_and_impossible_requests_fail() {
    let dem = data("srtm/N43E007.hgt");
    let z = hgt(&dem);
    let d = tempfile::tempdir().unwrap();
    // --nodata 0 replaces SRTM's -32768: cells at exactly 0 m are nodata.
    let out = d.path().join("f.tif");
    ok(orogen().args([
        "slope",
        s(&dem),
        "--nodata",
        "0",
        "-o",
        s(&out),
        "-q",
        "--compress",
        "none",
    ]));
    let g = grid(&out);
    let zero = z.iter().filter(|&&v| v == 0).count();
    let nan = g.data().iter().filter(|v| v.is_nan()).count();
    // slope is nodata at the zero cells, their neighbours and the border
    assert!(
        zero > 100_000 && nan >= zero,
        "{zero} zero cells, {nan} nodata slopes"
    );
    for (i, &v) in z.iter().enumerate() {
        if v == 0 {
            assert!(g.data()[i].is_nan(), "cell {i} at 0 m has a slope");
        }
    }
    // An integer raster without nodata cannot take a sea level; a nodata
    // value its cells cannot hold is refused; both name the file and the fix
    // and write nothing.
    let u8_dem = data("gdal/uint8_strip_lzw_p2.tif");
    let bad = d.path().join("bad.tif");
    let e = fails(orogen().args(["fill", s(&u8_dem), "--sea-level", "3", "-o", s(&bad)]));
    assert!(
        e.contains("uint8_strip_lzw_p2.tif") && e.contains("--nodata"),
        "{e}"
    );
    let e = fails(orogen().args(["fill", s(&u8_dem), "--nodata", "-1", "-o", s(&bad)]));
    assert!(
        e.contains("uint8_strip_lzw_p2.tif") && e.contains("0..=255"),
        "{e}"
    );
    assert!(!bad.exists());
    // With a nodata value given, the sea level applies.
    ok(orogen().args([
        "fill",
        s(&u8_dem),
        "--nodata",
        "0",
        "--sea-level",
        "3",
        "-o",
        s(&bad),
        "-q",
    ]));
    let f = grid(&bad);
    let src = grid(&u8_dem);
    for (i, &v) in src.data().iter().enumerate() {
        if v <= 3.0 {
            assert!(f.data()[i].is_nan(), "cell {i} at {v} is not nodata");
        } else {
            assert!(f.data()[i] >= v, "cell {i}");
        }
    }
}

#[test]
fn a_mask_on_the_grid_masks_as_the_sea_level_does() {
    let dem = data("srtm/N43E007.hgt");
    let d = tempfile::tempdir().unwrap();
    // The mask: nodata exactly on the sea (the filled DEM read with --sea-level 0).
    let mask = d.path().join("land.tif");
    ok(orogen().args(["fill", s(&dem), "--sea-level", "0", "-o", s(&mask), "-q"]));
    let by_level = d.path().join("level.tif");
    let by_mask = d.path().join("mask.tif");
    ok(orogen().args([
        "flow",
        s(&dem),
        "--sea-level",
        "0",
        "-o",
        s(&by_level),
        "-q",
    ]));
    ok(orogen().args([
        "flow",
        s(&dem),
        "--mask",
        s(&mask),
        "-o",
        s(&by_mask),
        "-q",
        "--tile",
        "257",
    ]));
    assert!(
        same_bits(&grid(&by_level), &grid(&by_mask)),
        "--mask differs from --sea-level"
    );
    // a mask of another grid is refused, naming both sizes; nothing written
    let small = data("whitebox_DEM.tif");
    let bad = d.path().join("bad.tif");
    let e = fails(orogen().args(["flow", s(&dem), "--mask", s(&small), "-o", s(&bad)]));
    assert!(e.contains("237x188") && e.contains("1201x1201"), "{e}");
    assert!(!bad.exists());
}
