//! Declared sinks (`orogen fill --sinks`, `orogen flow --sinks`): an
//! endorheic basin drains into its sink instead of filling to its spill
//! point.
//!
//! Oracles that share nothing with the flood: the filled surface by
//! relaxation to the fixed point W = max(z, min over the neighbours of W)
//! with the outlets (edge, cells beside nodata, sinks) held at their own
//! elevation (Planchon & Darboux 2001's definition of the depression-free
//! surface, iterated naively here); flow paths walked from every cell by
//! the oracle's own neighbour table; accumulation as the count of cells
//! whose walk reaches a cell. Tiled runs with odd tile sizes give the same
//! bytes.

use super::common::cli::{data, fails, ok, orogen, read_f32, s};
use super::NB;
use std::path::Path;

const NODATA: f32 = -9999.0;

/// Write an ESRI ASCII grid with lower-left corner (1000, 2000), 10 m cells.
fn write_asc(p: &Path, w: usize, h: usize, z: &[f32]) {
    let mut t = format!(
        "ncols {w}\nnrows {h}\nxllcorner 1000\nyllcorner 2000\ncellsize 10\nNODATA_value {NODATA}\n"
    );
    for y in 0..h {
        let row: Vec<String> = (0..w).map(|x| format!("{}", z[y * w + x])).collect();
        t += &row.join(" ");
        t += "\n";
    }
    std::fs::write(p, t).unwrap();
}

/// Map coordinates of the centre of cell (x, y) of the grid of [`write_asc`].
fn centre(x: usize, y: usize, h: usize) -> (f64, f64) {
    (
        1000.0 + 10.0 * x as f64 + 5.0,
        2000.0 + 10.0 * (h - y) as f64 - 5.0,
    )
}

/// The relaxation oracle: outlets keep z; every other valid cell is the
/// smallest level from which water reaches an outlet.
fn relaxed_fill(w: usize, h: usize, z: &[f32], sinks: &[usize]) -> Vec<f32> {
    let valid = |i: usize| z[i] != NODATA;
    let mut outlet = vec![false; w * h];
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            if !valid(i) {
                continue;
            }
            let edge = x == 0 || y == 0 || x + 1 == w || y + 1 == h;
            let by_void = NB.iter().any(|&(dx, dy)| {
                let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                nx >= 0
                    && ny >= 0
                    && (nx as usize) < w
                    && (ny as usize) < h
                    && !valid(ny as usize * w + nx as usize)
            });
            outlet[i] = edge || by_void || sinks.contains(&i);
        }
    }
    let mut wl: Vec<f32> = (0..w * h)
        .map(|i| {
            if outlet[i] || !valid(i) {
                z[i]
            } else {
                f32::INFINITY
            }
        })
        .collect();
    loop {
        let mut changed = false;
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                if outlet[i] || !valid(i) {
                    continue;
                }
                let mut lo = f32::INFINITY;
                for &(dx, dy) in &NB {
                    let n = (y as i64 + dy) as usize * w + (x as i64 + dx) as usize;
                    if valid(n) && wl[n] < lo {
                        lo = wl[n];
                    }
                }
                let v = z[i].max(lo);
                if v < wl[i] {
                    wl[i] = v;
                    changed = true;
                }
            }
        }
        if !changed {
            return wl;
        }
    }
}

/// A bowl 100 m deep around (20, 17) on a 43 x 37 grid, rough (a
/// deterministic hash adds up to 3 m), its rim lowest (spill point) on the
/// east side, with a void of 3 x 2 cells on the west slope.
fn bowl() -> (usize, usize, Vec<f32>) {
    let (w, h) = (43usize, 37usize);
    let mut z = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            let (dx, dy) = (x as f32 - 20.0, y as f32 - 17.0);
            let r = (dx * dx + dy * dy).sqrt();
            let hash = ((x * 7919 + y * 104729) % 31) as f32 / 10.0;
            let east = if dx > 0.0 { -0.8 * dx } else { 0.0 };
            z.push(300.0 + 5.0 * r.min(18.0) + east + hash);
        }
    }
    for y in 15..17 {
        for x in 8..11 {
            z[y * w + x] = NODATA;
        }
    }
    (w, h, z)
}

#[test]
fn a_declared_sink_keeps_its_basin_unfilled_and_drains_it() {
    let t = tempfile::tempdir().unwrap();
    let (w, h, z) = bowl();
    let dem = t.path().join("bowl.asc");
    write_asc(&dem, w, h, &z);
    // The sink on the bowl's slope, 4 cells east of its bottom: the fill
    // leaves a lake at the sink's level below it, a flat whose only way
    // out is the sink.
    let sink = 17 * w + 24;
    let (sx, sy) = centre(24, 17, h);
    let csv = t.path().join("sinks.csv");
    std::fs::write(&csv, format!("x,y,name\n{sx},{sy},centre\n")).unwrap();

    // Without the sink the bowl fills to its spill point; with it, to the
    // relaxation's surface, for any tiling.
    let plain = t.path().join("plain.tif");
    ok(orogen().args(["fill", s(&dem), "-o", s(&plain), "-q"]));
    let spill_filled = read_f32(&plain);
    let want_plain = relaxed_fill(w, h, &z, &[]);
    let want = relaxed_fill(w, h, &z, &[sink]);
    let as_nan = |v: f32| if v == NODATA { f32::NAN } else { v };
    for (i, &wp) in want_plain.iter().enumerate() {
        assert_eq!(
            spill_filled.data()[i].to_bits(),
            as_nan(wp).to_bits(),
            "plain cell {i}"
        );
    }
    assert!(
        want_plain[sink] > z[sink] + 20.0,
        "the bowl is a real depression: {} over {}",
        want_plain[sink],
        z[sink]
    );
    assert_eq!(want[sink], z[sink]);
    let lake = (0..w * h).filter(|&i| want[i] > z[i]).count();
    assert!(lake >= 20, "{lake} cells under the lake");
    for tile in [None, Some("7"), Some("13")] {
        let out = t.path().join(format!("f{tile:?}.tif"));
        let mut c = orogen();
        c.args(["fill", s(&dem), "--sinks", s(&csv), "-o", s(&out), "-q"]);
        if let Some(k) = tile {
            c.args(["--tile", k]);
        }
        ok(&mut c);
        let got = read_f32(&out);
        for (i, &wv) in want.iter().enumerate() {
            assert_eq!(
                got.data()[i].to_bits(),
                as_nan(wv).to_bits(),
                "tile {tile:?} cell {i}"
            );
        }
    }
    // A raster of sinks on the DEM's grid gives the same bytes as the point.
    let mask = t.path().join("sinks.asc");
    let m: Vec<f32> = (0..w * h)
        .map(|i| if i == sink { 1.0 } else { 0.0 })
        .collect();
    write_asc(&mask, w, h, &m);
    let via_mask = t.path().join("m.tif");
    ok(orogen().args([
        "fill",
        s(&dem),
        "--sinks",
        s(&mask),
        "-o",
        s(&via_mask),
        "-q",
    ]));
    let same = read_f32(&via_mask)
        .data()
        .iter()
        .map(|v| v.to_bits())
        .collect::<Vec<_>>()
        == read_f32(&t.path().join("fNone.tif"))
            .data()
            .iter()
            .map(|v| v.to_bits())
            .collect::<Vec<_>>();
    assert!(same, "a sink raster and the same sink as a point differ");

    // Flow: the sink has no flow, every path of the bowl ends in it, the
    // flats the fill left drain into it; accumulation at the sink counts
    // them, for any tiling.
    let filled = t.path().join("fNone.tif");
    let mut d8s = Vec::new();
    for tile in ["1024", "5", "11"] {
        let d8 = t.path().join(format!("d8_{tile}.tif"));
        ok(orogen().args([
            "flow",
            s(&filled),
            "--sinks",
            s(&csv),
            "-o",
            s(&d8),
            "--tile",
            tile,
            "-q",
        ]));
        let acc = t.path().join(format!("acc_{tile}.tif"));
        ok(orogen().args(["accumulate", s(&d8), "-o", s(&acc), "--tile", tile, "-q"]));
        d8s.push((read_f32(&d8), read_f32(&acc)));
    }
    let bits =
        |g: &orogen::raster::Grid<f32>| g.data().iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    for (d, a) in &d8s[1..] {
        assert!(
            bits(d) == bits(&d8s[0].0),
            "directions differ across tilings"
        );
        assert!(
            bits(a) == bits(&d8s[0].1),
            "accumulation differs across tilings"
        );
    }
    let (d8, acc) = &d8s[0];
    assert_eq!(d8.data()[sink], 0.0);
    let stops = |d: &orogen::raster::Grid<f32>| (0..w * h).filter(|&i| d.data()[i] == 0.0).count();
    assert_eq!(stops(d8), 1, "only the sink stops the flow");
    // Without --sinks the lake is a flat with no way out.
    let blind = t.path().join("d8_blind.tif");
    ok(orogen().args(["flow", s(&filled), "-o", s(&blind), "-q"]));
    let blind_stops = stops(&read_f32(&blind));
    assert!(blind_stops > 10, "{blind_stops} stops, {lake} lake cells");
    // Walk every valid cell's path with the oracle's table.
    let mut reach = vec![0u32; w * h];
    let mut into_sink = 0;
    for start in 0..w * h {
        if z[start] == NODATA {
            continue;
        }
        let mut c = start;
        let mut steps = 0;
        loop {
            reach[c] += 1;
            let code = d8.data()[c] as u32;
            if code == 0 {
                break;
            }
            let k = code.trailing_zeros() as usize;
            assert_eq!(1 << k, code, "cell {c}: code {code}");
            let (x, y) = ((c % w) as i64 + NB[k].0, (c / w) as i64 + NB[k].1);
            if x < 0
                || y < 0
                || x >= w as i64
                || y >= h as i64
                || z[y as usize * w + x as usize] == NODATA
            {
                break;
            }
            c = y as usize * w + x as usize;
            steps += 1;
            assert!(steps <= w * h, "cycle from {start}");
        }
        if c == sink {
            into_sink += 1;
        }
    }
    for i in 0..w * h {
        if z[i] != NODATA {
            assert_eq!(acc.data()[i], reach[i] as f32, "accumulation at {i}");
        }
    }
    // Every cell below the spill level drains to the sink (the basin of a
    // bowl whose rim is higher than its inside everywhere it is filled).
    let below_spill = (0..w * h)
        .filter(|&i| z[i] != NODATA && want_plain[i] > z[i])
        .count();
    assert!(
        into_sink >= below_spill,
        "{into_sink} cells reach the sink, {below_spill} lie below the spill level"
    );
    assert!(into_sink > 300, "{into_sink}");
}

#[test]
fn sinks_on_a_real_dem_leave_their_depression_as_it_is() {
    // The Big Tujunga crop (SRTM 30 m, UTM 11N): its deepest depression's
    // lowest cell declared a sink (found here from the oracle's fill).
    let t = tempfile::tempdir().unwrap();
    let dem = data("bigtujunga_crop.tif");
    let g = read_f32(&dem);
    let (w, h) = (g.width(), g.height());
    let z: Vec<f32> = g
        .data()
        .iter()
        .map(|&v| if v.is_nan() { NODATA } else { v })
        .collect();
    let plain = relaxed_fill(w, h, &z, &[]);
    let deepest = (0..w * h)
        .max_by(|&a, &b| (plain[a] - z[a]).total_cmp(&(plain[b] - z[b])))
        .unwrap();
    assert!(
        plain[deepest] - z[deepest] > 1.0,
        "the crop has a depression"
    );
    let src = orogen::io::open_raster(&dem, &Default::default()).unwrap();
    let gt = src.info().georef.transform;
    let (x, y) = (deepest % w, deepest / w);
    let (mx, my) = (
        gt[0] + (x as f64 + 0.5) * gt[1],
        gt[3] + (y as f64 + 0.5) * gt[5],
    );
    let csv = t.path().join("s.csv");
    std::fs::write(&csv, format!("x,y\n{mx},{my}\n")).unwrap();
    let out = t.path().join("f.tif");
    ok(orogen().args([
        "fill",
        s(&dem),
        "--sinks",
        s(&csv),
        "-o",
        s(&out),
        "--tile",
        "37",
        "-q",
    ]));
    let want = relaxed_fill(w, h, &z, &[deepest]);
    let got = read_f32(&out);
    assert_eq!(got.data()[deepest], z[deepest]);
    for (i, &wv) in want.iter().enumerate() {
        assert_eq!(got.data()[i], wv, "cell {i}");
    }
}

#[test]
fn bad_sinks_are_refused_naming_the_file() {
    let t = tempfile::tempdir().unwrap();
    let (w, h, z) = bowl();
    let dem = t.path().join("bowl.asc");
    write_asc(&dem, w, h, &z);
    let csv = t.path().join("far.csv");
    std::fs::write(&csv, "x,y\n5000,5000\n").unwrap();
    let out = t.path().join("o.tif");
    let e = fails(orogen().args(["fill", s(&dem), "--sinks", s(&csv), "-o", s(&out)]));
    assert!(e.contains("far.csv") && e.contains("lies outside"), "{e}");
    assert!(!out.exists());
    let small = t.path().join("small.asc");
    write_asc(&small, 5, 5, &[0.0; 25]);
    let e = fails(orogen().args(["fill", s(&dem), "--sinks", s(&small), "-o", s(&out)]));
    assert!(
        e.contains("small.asc") && e.contains("5x5") && e.contains("input's grid"),
        "{e}"
    );
    assert!(!out.exists());
    let e = fails(orogen().args([
        "flow",
        s(&dem),
        "--sinks",
        s(&csv.with_file_name("none.csv")),
        "--method",
        "rho8",
        "-o",
        s(&out),
    ]));
    assert!(e.contains("D8 only"), "{e}");
}
