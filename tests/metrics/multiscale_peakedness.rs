//! Deng & Wilson multi-scale peakedness (`peakedness_dw`) and peak
//! prototypicality against a brute-force oracle written from the definition
//! (direct loops over every window, no shared code), tiled == untiled bit for
//! bit, bad parameters, the CLI; and tiled == untiled for EVERY metric of the
//! registry at several tile sizes.

#![allow(clippy::needless_range_loop)] // index loops read like the definitions

use orogen::exec::EngineConfig;
use orogen::metrics::peak_dw::{self, run_to_memory};
use orogen::metrics::registry::{MetricKind, METRICS};
use orogen::metrics::{parse_specs, MetricSpec};
use orogen::raster::{MemRaster, RasterSource, TileLayout};

use crate::common::cli::{ok, orogen};
use crate::common::{check_abs as check, run, source, Rng, CELL};

/// Hills (Gaussian bumps of 60..400 m) plus noise, with nodata holes.
fn hills(w: usize, h: usize, seed: u64, holes: f64) -> Vec<f32> {
    let mut rng = Rng(seed);
    let bumps: Vec<(f64, f64, f64, f64)> = (0..9)
        .map(|_| {
            (
                rng.unit() * w as f64,
                rng.unit() * h as f64,
                60.0 + 340.0 * rng.unit(),
                3.0 + 12.0 * rng.unit(),
            )
        })
        .collect();
    (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f64, (i / w) as f64);
            if rng.unit() < holes {
                return f32::NAN;
            }
            let mut z = 100.0 + 6.0 * rng.unit();
            for &(bx, by, a, s) in &bumps {
                z += a * (-((x - bx).powi(2) + (y - by).powi(2)) / (2.0 * s * s)).exp();
            }
            z as f32
        })
        .collect()
}

const SCALES: [usize; 3] = [5, 20, 50];
const RELIEF: [f64; 3] = [20.0, 80.0, 80.0];
const WEIGHTS: [f64; 3] = [1.0, 1.2, 1.4];

/// The definition evaluated directly: `(prototypicality, similarity)`.
fn oracle(d: &[f32], w: usize, h: usize, top: f64) -> (Vec<f64>, Vec<f64>) {
    let z: Vec<f64> = d.iter().map(|&v| v as f64).collect();
    let at = |x: i64, y: i64| -> f64 {
        if x < 0 || y < 0 || x >= w as i64 || y >= h as i64 {
            f64::NAN
        } else {
            z[y as usize * w + x as usize]
        }
    };
    // Horn gradient norm where the 3x3 window is complete (centre included).
    let mut slope = vec![f64::NAN; w * h];
    for y in 0..h as i64 {
        for x in 0..w as i64 {
            let n = |dx: i64, dy: i64| at(x + dx, y + dy);
            let gx = ((n(1, -1) + 2.0 * n(1, 0) + n(1, 1))
                - (n(-1, -1) + 2.0 * n(-1, 0) + n(-1, 1)))
                / (8.0 * CELL);
            let gy = ((n(-1, 1) + 2.0 * n(0, 1) + n(1, 1))
                - (n(-1, -1) + 2.0 * n(0, -1) + n(1, -1)))
                / (8.0 * CELL);
            // A nodata cell has no slope (Horn's stencil skips the centre).
            if !at(x, y).is_nan() {
                slope[y as usize * w + x as usize] = (gx * gx + gy * gy).sqrt();
            }
        }
    }
    // Window statistics over the valid cells of the square of half-side r.
    let stat = |g: &[f64], x: usize, y: usize, r: usize| -> (f64, f64, f64, usize) {
        let (mut mx, mut mn, mut s, mut n) = (f64::NEG_INFINITY, f64::INFINITY, 0.0, 0);
        for yy in y.saturating_sub(r)..(y + r + 1).min(h) {
            for xx in x.saturating_sub(r)..(x + r + 1).min(w) {
                let v = g[yy * w + xx];
                if !v.is_nan() {
                    mx = mx.max(v);
                    mn = mn.min(v);
                    s += v;
                    n += 1;
                }
            }
        }
        (mx, mn, s, n)
    };
    // The cells with a value: (column, row, value).
    let valid_cells = || {
        (0..w * h)
            .map(|i| (i % w, i / w, z[i]))
            .filter(|c| !c.2.is_nan())
    };
    let mut proto = vec![0.0; w * h];
    let mut sim = vec![0.0; w * h];
    let mut valid = vec![true; w * h];
    let mut sim_w = 0.0;
    for si in 0..3 {
        let r = SCALES[si];
        let e = 3 * r;
        let mut is_peak = vec![false; w * h];
        for (x, y, v) in valid_cells() {
            let (mx, mn, _, _) = stat(&z, x, y, r);
            is_peak[y * w + x] = v == mx && mx - mn > RELIEF[si];
        }
        let mut f: Vec<Option<[f64; 4]>> = vec![None; w * h];
        for (x, y, v) in valid_cells() {
            let (mx, mn, _, _) = stat(&z, x, y, r);
            let (_, _, ss, sn) = stat(&slope, x, y, r);
            let (ex, en, _, _) = stat(&z, x, y, e);
            let mut peaks = 0;
            for yy in y.saturating_sub(e)..(y + e + 1).min(h) {
                for xx in x.saturating_sub(e)..(x + e + 1).min(w) {
                    peaks += is_peak[yy * w + xx] as usize;
                }
            }
            if sn == 0 {
                continue;
            }
            let rel = if ex > en { (v - en) / (ex - en) } else { 0.0 };
            f[y * w + x] = Some([mx - mn, ss / sn as f64, rel, 1.0 / (1.0 + peaks as f64)]);
        }
        let (mut lo, mut hi) = ([f64::INFINITY; 4], [f64::NEG_INFINITY; 4]);
        for v in f.iter().flatten() {
            for k in 0..4 {
                lo[k] = lo[k].min(v[k]);
                hi[k] = hi[k].max(v[k]);
            }
        }
        let pr = |v: &[f64; 4]| -> f64 {
            (0..4)
                .map(|k| {
                    if hi[k] > lo[k] {
                        (v[k] - lo[k]) / (hi[k] - lo[k])
                    } else {
                        1.0
                    }
                })
                .sum::<f64>()
                / 4.0
        };
        for i in 0..w * h {
            match &f[i] {
                Some(v) => proto[i] += WEIGHTS[si] * pr(v),
                None => valid[i] = false,
            }
        }
        // Peaks (valid factors), by index.
        let peaks: Vec<(usize, [f64; 4])> = (0..w * h)
            .filter(|&i| is_peak[i])
            .filter_map(|i| f[i].map(|v| (i, v)))
            .collect();
        if peaks.is_empty() {
            continue;
        }
        let n = peaks.len() as f64;
        let mut var = [0.0; 4];
        for k in 0..4 {
            let m: f64 = peaks.iter().map(|p| p.1[k]).sum::<f64>() / n;
            var[k] = peaks
                .iter()
                .map(|p| (p.1[k] - m) * (p.1[k] - m))
                .sum::<f64>()
                / n;
        }
        let mut order: Vec<(f64, usize, [f64; 4])> =
            peaks.iter().map(|p| (pr(&p.1), p.0, p.1)).collect();
        order.sort_by(|a, b| b.0.partial_cmp(&a.0).unwrap().then(b.1.cmp(&a.1)));
        let nc = ((n * top).floor() as usize).max(1);
        let mut c = [0.0; 4];
        for o in &order[..nc] {
            for k in 0..4 {
                c[k] += o.2[k];
            }
        }
        for v in c.iter_mut() {
            *v /= nc as f64;
        }
        let dist: Vec<f64> = f
            .iter()
            .map(|v| match v {
                None => f64::NAN,
                Some(v) => (0..4)
                    .filter(|&k| var[k] > 0.0)
                    .map(|k| (v[k] - c[k]).powi(2) / var[k])
                    .sum::<f64>()
                    .sqrt(),
            })
            .collect();
        let dmin = dist
            .iter()
            .filter(|d| !d.is_nan())
            .fold(f64::INFINITY, |a, &b| a.min(b));
        let dmax = dist
            .iter()
            .filter(|d| !d.is_nan())
            .fold(f64::NEG_INFINITY, |a, &b| a.max(b));
        for i in 0..w * h {
            if !dist[i].is_nan() {
                sim[i] += WEIGHTS[si]
                    * if dmax > dmin {
                        (dmax - dist[i]) / (dmax - dmin)
                    } else {
                        1.0
                    };
            }
        }
        sim_w += WEIGHTS[si];
    }
    for i in 0..w * h {
        if !valid[i] {
            proto[i] = f64::NAN;
            sim[i] = f64::NAN;
        } else {
            proto[i] /= 3.6;
            sim[i] /= sim_w;
        }
    }
    (proto, sim)
}

fn both(src: &MemRaster, top: f64, tile: usize, threads: usize) -> (Vec<f32>, Vec<f32>) {
    let info = src.info();
    let cfg = EngineConfig {
        threads,
        ..EngineConfig::default()
    };
    let (p, s) = run_to_memory(
        src,
        top,
        TileLayout::new(info.width, info.height, tile),
        &cfg,
        true,
        true,
    )
    .unwrap();
    (p.unwrap().into_vec(), s.unwrap().into_vec())
}

#[test]
fn peakedness_dw_brute_force() {
    for (w, h, seed, holes, top) in [
        (110, 90, 7, 0.02, 0.2),
        (73, 61, 11, 0.0, 0.5),
        (64, 40, 3, 0.05, 1.0),
    ] {
        let d = hills(w, h, seed, holes);
        let src = source(&d, w, h);
        let (want_p, want_s) = oracle(&d, w, h, top);
        let (p, s) = both(&src, top, 1024, 1);
        check("peak_prototypicality", &p, &want_p, w, 2e-6);
        check("peakedness_dw", &s, &want_s, w, 2e-6);
        // The similarity spans [0, 1] at the scales that have peaks: the
        // best cell of the raster is the centroid's nearest cell.
        let mx = s
            .iter()
            .filter(|v| !v.is_nan())
            .fold(0.0f32, |a, &b| a.max(b));
        assert!(mx > 0.5 && mx <= 1.0, "max similarity {mx}");
    }
}

#[test]
fn peakedness_dw_tiled_equals_untiled() {
    let (w, h) = (97, 83);
    let d = hills(w, h, 19, 0.03);
    let src = source(&d, w, h);
    let (p0, s0) = both(&src, 0.2, 1024, 1);
    for (tile, threads) in [(7, 2), (13, 1), (32, 2), (50, 2)] {
        let (p, s) = both(&src, 0.2, tile, threads);
        for (a, b) in [(&p0, &p), (&s0, &s)] {
            let x: Vec<u32> = a.iter().map(|v| v.to_bits()).collect();
            let y: Vec<u32> = b.iter().map(|v| v.to_bits()).collect();
            assert!(x == y, "tile {tile}, {threads} threads differs");
        }
    }
}

#[test]
fn peakedness_dw_bad_parameters_and_flat_dem() {
    let d = hills(40, 40, 1, 0.0);
    let src = source(&d, 40, 40);
    for (spec, want) in [
        ("peakedness_dw:top=0", "0 < top <= 1"),
        ("peakedness_dw:top=1.5", "0 < top <= 1"),
        ("peak_prototypicality:top=-1", ">= 0"),
        ("peakedness_dw:radius=5c", "has no parameter 'radius'"),
        ("peakedness_dw:top=x", "not a number"),
    ] {
        let e = parse_specs(spec)
            .and_then(|s| orogen::metrics::multi::check(&s, src.info()))
            .unwrap_err()
            .to_string();
        assert!(e.contains(want), "{spec}: {e}");
    }
    // A flat DEM has no peak: the similarity is undefined, and says so.
    let flat = source(&vec![10.0f32; 30 * 30], 30, 30);
    let cfg = EngineConfig::default();
    let e = run_to_memory(&flat, 0.2, TileLayout::new(30, 30, 16), &cfg, false, true)
        .unwrap_err()
        .to_string();
    assert!(e.contains("no peak"), "{e}");
    // ... while the prototypicality is defined (every factor constant: 1).
    let (p, _) = run_to_memory(&flat, 0.2, TileLayout::new(30, 30, 16), &cfg, true, false).unwrap();
    assert!(p.unwrap().data().iter().all(|&v| v == 1.0));
    // MultiMetric refuses the whole-raster metrics with a pointer to compute.
    let e =
        orogen::metrics::MultiMetric::new(&parse_specs("slope,peakedness_dw").unwrap(), src.info())
            .unwrap_err()
            .to_string();
    assert!(e.contains("whole-raster"), "{e}");
}

#[test]
fn peakedness_dw_cli() {
    let dir = tempfile::tempdir().unwrap();
    ok(orogen()
        .args([
            "metric",
            "tests/data/bigtujunga_crop.tif",
            "-m",
            "slope,peakedness_dw,peak_prototypicality:top=0.5",
            "-o",
        ])
        .arg(dir.path())
        .args(["--tile", "64", "-q"]));
    let mut grids = Vec::new();
    for f in [
        "slope.tif",
        "peakedness_dw.tif",
        "peak_prototypicality_t0.5.tif",
    ] {
        let r = orogen::io::open_raster(&dir.path().join(f), &Default::default()).unwrap();
        let info = r.info().clone();
        let g = orogen::raster::read_window::<f32>(
            r.as_ref(),
            orogen::raster::Window::new(0, 0, info.width, info.height),
        )
        .unwrap();
        grids.push(g.into_vec());
    }
    // Same values as the in-memory run on one tile.
    let src = orogen::io::open_raster(
        std::path::Path::new("tests/data/bigtujunga_crop.tif"),
        &Default::default(),
    )
    .unwrap();
    let info = src.info().clone();
    let cfg = EngineConfig::default();
    let one = TileLayout::new(info.width, info.height, 4096);
    let (_, s) = run_to_memory(src.as_ref(), 0.2, one, &cfg, false, true).unwrap();
    let (p, _) = run_to_memory(src.as_ref(), 0.5, one, &cfg, true, false).unwrap();
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&grids[1]), bits(s.unwrap().data()));
    assert_eq!(bits(&grids[2]), bits(p.unwrap().data()));
    assert!(grids[1].iter().any(|v| !v.is_nan()));
}

/// A small spec for every registry entry (radii a few cells so that the
/// O(r²)/O(r³) metrics stay cheap).
fn small_spec(name: &str) -> String {
    let d = METRICS.iter().find(|d| d.name == name).unwrap();
    let mut s = name.to_string();
    for p in d.params {
        match p.name {
            "radius" => s.push_str(":radius=4c"),
            "large" => s.push_str(":large=7c"),
            "scales" => s.push_str(":scales=1/3"),
            _ => {}
        }
    }
    s
}

/// Every metric of the registry: tiled (tiles 1, 7, 16; 1 and 2 threads)
/// equals the whole raster as one tile, bit for bit, on terrain with holes.
#[test]
fn every_registered_metric_tiled_equals_untiled() {
    let (w, h) = (41, 35);
    let d = hills(w, h, 23, 0.03);
    let src = source(&d, w, h);
    let mut seen = 0;
    for def in METRICS {
        let spec = small_spec(def.name);
        let whole_raster = peak_dw::is_whole_raster(def.kind);
        let tiles: &[(usize, usize)] = if whole_raster {
            &[(7, 2), (16, 1)]
        } else {
            &[(1, 2), (7, 2), (16, 1)]
        };
        let get = |tile: usize, threads: usize| -> Vec<u32> {
            let v = if whole_raster {
                let cfg = EngineConfig {
                    threads,
                    ..EngineConfig::default()
                };
                let top = parse_specs(&spec).unwrap()[0].threshold.unwrap_or(0.2);
                let proto = def.kind == MetricKind::PeakPrototypicality;
                let (p, s) =
                    run_to_memory(&src, top, TileLayout::new(w, h, tile), &cfg, proto, !proto)
                        .unwrap();
                (if proto { p } else { s }).unwrap().into_vec()
            } else {
                run(&src, &spec, tile, threads).remove(0)
            };
            v.iter().map(|x| x.to_bits()).collect()
        };
        let base = get(w.max(h), 1);
        for &(tile, threads) in tiles {
            assert!(
                get(tile, threads) == base,
                "{spec}: tile {tile}, {threads} threads differs from untiled"
            );
        }
        seen += 1;
    }
    assert_eq!(seen, METRICS.len());
    // The registry includes the new whole-raster metrics.
    assert!(METRICS.iter().any(|d| d.kind == MetricKind::PeakednessDw));
    // Its defaults: top = 0.2 (the share of peaks averaged into the
    // centroid), the plain name as label, and the bare name parses to it.
    let d = MetricSpec::new(MetricKind::PeakPrototypicality);
    assert_eq!(d.threshold, Some(0.2));
    assert_eq!(d.label(), "peak_prototypicality");
    assert_eq!(
        parse_specs("peak_prototypicality").unwrap(),
        vec![d.clone()]
    );
    let top = parse_specs("peak_prototypicality:top=0.5").unwrap();
    assert_eq!(top[0].threshold, Some(0.5));
    assert_ne!(top[0], d);
}

/// Xu's spherical measures evaluated with explicit 2-D vectors in the plane
/// of the two points and the planet's centre: `[dominance, submission, jut, rut]`.
fn xu_oracle(d: &[f32], w: usize, h: usize, radius: f64, planet: f64) -> [Vec<f64>; 4] {
    let mut out: [Vec<f64>; 4] = std::array::from_fn(|_| vec![f64::NAN; w * h]);
    let r = (radius / CELL).ceil() as i64;
    for y in 0..h as i64 {
        for x in 0..w as i64 {
            let zp = d[y as usize * w + x as usize] as f64;
            if zp.is_nan() {
                continue;
            }
            let mut m = [0.0f64; 4];
            for dy in -r..=r {
                for dx in -r..=r {
                    let (qx, qy) = (x + dx, y + dy);
                    let dist = ((dx * dx + dy * dy) as f64).sqrt() * CELL;
                    if (dx, dy) == (0, 0)
                        || dist > radius
                        || qx < 0
                        || qy < 0
                        || qx >= w as i64
                        || qy >= h as i64
                    {
                        continue;
                    }
                    let zq = d[qy as usize * w + qx as usize] as f64;
                    if zq.is_nan() {
                        continue;
                    }
                    let t = dist / planet;
                    let p = [0.0, planet + zp];
                    let q = [(planet + zq) * t.sin(), (planet + zq) * t.cos()];
                    let (kp, kq) = ([0.0, 1.0], [t.sin(), t.cos()]);
                    let dot = |a: [f64; 2], b: [f64; 2]| a[0] * b[0] + a[1] * b[1];
                    let pq = [p[0] - q[0], p[1] - q[1]];
                    let qp = [-pq[0], -pq[1]];
                    let l = dot(pq, pq).sqrt();
                    let h_p_over_q = dot(pq, kq); // summit p, base q
                    let h_q_over_p = dot(qp, kp); // summit q, base p
                    m[0] = m[0].max(h_p_over_q);
                    m[1] = m[1].max(h_q_over_p);
                    m[2] = m[2].max(h_p_over_q * h_p_over_q.abs() / l);
                    m[3] = m[3].max(h_q_over_p * h_q_over_p.abs() / l);
                }
            }
            for k in 0..4 {
                out[k][y as usize * w + x as usize] = m[k];
            }
        }
    }
    out
}

#[test]
fn xu_spherical_brute_force_and_limits() {
    let (w, h) = (45, 38);
    let d = hills(w, h, 5, 0.03);
    let src = source(&d, w, h);
    // A 2 km planet: at 100 m the horizon drops by ~2.5 m, comparable to the relief.
    for (radius, planet_km) in [(100.0, 2.0), (70.0, 1.0), (150.0, 6371.0)] {
        let want = xu_oracle(&d, w, h, radius, planet_km * 1000.0);
        for (k, name) in ["dominance", "submission", "jut", "rut"].iter().enumerate() {
            let spec = format!("{name}:radius={radius}m:planet={planet_km}");
            let got = run(&src, &spec, 16, 2).remove(0);
            // f32 outputs of values up to ~400 m.
            check(&spec, &got, &want[k], w, 1e-4 * 400.0);
            // Tiled == untiled, bit for bit.
            let one = run(&src, &spec, 64, 1).remove(0);
            let t7 = run(&src, &spec, 7, 2).remove(0);
            assert!(
                one.iter()
                    .map(|v| v.to_bits())
                    .eq(t7.iter().map(|v| v.to_bits())),
                "{spec}: tiled differs"
            );
        }
    }
    // A huge planet gives the planar values (to f32 rounding).
    for name in ["dominance", "submission", "jut", "rut"] {
        let flat = run(&src, &format!("{name}:radius=90m"), 16, 1).remove(0);
        let big = run(&src, &format!("{name}:radius=90m:planet=1000000"), 16, 1).remove(0);
        for (a, b) in flat.iter().zip(&big) {
            assert!(
                a.is_nan() == b.is_nan() && (a.is_nan() || (a - b).abs() <= 2e-3),
                "{name}: {a} vs {b}"
            );
        }
    }
    // Closed forms on a spike of height s on flat ground (planet R):
    // the spike's dominance is s − (R+s)(1 − cos(c/R)) from its nearest
    // neighbour; a flat cell's dominance and submission away from the
    // spike are 0 (every other cell is below its horizon plane).
    let (n, s, rp) = (21usize, 30.0f32, 1000.0f64);
    let mut g = vec![0.0f32; n * n];
    g[10 * n + 10] = s;
    let spike = source(&g, n, n);
    let dom = run(&spike, "dominance:radius=40m:planet=1", 8, 2).remove(0);
    let want = s as f64 - (rp + s as f64) * (1.0 - (CELL / rp).cos());
    assert!(
        (dom[10 * n + 10] as f64 - want).abs() < 1e-4,
        "{} vs {want}",
        dom[10 * n + 10]
    );
    assert_eq!(dom[2 * n + 2], 0.0);
    let sub = run(&spike, "submission:radius=40m:planet=1", 8, 2).remove(0);
    assert_eq!(sub[2 * n + 2], 0.0);
    // Next to the spike: submission = its height above the neighbour's horizon.
    let want = (rp + s as f64) * (CELL / rp).cos() - rp;
    assert!((sub[10 * n + 11] as f64 - want).abs() < 1e-4);
    // Bad planet radii.
    for (spec, want) in [
        ("jut:planet=0", "outside"),
        ("rut:planet=-3", "outside"),
        ("dominance:planet=abc", "not a number"),
        ("ors:planet=6371", "has no parameter 'planet'"),
    ] {
        let e = parse_specs(spec).unwrap_err().to_string();
        assert!(e.contains(want), "{spec}: {e}");
    }
    // Labels name the planet; the planar default keeps the old names.
    let l: Vec<String> = parse_specs("jut:radius=1km,jut:radius=1km:planet=6371")
        .unwrap()
        .iter()
        .map(|s| s.label())
        .collect();
    assert_eq!(l, ["jut_r1000m", "jut_r1000m_planet6371"]);
}

/// Closed forms the earlier suites did not cover: a Gaussian hill and a
/// cone. Analytic derivatives (p, q, r, s, t) of the surface, put into the
/// published curvature formulas (Florinsky 2016, ch. 2) written out here,
/// against orogen's Evans 3x3 curvatures and 5-point Laplacian: agreement to
/// the O(h²) discretisation error (cell 10 m, scales ≥ 150 m).
#[test]
fn gaussian_hill_and_cone_curvatures_closed_form() {
    let (n, c) = (81usize, 40.0f64);
    // (name, z(x, y), derivatives (p, q, r, s, t) at (x, y)); x east, y north, metres from the centre.
    type Surf = (&'static str, fn(f64, f64) -> f64, fn(f64, f64) -> [f64; 5]);
    let gauss: Surf = (
        "gaussian",
        |x, y| 300.0 * (-(x * x + y * y) / (2.0 * 150.0f64.powi(2))).exp(),
        |x, y| {
            let s2 = 150.0f64.powi(2);
            let z = 300.0 * (-(x * x + y * y) / (2.0 * s2)).exp();
            [
                -x / s2 * z,
                -y / s2 * z,
                (x * x / (s2 * s2) - 1.0 / s2) * z,
                x * y / (s2 * s2) * z,
                (y * y / (s2 * s2) - 1.0 / s2) * z,
            ]
        },
    );
    let cone: Surf = (
        "cone",
        |x, y| 500.0 - 0.8 * (x * x + y * y).sqrt(),
        |x, y| {
            let rho = (x * x + y * y).sqrt();
            let k = 0.8;
            [
                -k * x / rho,
                -k * y / rho,
                -k * y * y / rho.powi(3),
                k * x * y / rho.powi(3),
                -k * x * x / rho.powi(3),
            ]
        },
    );
    for (name, z, der) in [gauss, cone] {
        let d: Vec<f32> = (0..n * n)
            .map(|i| {
                let (col, row) = ((i % n) as f64, (i / n) as f64);
                z((col - c) * CELL, (c - row) * CELL) as f32
            })
            .collect();
        let src = source(&d, n, n);
        let out = run(
            &src,
            "laplacian,mean_curvature,gaussian_curvature,profile_curvature,plan_curvature,tangential_curvature,min_curvature,max_curvature",
            32,
            2,
        );
        // Sample points off the apex (the cone's apex is singular), on the
        // axes and diagonals, 15..25 cells out.
        for (col, row) in [(55usize, 40usize), (40, 22), (58, 58), (25, 27), (61, 45)] {
            let (x, y) = ((col as f64 - c) * CELL, (c - row as f64) * CELL);
            let [p, q, r, s, t] = der(x, y);
            let g = 1.0 + p * p + q * q;
            let g2 = p * p + q * q;
            let mean =
                -((1.0 + q * q) * r - 2.0 * p * q * s + (1.0 + p * p) * t) / (2.0 * g.powf(1.5));
            let gk = (r * t - s * s) / (g * g);
            let disc = (mean * mean - gk).max(0.0).sqrt();
            let want = [
                r + t,
                mean,
                gk,
                -(p * p * r + 2.0 * p * q * s + q * q * t) / (g2 * g.powf(1.5)),
                -(q * q * r - 2.0 * p * q * s + p * p * t) / g2.powf(1.5),
                -(q * q * r - 2.0 * p * q * s + p * p * t) / (g2 * g.sqrt()),
                mean - disc,
                mean + disc,
            ];
            let scale = [
                (r.abs() + t.abs()),
                mean.abs().max(1e-5),
                gk.abs().max(1e-9),
                (r.abs() + t.abs() + s.abs()),
                (r.abs() + t.abs() + s.abs()) / g2.sqrt(),
                (r.abs() + t.abs() + s.abs()),
                (r.abs() + t.abs()),
                (r.abs() + t.abs()),
            ];
            for k in 0..8 {
                let got = out[k][row * n + col] as f64;
                assert!(
                    (got - want[k]).abs() <= 0.03 * scale[k] + 1e-7,
                    "{name} metric {k} at ({col}, {row}): got {got}, want {}",
                    want[k]
                );
            }
        }
    }
}
