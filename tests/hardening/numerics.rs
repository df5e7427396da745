//! Numerics (issue 12): NaN, ±inf, declared nodata, subnormals, huge and
//! negative elevations, and f64 DEMs with values beyond the f32 range, through
//! fill, flow, accumulation, peaks, slope, a descriptor (TPI) and erosion
//! (diffusion and thermal), run as a user runs them (the binary on GeoTIFFs).
//!
//! The defined behaviour checked for every case:
//! - no command panics; each either succeeds or fails with one error line;
//! - no float output holds ±inf (NaN/nodata marks what has no value);
//! - a cell is *valid* iff its value is finite once read as f32 and is not
//!   the declared nodata (f64 values beyond ±f32::MAX read as ±inf, hence
//!   nodata: orogen's hydrology and terrain steps work in f32);
//! - fill: valid cells stay valid and are never lowered, invalid cells are
//!   nodata; flow: invalid cells get 255, valid ones an ESRI code or 0;
//!   accumulation: ≥ 1 on valid cells; slope: within [0°, 90°] or nodata,
//!   nodata on invalid cells; erosion: invalid cells stay nodata, valid
//!   cells finite; peaks: finite elevations and prominences, never on an
//!   invalid cell (a DEM with ±inf is refused by orometry with one error).
//!   Closed forms where the input allows: on a plane the slope equals
//!   atan(|∇z|) (Horn's kernel is exact on planes).

// Cell loops index the input, the validity mask and an output together.
#![allow(clippy::needless_range_loop)]

use orogen::io::geotiff::{write_geotiff, WriteOptions};
use orogen::raster::{read_window, AnyGrid, Crs, GeoRef, Grid, Window};
use std::path::{Path, PathBuf};
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_orogen");
const W: usize = 40;
const H: usize = 30;
const CELL: f64 = 10.0;

fn georef(nodata: Option<f64>) -> GeoRef {
    GeoRef::north_up(500000.0, 4000000.0, CELL, Crs::projected(32611)).with_nodata(nodata)
}

/// Run the binary; returns (success, stderr). Fails the test on a panic.
fn run(args: &[&str]) -> (bool, String) {
    let o = Command::new(BIN).args(args).output().unwrap();
    let e = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(
        !e.contains("panicked") && !e.contains("RUST_BACKTRACE"),
        "orogen {args:?} panicked: {e}"
    );
    (o.status.success(), e)
}

/// A raster as f64 (nodata -> NaN).
fn read(p: &Path) -> Grid<f64> {
    let src = orogen::io::open_raster(p, &orogen::io::OpenOptions::default()).unwrap();
    let i = src.info();
    read_window::<f64>(src.as_ref(), Window::full(i.width, i.height)).unwrap()
}

fn no_inf(g: &Grid<f64>, what: &str) {
    if let Some(k) = g.data().iter().position(|v| v.is_infinite()) {
        panic!("{what}: ±inf at cell {k}");
    }
}

/// Validity of each cell as orogen's f32 steps see it.
fn valid_mask(g: &Grid<f64>, nodata: Option<f64>) -> Vec<bool> {
    g.data()
        .iter()
        .map(|&v| (v as f32).is_finite() && Some(v) != nodata)
        .collect()
}

/// Run every step on `input` and check the defined behaviour. `z` is the
/// DEM as written (f64 values), `plane` an optional (a, b) such that cells
/// at least 2 away from any invalid or non-planar cell have z = c + a x + b y.
fn check_all(
    dir: &Path,
    input: &Path,
    z: &Grid<f64>,
    nodata: Option<f64>,
    plane_mask: Option<(&[bool], f64, f64)>,
) {
    let valid = valid_mask(z, nodata);
    let p = |n: &str| dir.join(n);
    let s = |p: &PathBuf| p.to_str().unwrap().to_string();
    let inp = input.to_str().unwrap();

    // fill
    let (ok, e) = run(&["fill", inp, "-o", &s(&p("fill.tif")), "-q"]);
    assert!(ok, "fill: {e}");
    let f = read(&p("fill.tif"));
    no_inf(&f, "fill");
    for k in 0..W * H {
        if valid[k] {
            let zin = z.data()[k] as f32 as f64;
            assert!(f.data()[k].is_finite(), "fill: valid cell {k} lost");
            assert!(
                f.data()[k] >= zin,
                "fill lowered cell {k}: {} < {zin}",
                f.data()[k]
            );
        } else {
            assert!(
                f.data()[k].is_nan(),
                "fill: invalid cell {k} got {}",
                f.data()[k]
            );
        }
    }

    // flow from the filled DEM, then accumulation
    let (ok, e) = run(&["flow", &s(&p("fill.tif")), "-o", &s(&p("d8.tif")), "-q"]);
    assert!(ok, "flow: {e}");
    let d = read(&p("d8.tif"));
    for k in 0..W * H {
        let c = d.data()[k];
        if valid[k] {
            assert!(
                [0.0, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0, 128.0].contains(&c),
                "flow: cell {k} code {c}"
            );
        } else {
            assert!(c.is_nan(), "flow: invalid cell {k} code {c}");
        }
    }
    let (ok, e) = run(&[
        "accumulate",
        &s(&p("d8.tif")),
        "-o",
        &s(&p("acc.tif")),
        "-q",
    ]);
    assert!(ok, "accumulate: {e}");
    let a = read(&p("acc.tif"));
    no_inf(&a, "accumulate");
    for k in 0..W * H {
        if valid[k] {
            assert!(a.data()[k] >= 1.0, "accumulate: cell {k} = {}", a.data()[k]);
        }
    }
    let total_valid = valid.iter().filter(|&&v| v).count() as f64;
    assert!(a.data().iter().all(|v| v.is_nan() || *v <= total_valid));

    // slope
    let (ok, e) = run(&["slope", inp, "-o", &s(&p("slope.tif")), "-q"]);
    assert!(ok, "slope: {e}");
    let sl = read(&p("slope.tif"));
    no_inf(&sl, "slope");
    for k in 0..W * H {
        let v = sl.data()[k];
        assert!(v.is_nan() || (0.0..=90.0).contains(&v), "slope {k}: {v}");
        if !valid[k] {
            assert!(v.is_nan(), "slope at invalid cell {k}: {v}");
        }
    }
    if let Some((mask, ga, gb)) = plane_mask {
        let want = ((ga * ga + gb * gb).sqrt() / CELL).atan().to_degrees();
        let mut n = 0;
        for y in 1..H - 1 {
            for x in 1..W - 1 {
                let all = (0..9).all(|i| mask[(y + i / 3 - 1) * W + x + i % 3 - 1]);
                if all {
                    let v = sl.data()[y * W + x];
                    assert!(
                        (v - want).abs() < 1e-3,
                        "slope ({x},{y}) {v}, plane gives {want}"
                    );
                    n += 1;
                }
            }
        }
        assert!(n > 100, "too few plane cells checked ({n})");
    }

    // a descriptor
    let (ok, e) = run(&[
        "metric",
        inp,
        "--metric",
        "tpi:radius=2c",
        "-o",
        &s(&p("m")),
        "-q",
    ]);
    if !ok {
        // The windowed statistics refuse elevations beyond ±5e7 (their
        // fixed-point range): one error naming the input and the fix.
        assert!(
            e.contains(inp) && e.contains("rescale the input") && e.trim().lines().count() == 1,
            "metric: {e}"
        );
    }
    for ent in std::fs::read_dir(p("m")).into_iter().flatten().flatten() {
        let g = read(&ent.path());
        no_inf(&g, "tpi");
        for k in 0..W * H {
            if !valid[k] {
                assert!(g.data()[k].is_nan(), "tpi at invalid cell {k}");
            }
        }
    }

    // erosion
    for model in ["diffusion", "thermal"] {
        let out = p(&format!("e_{model}.tif"));
        let (ok, e) = run(&[
            "erode",
            inp,
            "--model",
            model,
            "--steps",
            "3",
            "-o",
            &s(&out),
            "-q",
        ]);
        if !ok {
            // A refusal is defined behaviour only as one clear error line.
            assert!(
                e.trim().lines().count() <= 3 && e.contains("error"),
                "erode {model}: {e}"
            );
            continue;
        }
        let g = read(&out);
        no_inf(&g, &format!("erode {model}"));
        for k in 0..W * H {
            if valid[k] {
                assert!(
                    g.data()[k].is_finite(),
                    "erode {model}: valid cell {k} became {}",
                    g.data()[k]
                );
            } else {
                assert!(
                    g.data()[k].is_nan(),
                    "erode {model}: invalid cell {k} got {}",
                    g.data()[k]
                );
            }
        }
    }

    // peaks
    let (ok, e) = run(&[
        "peaks",
        inp,
        "-o",
        &s(&p("peaks")),
        "--min-prominence",
        "0",
        "-q",
    ]);
    let has_inf = z.data().iter().any(|v| (*v as f32).is_infinite());
    if has_inf {
        // Orometry refuses ±inf (rather than treating it as nodata): one
        // error naming the cell, and no output.
        assert!(
            !ok && e.contains("must be finite") && e.trim().lines().count() == 1,
            "peaks: {e}"
        );
        assert!(!p("peaks/peaks.csv").exists());
        return;
    }
    assert!(ok, "peaks: {e}");
    let csv = std::fs::read_to_string(p("peaks/peaks.csv")).unwrap();
    for line in csv.lines().skip(1) {
        let c: Vec<&str> = line.split(',').collect();
        let (elev, prom): (f64, f64) = (c[2].parse().unwrap(), c[3].parse().unwrap());
        assert!(
            elev.is_finite() && prom.is_finite() && prom >= 0.0,
            "peaks: {line}"
        );
        let (col, row): (usize, usize) = (c[9].parse().unwrap(), c[10].parse().unwrap());
        assert!(valid[row * W + col], "peak on an invalid cell: {line}");
    }
}

fn write_f32(path: &Path, z: &Grid<f64>, nodata: Option<f64>) {
    let g = z.map(|v| v as f32);
    write_geotiff(
        path,
        &AnyGrid::F32(g),
        &georef(nodata),
        &WriteOptions::default(),
    )
    .unwrap();
}

fn write_f64(path: &Path, z: &Grid<f64>, nodata: Option<f64>) {
    write_geotiff(
        path,
        &AnyGrid::F64(z.clone()),
        &georef(nodata),
        &WriteOptions::default(),
    )
    .unwrap();
}

/// A plane with two hills and a pit; `mask` marks the cells on the plane.
fn terrain(c: f64, a: f64, b: f64, scale: f64) -> (Grid<f64>, Vec<bool>) {
    let mut mask = vec![true; W * H];
    let g = Grid::from_fn(W, H, |x, y| {
        let mut v = c + a * x as f64 + b * y as f64;
        for (hx, hy, amp) in [(8.0, 22.0, 30.0), (32.0, 8.0, 20.0), (30.0, 24.0, -25.0)] {
            let r2 = (x as f64 - hx).powi(2) + (y as f64 - hy).powi(2);
            if r2 < 16.0 {
                v += amp * scale * (1.0 - r2 / 16.0);
                mask[y * W + x] = false;
            }
        }
        v
    });
    (g, mask)
}

fn poke(z: &mut Grid<f64>, mask: &mut [bool], cells: &[(usize, usize, f64)]) {
    for &(x, y, v) in cells {
        z.set(x, y, v);
        mask[y * W + x] = false;
    }
}

#[test]
fn nan_infinities_and_declared_nodata() {
    let tmp = tempfile::tempdir().unwrap();
    let (mut z, mut mask) = terrain(100.0, 0.5, 0.25, 1.0);
    poke(
        &mut z,
        &mut mask,
        &[
            (5, 5, f64::NAN),
            (12, 7, f64::INFINITY),
            (20, 10, f64::NEG_INFINITY),
            (25, 15, -9999.0),
            (0, 0, f64::NAN),
            (39, 29, f64::INFINITY),
        ],
    );
    let p = tmp.path().join("in.tif");
    write_f32(&p, &z, Some(-9999.0));
    check_all(tmp.path(), &p, &z, Some(-9999.0), Some((&mask, 0.5, 0.25)));
}

#[test]
fn subnormal_elevations() {
    let tmp = tempfile::tempdir().unwrap();
    // Every value subnormal in f32 (below 1.18e-38), with a pit in the middle.
    let z = Grid::from_fn(W, H, |x, y| {
        let v = (x + y) as f64 * 1e-41;
        if (x, y) == (20, 15) {
            0.0
        } else {
            v
        }
    });
    assert!(z
        .data()
        .iter()
        .all(|v| (*v as f32) == 0.0 || !(*v as f32).is_normal()));
    let p = tmp.path().join("in.tif");
    write_f32(&p, &z, None);
    check_all(tmp.path(), &p, &z, None, None);
    // The plane's slope is below any f32 resolution: exactly 0 or tiny.
    let sl = read(&tmp.path().join("slope.tif"));
    assert!(sl.data().iter().all(|v| v.is_nan() || *v < 1e-30));
}

#[test]
fn huge_and_negative_elevations() {
    let tmp = tempfile::tempdir().unwrap();
    // Bathymetry: a tilted sea floor around -10500 m with hills and a trench
    // (avoiding -9999, the fill output's nodata).
    let (z, mask) = terrain(-10500.0, 3.0, -2.0, 10.0);
    let d = tmp.path().join("neg");
    std::fs::create_dir(&d).unwrap();
    let p = d.join("in.tif");
    write_f32(&p, &z, None);
    check_all(&d, &p, &z, None, Some((&mask, 3.0, -2.0)));

    // Elevations near ±f32::MAX: differences overflow f32.
    let (mut z, mut mask) = terrain(1e37, 1e35, 5e34, 1e36);
    poke(
        &mut z,
        &mut mask,
        &[
            (3, 3, f32::MAX as f64),
            (30, 3, -(f32::MAX as f64)),
            (10, 27, -1e38),
        ],
    );
    let d = tmp.path().join("huge");
    std::fs::create_dir(&d).unwrap();
    let p = d.join("in.tif");
    write_f32(&p, &z, None);
    check_all(&d, &p, &z, None, None);
}

#[test]
fn bathymetry_holding_the_old_fill_nodata_stays_data() {
    // Regression (session 5): fill and breach wrote nodata -9999, so a DEM
    // without nodata holding -9999 as a real depth lost those cells. The
    // output nodata is now chosen below the data (-99999 here).
    let tmp = tempfile::tempdir().unwrap();
    let (mut z, mut mask) = terrain(-9000.0, 3.0, -2.0, 10.0);
    poke(
        &mut z,
        &mut mask,
        &[(5, 5, -9999.0), (20, 12, -9999.0), (33, 25, -10_994.0)],
    );
    let d = tmp.path().join("b");
    std::fs::create_dir(&d).unwrap();
    let p = d.join("in.tif");
    write_f32(&p, &z, None);
    check_all(&d, &p, &z, None, None);
    let inp = p.to_str().unwrap();
    let nodata_of = |p: &Path| {
        orogen::io::open_raster(p, &orogen::io::OpenOptions::default())
            .unwrap()
            .info()
            .georef
            .nodata
    };
    assert_eq!(nodata_of(&d.join("fill.tif")), Some(-99_999.0));
    let outs: [(&str, Vec<&str>); 4] = [
        ("fe.tif", vec!["fill-epsilon"]),
        ("br.tif", vec!["breach"]),
        ("brl.tif", vec!["breach", "--method", "least-cost"]),
        ("fill.tiles", vec!["fill"]),
    ];
    for (name, cmd) in outs {
        let o = d.join(name);
        let mut args = cmd.clone();
        args.extend([inp, "-o", o.to_str().unwrap(), "-q"]);
        let (ok, e) = run(&args);
        assert!(ok, "{args:?}: {e}");
        let g = read(&o);
        for k in 0..W * H {
            assert!(
                g.data()[k].is_finite(),
                "{args:?}: real cell {k} ({}) became nodata",
                z.data()[k]
            );
        }
        assert_eq!(nodata_of(&o), Some(-99_999.0), "{args:?}");
    }
}

#[test]
fn f64_beyond_the_f32_range() {
    let tmp = tempfile::tempdir().unwrap();
    let (mut z, mut mask) = terrain(2000.0, -1.0, 2.0, 1.0);
    poke(
        &mut z,
        &mut mask,
        &[
            (6, 6, 1e300),
            (14, 20, -1e300),
            (22, 4, 4e38),
            (35, 12, f64::NAN),
            // f64 subnormal: reads as 0.0 in f32, a valid (low) cell.
            (18, 18, 1e-320),
        ],
    );
    let p = tmp.path().join("in.tif");
    write_f64(&p, &z, None);
    check_all(tmp.path(), &p, &z, None, None);
    // The f64 input itself is read back exactly (no silent f32 rounding in I/O).
    let back = read(&p);
    for k in 0..W * H {
        let (a, b) = (back.data()[k], z.data()[k]);
        assert!(
            a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()),
            "cell {k}"
        );
    }
}
