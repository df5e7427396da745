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
//!   nodata on invalid cells; TPI: refused (one error line) exactly when a
//!   value is beyond ±5e7 or infinite, else nodata on invalid cells and 0
//!   on a plane; erosion (never refused): invalid cells stay nodata, valid
//!   cells finite, the volume conserved, diffusion within the input's
//!   [min, max], and every cell equal to the model written out by hand in
//!   this file (FTCS diffusion, Musgrave's thermal weathering); peaks:
//!   finite elevations and prominences, never on an invalid cell (a DEM
//!   with ±inf is refused by orometry with one error).
//!   Closed forms where the input allows: on a plane the slope equals
//!   atan(|∇z|) (Horn's kernel is exact on planes) and erosion leaves the
//!   plane's interior as it was.

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
/// DEM as written (f64 values), `plane` an optional mask of the cells on a
/// plane z = c + a x + b y (sloping less than the thermal talus, 35°),
/// `gradient` its (a, b) when the slope is to be checked against it.
fn check_all(
    dir: &Path,
    input: &Path,
    z: &Grid<f64>,
    nodata: Option<f64>,
    plane: Option<&[bool]>,
    gradient: Option<(f64, f64)>,
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
    if let (Some(mask), Some((ga, gb))) = (plane, gradient) {
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

    // a descriptor: TPI refuses elevations beyond ±5e7 (the fixed-point
    // range of the windowed statistics), ±inf included (unlike slope, it does
    // not take ±inf for nodata), with one error naming the input and the
    // fix, and succeeds on everything else.
    let (ok, e) = run(&[
        "metric",
        inp,
        "--metric",
        "tpi:radius=2c",
        "-o",
        &s(&p("m")),
        "-q",
    ]);
    let beyond_windowed = (0..W * H).any(|k| {
        let v = z.data()[k] as f32 as f64;
        Some(z.data()[k]) != nodata && !v.is_nan() && v.abs() > 5e7
    });
    if beyond_windowed {
        assert!(
            !ok && e.contains(inp)
                && e.contains("rescale the input")
                && e.trim().lines().count() == 1,
            "metric on elevations beyond ±5e7: {e}"
        );
    } else {
        assert!(ok, "metric: {e}");
        let mut n = 0;
        for ent in std::fs::read_dir(p("m")).unwrap().flatten() {
            let g = read(&ent.path());
            no_inf(&g, "tpi");
            n += 1;
            for k in 0..W * H {
                if !valid[k] {
                    assert!(g.data()[k].is_nan(), "tpi at invalid cell {k}");
                }
            }
            // On a plane every window symmetric about its centre has the
            // centre's elevation as its mean: TPI = 0 where the radius-2
            // window lies on the plane.
            if let Some(mask) = plane {
                for (x, y) in interior(mask, 2) {
                    let (v, zc) = (g.data()[y * W + x], z.data()[y * W + x]);
                    assert!(
                        v.abs() <= 1e-6 * zc.abs().max(1.0),
                        "tpi ({x},{y}) on the plane = {v}"
                    );
                }
            }
        }
        assert!(n > 0, "metric wrote nothing");
    }

    // erosion: both models succeed on every input (nodata is a wall, not an
    // error) and are checked against their defining properties.
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
        assert!(ok, "erode {model}: {e}");
        check_erosion(model, z, &valid, plane, &read(&out));
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

/// Cells (x, y) whose (2r+1)² window lies inside the raster and on the plane.
fn interior(mask: &[bool], r: usize) -> Vec<(usize, usize)> {
    let mut v = Vec::new();
    for y in r..H - r {
        for x in r..W - r {
            if (y - r..=y + r).all(|yy| (x - r..=x + r).all(|xx| mask[yy * W + xx])) {
                v.push((x, y));
            }
        }
    }
    v
}

/// The CLI's default diffusion (D = 0.01 m²/yr, dt = 1000 yr) on 10 m cells
/// is one FTCS substep per step with rx = ry = D·dt/dx² = 0.1; `steps` of
/// h' = h + rx·Σ(h_n − h) over the 4-neighbours with data (a missing
/// neighbour contributes 0: zero-flux walls), written from the formula.
fn diffusion_by_hand(h: &[f64], steps: usize) -> Vec<f64> {
    let r = 0.01 * 1000.0 / (CELL * CELL);
    let mut h = h.to_vec();
    for _ in 0..steps {
        let mut n = h.clone();
        for y in 0..H as i64 {
            for x in 0..W as i64 {
                let i = (y * W as i64 + x) as usize;
                if !h[i].is_finite() {
                    continue;
                }
                let mut lap = 0.0;
                for (dx, dy) in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
                    let (nx, ny) = (x + dx, y + dy);
                    if nx >= 0 && ny >= 0 && nx < W as i64 && ny < H as i64 {
                        let hj = h[(ny * W as i64 + nx) as usize];
                        if hj.is_finite() {
                            lap += hj - h[i];
                        }
                    }
                }
                n[i] = h[i] + r * lap;
            }
        }
        h = n;
    }
    h
}

/// Musgrave et al. 1989 thermal weathering with the CLI's defaults (talus
/// 35°, rate 1/2), written from the paper: on the 8-neighbourhood the excess
/// towards n is e = (h − h_n) − tan(35°)·|offset|; a cell whose largest
/// excess is positive sends rate·max e, shared in proportion to the
/// positive excesses; all cells move at once. Edges and nodata are walls.
fn thermal_by_hand(h: &[f64], steps: usize) -> Vec<f64> {
    let t = 35f64.to_radians().tan();
    let mut h = h.to_vec();
    let at = |x: i64, y: i64| {
        (x >= 0 && y >= 0 && x < W as i64 && y < H as i64).then(|| (y * W as i64 + x) as usize)
    };
    for _ in 0..steps {
        let mut n = h.clone();
        for y in 0..H as i64 {
            for x in 0..W as i64 {
                let i = at(x, y).unwrap();
                if !h[i].is_finite() {
                    continue;
                }
                let mut ex = Vec::new();
                for dy in -1..=1i64 {
                    for dx in -1..=1i64 {
                        if let Some(j) = at(x + dx, y + dy) {
                            let l = CELL * ((dx * dx + dy * dy) as f64).sqrt();
                            let e = h[i] - h[j] - t * l;
                            if j != i && h[j].is_finite() && e > 0.0 {
                                ex.push((j, e));
                            }
                        }
                    }
                }
                let emax = ex.iter().map(|p| p.1).fold(0.0, f64::max);
                let esum: f64 = ex.iter().map(|p| p.1).sum();
                for (j, e) in ex {
                    let m = 0.5 * emax * e / esum;
                    n[i] -= m;
                    n[j] += m;
                }
            }
        }
        h = n;
    }
    h
}

/// Check `erode --model <model> --steps 3` (`out`) on the DEM `z` against
/// the model written by hand, and against the properties both models have
/// whatever their implementation: nodata stays nodata, the volume over the
/// cells with data is conserved (zero-flux walls), diffusion keeps every
/// value within the input's [min, max], and a plane below the talus far from anything else
/// does not move.
fn check_erosion(
    model: &str,
    z: &Grid<f64>,
    valid: &[bool],
    plane: Option<&[bool]>,
    out: &Grid<f64>,
) {
    no_inf(out, &format!("erode {model}"));
    let zin: Vec<f64> = (0..W * H)
        .map(|k| {
            if valid[k] {
                z.data()[k] as f32 as f64
            } else {
                f64::NAN
            }
        })
        .collect();
    let g = out.data();
    let scale = zin
        .iter()
        .filter(|v| v.is_finite())
        .fold(0.0f64, |m, v| m.max(v.abs()));
    let floor = 1e-12 * scale + 1e-44;
    for k in 0..W * H {
        if valid[k] {
            assert!(
                g[k].is_finite(),
                "erode {model}: valid cell {k} became {}",
                g[k]
            );
        } else {
            assert!(
                g[k].is_nan(),
                "erode {model}: invalid cell {k} got {}",
                g[k]
            );
        }
    }
    // Volume.
    let (mut vin, mut vout, mut vabs, mut n) = (0.0, 0.0, 0.0, 0.0);
    for k in (0..W * H).filter(|&k| valid[k]) {
        vin += zin[k];
        vout += g[k];
        vabs += zin[k].abs();
        n += 1.0;
    }
    assert!(
        (vout - vin).abs() <= 1e-6 * vabs + n * 1.5e-45,
        "erode {model}: volume {vin} became {vout}"
    );
    // Bounds: diffusion's update is a convex combination of the cell and its
    // neighbours (rx + ry <= 1/4), so no value leaves the input's [min, max].
    // (Thermal's is not: a pit between several higher neighbours receives
    // up to half of each excess at once and can rise above them.)
    if model == "diffusion" {
        let lo = zin
            .iter()
            .copied()
            .filter(|v| v.is_finite())
            .fold(f64::INFINITY, f64::min);
        let hi = zin
            .iter()
            .copied()
            .filter(|v| v.is_finite())
            .fold(f64::NEG_INFINITY, f64::max);
        let tol = 1e-6 * scale + 1e-44;
        for k in (0..W * H).filter(|&k| valid[k]) {
            assert!(
                g[k] >= lo - tol && g[k] <= hi + tol,
                "erode {model}: cell {k} = {} outside the input's [{lo}, {hi}]",
                g[k]
            );
        }
    }
    // The model by hand, cell by cell.
    let want = match model {
        "diffusion" => diffusion_by_hand(&zin, 3),
        _ => thermal_by_hand(&zin, 3),
    };
    for k in (0..W * H).filter(|&k| valid[k]) {
        assert!(
            (g[k] - want[k]).abs() <= 1e-6 * want[k].abs() + floor,
            "erode {model}: cell ({}, {}) = {}, by hand {}",
            k % W,
            k / W,
            g[k],
            want[k]
        );
    }
    // The plane: 3 steps reach 3 cells, so a cell whose radius-3 window is
    // plane (and inside the raster: the walls bend a plane) keeps its value.
    if let Some(mask) = plane {
        for (x, y) in interior(mask, 3) {
            let k = y * W + x;
            assert!(
                (g[k] - zin[k]).abs() <= 1e-6 * zin[k].abs() + floor,
                "erode {model}: plane cell ({x},{y}) moved from {} to {}",
                zin[k],
                g[k]
            );
        }
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
    check_all(
        tmp.path(),
        &p,
        &z,
        Some(-9999.0),
        Some(&mask),
        Some((0.5, 0.25)),
    );
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
    let mut mask = vec![true; W * H];
    mask[15 * W + 20] = false;
    check_all(tmp.path(), &p, &z, None, Some(&mask), None);
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
    check_all(&d, &p, &z, None, Some(&mask), Some((3.0, -2.0)));

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
    // (The plane slopes far beyond the talus: thermal moves it everywhere.)
    check_all(&d, &p, &z, None, None, None);
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
    check_all(&d, &p, &z, None, Some(&mask), None);
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
    check_all(tmp.path(), &p, &z, None, Some(&mask), None);
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
