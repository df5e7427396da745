//! The remaining pointwise descriptors (directional and average slope,
//! fractional Laplacian, hillslope asymmetry, Shary's classes, ORS, jut,
//! rut) and the cost/correlation table, against oracles that share no code
//! with them: closed forms on analytic surfaces and direct double loops
//! over windows on random grids with nodata holes; tiled == untiled bit for
//! bit; bad parameters.

#![allow(clippy::needless_range_loop)] // index loops read like the definitions

use orogen::metrics::fractional::{frac_constant, gamma};
use orogen::metrics::table;

use crate::common::{
    assert_tiled_equals_untiled, check, facing_gradients, get, horn, random_terrain, ridge, run,
    run1, run_bits, source, spec_err as err, Rng, CELL,
};

/// Random terrain (smooth + noise, values rounded to 1/8) with nodata holes.
fn random_grid(w: usize, h: usize, seed: u64, holes: f64) -> Vec<f32> {
    random_terrain(w, h, seed, holes, 8.0)
}

/// `f(z, disk)` at every valid cell (nodata elsewhere), `disk` the valid
/// cells (distance in metres, value) with `0 < d ≤ cut` within `r` cells of
/// it on each axis, in row-major order.
fn disk_oracle(
    data: &[f32],
    w: usize,
    h: usize,
    r: i64,
    cut: f64,
    f: impl Fn(f64, &[(f64, f64)]) -> f64,
) -> Vec<f64> {
    (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as i64, (i / w) as i64);
            let z = data[i] as f64;
            if z.is_nan() {
                return f64::NAN;
            }
            let mut disk = Vec::new();
            for yy in y - r..=y + r {
                for xx in x - r..=x + r {
                    let d = (((xx - x).pow(2) + (yy - y).pow(2)) as f64).sqrt() * CELL;
                    let v = get(data, w, h, xx, yy);
                    if d > 0.0 && d <= cut && !v.is_nan() {
                        disk.push((d, v));
                    }
                }
            }
            f(z, &disk)
        })
        .collect()
}

// ---------- directional slope ----------

#[test]
fn directional_slope_on_a_tilted_plane() {
    let (w, h) = (17, 13);
    let (a, b) = (0.25, -0.5); // dz/dx east, dz/dy north
    let data: Vec<f32> = (0..w * h)
        .map(|i| (a * (i % w) as f64 * CELL - b * (i / w) as f64 * CELL) as f32)
        .collect();
    let src = source(&data, w, h);
    for az in [0.0f64, 90.0, 30.0, 225.0, -45.0] {
        let got = run1(&src, &format!("directional_slope:azimuth={az}"));
        let r = az.to_radians();
        let want: Vec<f64> = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                if x == 0 || y == 0 || x == w - 1 || y == h - 1 {
                    f64::NAN
                } else {
                    a * r.sin() + b * r.cos()
                }
            })
            .collect();
        check("directional_slope", &got, &want, w, 1e-6, 1e-6);
    }
}

// ---------- average slope ----------

#[test]
fn average_slope_brute_force() {
    let (w, h) = (29, 23);
    let data = random_grid(w, h, 7, 0.06);
    let src = source(&data, w, h);
    for r in [1i64, 3, 6] {
        let got = run1(&src, &format!("average_slope:radius={r}c"));
        let want: Vec<f64> = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as i64, (i / w) as i64);
                if data[i].is_nan() {
                    return f64::NAN;
                }
                let (mut s, mut n) = (0.0, 0);
                for yy in y - r..=y + r {
                    for xx in x - r..=x + r {
                        let (p, q) = horn(&data, w, h, xx, yy);
                        if !(p.is_nan() || q.is_nan()) {
                            s += (p * p + q * q).sqrt().atan().to_degrees();
                            n += 1;
                        }
                    }
                }
                if n == 0 {
                    f64::NAN
                } else {
                    s / n as f64
                }
            })
            .collect();
        check("average_slope", &got, &want, w, 1e-6, 1e-5);
    }
}

// ---------- fractional Laplacian ----------

#[test]
fn gamma_and_constant_closed_forms() {
    let pi = std::f64::consts::PI;
    assert!((gamma(0.5) - pi.sqrt()).abs() < 1e-13);
    assert!((gamma(5.0) - 24.0).abs() < 1e-11);
    assert!((gamma(1.5) - pi.sqrt() / 2.0).abs() < 1e-13);
    // C(1/2) = Γ(3/2) / (π Γ(1/2)) = 1/(2π).
    assert!((frac_constant(0.5) - 1.0 / (2.0 * pi)).abs() < 1e-14);
    // C(s) = s 4^s Γ(1+s)/(π Γ(1−s)) with tabulated Γ(1.25), Γ(0.75).
    let c = 0.25 * 4f64.powf(0.25) * 0.906_402_477_055_477 / (pi * 1.225_416_702_465_178);
    assert!((frac_constant(0.25) - c).abs() < 1e-13);
    // s → 1: C(s) ~ 4(1−s)/π.
    let s = 1.0 - 1e-6;
    assert!((frac_constant(s) / (4.0 * (1.0 - s) / pi) - 1.0).abs() < 1e-4);
}

#[test]
fn fractional_laplacian_plane_is_zero_and_paraboloid_closed_form() {
    let (w, h) = (31, 31);
    let r = 6i64;
    let plane: Vec<f32> = (0..w * h)
        .map(|i| (0.5 * (i % w) as f64 - 0.25 * (i / w) as f64) as f32)
        .collect();
    let a = 0.01; // z = a (x² + y²) in metres
    let para: Vec<f32> = (0..w * h)
        .map(|i| {
            let (x, y) = (
                ((i % w) as f64 - 15.0) * CELL,
                ((i / w) as f64 - 15.0) * CELL,
            );
            (a * (x * x + y * y)) as f32
        })
        .collect();
    for s in [0.25, 0.5, 0.75] {
        let got = run1(
            &source(&plane, w, h),
            &format!("fractional_laplacian:radius={r}c:s={s}"),
        );
        let gotp = run1(
            &source(&para, w, h),
            &format!("fractional_laplacian:radius={r}c:s={s}"),
        );
        // Lattice sum of |y|^{-2s} over the disk (0 < |y| ≤ r cells).
        let mut lattice = 0.0;
        for dy in -r..=r {
            for dx in -r..=r {
                let d2 = (dx * dx + dy * dy) as f64;
                if d2 > 0.0 && d2 <= (r * r) as f64 {
                    lattice += (d2 * CELL * CELL).powf(-s);
                }
            }
        }
        let want = -a * frac_constant(s) * CELL * CELL * lattice;
        // The continuous integral 2π R^{2−2s}/(2−2s) over the disk is close.
        let rm = r as f64 * CELL;
        let cont = 2.0 * std::f64::consts::PI * rm.powf(2.0 - 2.0 * s) / (2.0 - 2.0 * s);
        assert!((lattice * CELL * CELL / cont - 1.0).abs() < 0.35, "s {s}");
        for y in r..h as i64 - r {
            for x in r..w as i64 - r {
                let i = y as usize * w + x as usize;
                assert!(got[i].abs() < 1e-4, "plane s {s} ({x},{y}) {}", got[i]);
                assert!(
                    (gotp[i] as f64 - want).abs() < 1e-4 * want.abs(),
                    "paraboloid s {s} ({x},{y}) got {} want {want}",
                    gotp[i]
                );
            }
        }
    }
    // s → 1: the truncated lattice sum vanishes with C(s) (stated in the docs).
    let near1 = run1(
        &source(&para, w, h),
        &format!("fractional_laplacian:radius={r}c:s=0.9999"),
    );
    let half = run1(
        &source(&para, w, h),
        &format!("fractional_laplacian:radius={r}c:s=0.5"),
    );
    let c = 15 * w + 15;
    assert!(near1[c].abs() < 1e-3 * half[c].abs());
}

#[test]
fn fractional_laplacian_brute_force() {
    let (w, h) = (21, 19);
    let data = random_grid(w, h, 3, 0.08);
    let src = source(&data, w, h);
    let (r, s) = (4i64, 0.3);
    let got = run1(&src, &format!("fractional_laplacian:radius={r}c:s={s}"));
    let c = frac_constant(s);
    let want = disk_oracle(&data, w, h, r, r as f64 * CELL, |z, disk| {
        let acc: f64 = disk
            .iter()
            .map(|&(d, v)| (z - v) / d.powf(2.0 + 2.0 * s))
            .sum();
        c * CELL * CELL * acc
    });
    check("fractional_laplacian", &got, &want, w, 1e-5, 1e-6);
}

// ---------- hillslope asymmetry ----------

#[test]
fn hillslope_asymmetry_plane_and_ridges() {
    let (w, h, crest, r) = (15usize, 21usize, 10usize, 4usize);
    // A plane facing north only: no opposite slopes anywhere.
    let plane: Vec<f32> = (0..w * h)
        .map(|i| (0.3 * (i / w) as f64 * CELL) as f32)
        .collect();
    let got = run1(
        &source(&plane, w, h),
        &format!("hillslope_asymmetry:radius={r}c"),
    );
    assert!(got.iter().all(|v| v.is_nan()));
    // Symmetric ridge: 0 wherever the window sees both sides.
    let sym = ridge(w, h, crest, 0.4, 0.4);
    let got = run1(
        &source(&sym, w, h),
        &format!("hillslope_asymmetry:radius={r}c"),
    );
    for y in crest - r + 1..crest + r {
        for x in r + 1..w - r - 1 {
            let v = got[y * w + x];
            // Both sides present (the crest row itself is flat in Horn's gradient).
            if y + r > crest && y < crest + r {
                assert!(v.abs() < 1e-6, "sym ({x},{y}) {v}");
            }
        }
    }
    // North side twice as steep: north-facing mean over south-facing mean.
    let (gn, gs) = (0.8, 0.4);
    let asym = ridge(w, h, crest, gn, gs);
    let got = run1(
        &source(&asym, w, h),
        &format!("hillslope_asymmetry:radius={r}c"),
    );
    let got_s = run1(
        &source(&asym, w, h),
        &format!("hillslope_asymmetry:radius={r}c:azimuth=180"),
    );
    // The crest row's Horn gradient is (gn − gs)/2, facing north.
    let crest_g = (gn - gs) / 2.0;
    for y in crest - r + 2..=crest + r - 2 {
        for x in r + 1..w - r - 1 {
            let (y0, y1) = (y - r, y + r);
            // Interior rows strictly north of the crest (exclude row 0: edge).
            let north_rows = (y0.max(1)..crest.min(y1 + 1)).count() as f64;
            let crest_rows = if (y0..=y1).contains(&crest) { 1.0 } else { 0.0 };
            let mean_n = (gn * north_rows + crest_g * crest_rows) / (north_rows + crest_rows);
            let want = (mean_n / gs).log10();
            let v = got[y * w + x] as f64;
            assert!(
                (v - want).abs() < 1e-5,
                "asym ({x},{y}) got {v} want {want}"
            );
            assert!((got_s[y * w + x] as f64 + want).abs() < 1e-5);
        }
    }
}

#[test]
fn hillslope_asymmetry_brute_force() {
    let (w, h) = (27, 25);
    let data = random_grid(w, h, 11, 0.05);
    let src = source(&data, w, h);
    for (r, az, tol) in [(3i64, 0.0, 45.0), (5, 60.0, 30.0), (2, 270.0, 90.0)] {
        let got = run1(
            &src,
            &format!("hillslope_asymmetry:radius={r}c:azimuth={az}:tolerance={tol}"),
        );
        let want: Vec<f64> = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as i64, (i / w) as i64);
                if data[i].is_nan() {
                    return f64::NAN;
                }
                let (toward, away) = facing_gradients(&data, w, h, (x, y), r, az, tol);
                let (np, nn) = (toward.len(), away.len());
                let (sp, sn) = (toward.iter().sum::<f64>(), away.iter().sum::<f64>());
                if np == 0 || nn == 0 {
                    f64::NAN
                } else {
                    ((sp / np as f64) / (sn / nn as f64)).log10()
                }
            })
            .collect();
        check("hillslope_asymmetry", &got, &want, w, 1e-5, 1e-5);
    }
}

// ---------- Shary ----------

/// Shary's twelve types as sign tuples (kh, kv, K, E, H), 0 = not used by
/// the type: written out here from the definition (kh, kv alike: K and E;
/// opposite: H), independently of `metrics::shary`.
const SHARY_TYPES: [(i8, i8, i8, i8, i8); 12] = [
    (-1, -1, 1, -1, 0),
    (-1, -1, 1, 1, 0),
    (-1, -1, -1, -1, 0),
    (-1, -1, -1, 1, 0),
    (-1, 1, 0, 0, -1),
    (-1, 1, 0, 0, 1),
    (1, -1, 0, 0, -1),
    (1, -1, 0, 0, 1),
    (1, 1, -1, -1, 0),
    (1, 1, -1, 1, 0),
    (1, 1, 1, -1, 0),
    (1, 1, 1, 1, 0),
];

/// Closed-form curvatures (convex positive) of z(e, n) from its first and
/// second derivatives p, q, r = z_ee, s = z_en, t = z_nn.
fn curvatures(p: f64, q: f64, r: f64, s: f64, t: f64) -> (f64, f64, f64, f64) {
    let g = p * p + q * q;
    let kv = -(r * p * p + 2.0 * s * p * q + t * q * q) / (g * (1.0 + g).powf(1.5));
    let kh = -(r * q * q - 2.0 * s * p * q + t * p * p) / (g * (1.0 + g).sqrt());
    let k = (r * t - s * s) / (1.0 + g).powi(2);
    let h =
        -((1.0 + q * q) * r - 2.0 * p * q * s + (1.0 + p * p) * t) / (2.0 * (1.0 + g).powf(1.5));
    (kh, kv, k, h)
}

#[test]
fn shary_classes_on_analytic_surfaces() {
    // Quadratic surfaces z = a e² + b n² + c e n + d e + f n (the Evans/Wood
    // 3 x 3 fit is exact on them), each cell's type from the closed-form
    // curvatures and SHARY_TYPES; cells where a sign is within rounding of
    // zero are left out.
    let (w, h) = (25, 25);
    let c = 12.0;
    let surfaces: [(&str, [f64; 5]); 7] = [
        ("elliptic dome", [-0.002, -0.0005, 0.0, 0.0, 0.0]),
        ("elliptic bowl", [0.002, 0.0005, 0.0, 0.0, 0.0]),
        ("tilted saddle", [0.005, -0.005, 0.0, 0.3, 0.1]),
        ("ridge on a slope", [-0.002, 0.0, 0.0, 0.0, 0.05]),
        ("valley on a slope", [0.002, 0.0, 0.0, 0.0, 0.05]),
        ("twisted slope", [0.001, -0.003, 0.002, 0.1, 0.05]),
        ("round dome", [-0.002, -0.002, 0.0, 0.0, 0.0]),
    ];
    let mut seen = std::collections::BTreeSet::new();
    for (name, [a, b, cc, d, f]) in surfaces {
        let z: Vec<f32> = (0..w * h)
            .map(|i| {
                let (e, n) = (((i % w) as f64 - c) * CELL, (c - (i / w) as f64) * CELL);
                (1000.0 + a * e * e + b * n * n + cc * e * n + d * e + f * n) as f32
            })
            .collect();
        let got = run1(&source(&z, w, h), "shary_landform");
        for y in 2..h - 2 {
            for x in 2..w - 2 {
                let (e, n) = ((x as f64 - c) * CELL, (c - y as f64) * CELL);
                let (p, q) = (2.0 * a * e + cc * n + d, 2.0 * b * n + cc * e + f);
                let (kh, kv, k, hh) = curvatures(p, q, 2.0 * a, cc, 2.0 * b);
                let ee = 0.5 * (kv - kh);
                let sig = |v: f64, scale: f64| -> Option<i8> {
                    if v.is_nan() || v.abs() <= 1e-6 * scale {
                        None
                    } else {
                        Some(if v > 0.0 { 1 } else { -1 })
                    }
                };
                let scale = kh.abs().max(kv.abs()).max(1e-12);
                let (Some(sh), Some(sv)) = (sig(kh, scale), sig(kv, scale)) else {
                    continue;
                };
                let (sk, se, shh) = (sig(k, scale * scale), sig(ee, scale), sig(hh, scale));
                let want = SHARY_TYPES.iter().position(|&(a1, a2, a3, a4, a5)| {
                    a1 == sh
                        && a2 == sv
                        && (a3 == 0 || Some(a3) == sk)
                        && (a4 == 0 || Some(a4) == se)
                        && (a5 == 0 || Some(a5) == shh)
                });
                let Some(want) = want else {
                    continue; // a needed sign within rounding of zero
                };
                let i = y * w + x;
                assert_eq!(
                    got[i],
                    (want + 1) as f32,
                    "{name} ({x},{y}): kh {kh} kv {kv} K {k} E {ee} H {hh}"
                );
                seen.insert(want + 1);
            }
        }
    }
    // Kinds of point the surfaces hold: elliptic and saddle points of both
    // groups and both mixed groups.
    assert!(seen.len() >= 8, "{seen:?}");
    // The paraboloid dome of revolution: kv < kh off the apex (class 11);
    // a sphere would be umbilic (E = 0).
    let plane: Vec<f32> = (0..w * h).map(|i| (0.25 * (i % w) as f64) as f32).collect();
    assert!(run1(&source(&plane, w, h), "shary_landform")
        .iter()
        .all(|&v| v == 0.0 || v.is_nan()));
}

#[test]
fn mean_curvature_is_the_mean_of_kh_and_kv() {
    // The premise of Shary's twelve types: H = (kh + kv)/2.
    let (w, h) = (23, 21);
    let data = random_grid(w, h, 5, 0.0);
    let src = source(&data, w, h);
    let out = run(
        &src,
        "mean_curvature,tangential_curvature,profile_curvature",
        8,
        1,
    );
    for i in 0..w * h {
        let (hh, kh, kv) = (out[0][i] as f64, out[1][i] as f64, out[2][i] as f64);
        if hh.is_nan() || (kh == 0.0 && kv == 0.0) {
            continue;
        }
        assert!(
            (hh - (kh + kv) / 2.0).abs() < 1e-5 * (hh.abs() + 1e-4),
            "{i}: {hh} {kh} {kv}"
        );
    }
}

// ---------- ORS, jut, rut ----------

#[test]
fn ors_jut_rut_brute_force() {
    let (w, h) = (22, 19);
    let data = random_grid(w, h, 17, 0.07);
    let src = source(&data, w, h);
    let r = 5i64;
    let pi = std::f64::consts::PI;
    let got = run(
        &src,
        &format!("ors:radius={r}c,jut:radius={r}c,rut:radius=45m"),
        16,
        2,
    );
    for (k, cut) in [(0usize, r as f64 * CELL), (1, r as f64 * CELL), (2, 45.0)] {
        let want = disk_oracle(&data, w, h, r, cut, |z, disk| {
            let mut acc = 0.0f64;
            for &(d, v) in disk {
                let dz = z - v;
                match k {
                    0 if dz > 0.0 => {
                        let u = dz / d;
                        let f = 4.0 / pi.powi(3)
                            * (2.0 * u * u.atan() - (1.0 + u * u).ln() - u.atan().powi(2));
                        acc += f.max(0.0) * CELL * CELL;
                    }
                    1 if dz > 0.0 => acc = acc.max(dz * dz / (d * d + dz * dz).sqrt()),
                    2 if dz < 0.0 => acc = acc.max(dz * dz / (d * d + dz * dz).sqrt()),
                    _ => {}
                }
            }
            if k == 0 {
                acc.sqrt()
            } else {
                acc
            }
        });
        check(["ors", "jut", "rut"][k], &got[k], &want, w, 1e-5, 1e-5);
    }
}

#[test]
fn jut_and_rut_of_a_spike_and_ors_of_a_flat() {
    let (w, h) = (11, 11);
    let hgt = 30.0;
    let mut data = vec![0f32; w * h];
    data[5 * w + 5] = hgt as f32;
    let out = run(
        &source(&data, w, h),
        "jut:radius=3c,rut:radius=3c,ors:radius=3c",
        11,
        1,
    );
    // The spike juts H²/√(cell² + H²) above its 4-neighbours.
    let want = hgt * hgt / (CELL * CELL + hgt * hgt).sqrt();
    assert!((out[0][5 * w + 5] as f64 - want).abs() < 1e-4);
    assert!((out[1][5 * w + 6] as f64 - want).abs() < 1e-4);
    assert_eq!(out[0][5 * w + 6], 0.0); // nothing lower than a flat cell
    assert_eq!(out[2][0], 0.0);
    let flat = vec![5f32; w * h];
    let o = run(
        &source(&flat, w, h),
        "ors:radius=3c,jut:radius=3c,rut:radius=3c",
        4,
        1,
    );
    assert!(o.iter().all(|g| g.iter().all(|&v| v == 0.0)));
}

// ---------- tiled == untiled ----------

#[test]
fn tiled_equals_untiled_bit_for_bit() {
    let (w, h) = (41, 37);
    let data = random_grid(w, h, 23, 0.04);
    let src = source(&data, w, h);
    let specs = "directional_slope:azimuth=33,average_slope:radius=4c,fractional_laplacian:radius=5c:s=0.4,hillslope_asymmetry:radius=5c:azimuth=90,shary_landform,shary_landform:radius=3c,ors:radius=4c,jut:radius=60m,rut:radius=5c";
    assert_tiled_equals_untiled(&src, specs, w * h / 2);
}

// ---------- bad parameters ----------

#[test]
fn bad_parameters_are_clear_errors() {
    for s in [
        "fractional_laplacian:s=0",
        "fractional_laplacian:s=1",
        "fractional_laplacian:s=1.5",
        "fractional_laplacian:s=-0.2",
        "fractional_laplacian:s=abc",
    ] {
        let e = err(s);
        assert!(
            e.contains("0 and 1") || e.contains("not a number"),
            "{s}: {e}"
        );
        assert!(e.contains("0 < s < 1"), "{s}: {e}");
    }
    let e = err("directional_slope:azimuth=north");
    assert!(e.contains("azimuth") && e.contains("degrees"), "{e}");
    let e = err("directional_slope:azimuth=inf");
    assert!(e.contains("finite"), "{e}");
    for s in [
        "hillslope_asymmetry:tolerance=0",
        "hillslope_asymmetry:tolerance=120",
    ] {
        let e = err(s);
        assert!(e.contains("0 < tolerance <= 90"), "{s}: {e}");
    }
    let e = err("ors:radius=-3c");
    assert!(e.contains("1c..="), "{e}");
    let e = err("jut:radius=50c");
    assert!(e.contains("beyond the raster"), "{e}");
    let e = err("rut:radius=5km");
    assert!(e.contains("beyond the raster"), "{e}");
    let e = err("peakiness");
    assert!(
        e.contains("unknown metric") && e.contains("jut") && e.contains("shary_landform"),
        "{e}"
    );
    // the nearest names are offered
    assert!(e.contains("(did you mean 'peakedness'"), "{e}");
    let e = err("geomorphn");
    assert!(e.contains("(did you mean 'geomorphon'?)"), "{e}");
    let e = err("xyzzy");
    assert!(!e.contains("did you mean"), "{e}");
    let e = err("average_slope:azimuth=3");
    assert!(
        e.contains("no parameter 'azimuth'") && e.contains("radius"),
        "{e}"
    );
}

// ---------- table ----------

#[test]
fn pearson_matches_a_naive_formula() {
    let mut rng = Rng(99);
    let n = 500;
    let a: Vec<f32> = (0..n).map(|_| rng.unit() as f32).collect();
    let mut b: Vec<f32> = a
        .iter()
        .map(|x| 0.5 * x + 0.3 * rng.unit() as f32)
        .collect();
    b[7] = f32::NAN;
    // Naive: Σxy − n x̄ ȳ over the pairs present.
    let pairs: Vec<(f64, f64)> = a
        .iter()
        .zip(&b)
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .map(|(&x, &y)| (x as f64, y as f64))
        .collect();
    let m = pairs.len() as f64;
    let (sx, sy) = pairs.iter().fold((0.0, 0.0), |s, p| (s.0 + p.0, s.1 + p.1));
    let sxy: f64 = pairs.iter().map(|p| p.0 * p.1).sum();
    let sxx: f64 = pairs.iter().map(|p| p.0 * p.0).sum();
    let syy: f64 = pairs.iter().map(|p| p.1 * p.1).sum();
    let want = (m * sxy - sx * sy) / ((m * sxx - sx * sx).sqrt() * (m * syy - sy * sy).sqrt());
    assert!((table::pearson(&a, &b) - want).abs() < 1e-9);
    assert!((table::pearson(&a, &a) - 1.0).abs() < 1e-12);
    let neg: Vec<f32> = a.iter().map(|x| -2.0 * x).collect();
    assert!((table::pearson(&a, &neg) + 1.0).abs() < 1e-12);
    assert!(table::pearson(&a, &vec![1.0; n]).is_nan());
}

#[test]
fn correlation_matrix_and_cost_table_on_a_small_dem() {
    let (w, h) = (40, 36);
    let data = random_grid(w, h, 31, 0.02);
    let src = source(&data, w, h);
    let specs = table::correlation_specs(&src, 30.0);
    assert!(specs.iter().all(|s| !table::is_categorical(s.kind)));
    let (labels, m) = table::correlation(&src, &specs).unwrap();
    let n = labels.len();
    assert_eq!(n, specs.len());
    for i in 0..n {
        assert!(
            (m[i * n + i] - 1.0).abs() < 1e-9 || m[i * n + i].is_nan(),
            "{}",
            labels[i]
        );
        for j in 0..n {
            assert_eq!(m[i * n + j].to_bits(), m[j * n + i].to_bits());
        }
    }
    // northness and normal_y are the same quantity.
    let ix = |name: &str| labels.iter().position(|l| l == name).unwrap();
    assert!((m[ix("northness") * n + ix("normal_y")] - 1.0).abs() < 1e-9);
    let (pw, ph, px) = table::heatmap_rgb(&m, n, 10);
    assert_eq!(px.len(), pw * ph * 3);
    assert!(pw >= n * 10 && ph == pw);

    let only = [
        orogen::metrics::MetricKind::Slope,
        orogen::metrics::MetricKind::Tpi,
        orogen::metrics::MetricKind::Jut,
    ];
    let rows = table::cost_table(&src, &[20.0, 50.0, 1e6], 1, Some(&only), |_| {}).unwrap();
    // slope once, tpi and jut at three radii each (the last one too large).
    assert_eq!(rows.len(), 7);
    assert!(rows.iter().filter(|r| r.skipped.is_some()).count() == 2);
    let slope = rows.iter().find(|r| r.name == "slope").unwrap();
    assert_eq!(slope.relative, 1.0);
    assert!(rows.iter().all(|r| r.skipped.is_some() || r.seconds > 0.0));
    let md = table::cost_markdown(&rows, &[20.0, 50.0, 1e6]);
    assert!(md.contains("| jut |") && md.lines().count() == 5, "{md}");
    assert!(table::cost_csv(&rows).lines().count() == 8);
}

#[test]
fn tiled_equals_untiled_on_a_real_dem() {
    use orogen::io::{open_raster, OpenOptions};
    let src = open_raster(
        std::path::Path::new("tests/data/whitebox_DEM.tif"),
        &OpenOptions::default(),
    )
    .unwrap();
    let specs = "directional_slope:azimuth=200,average_slope:radius=300m,fractional_laplacian:radius=4c,hillslope_asymmetry:radius=6c,shary_landform:radius=2c,ors:radius=400m,jut:radius=4c,rut:radius=4c";
    let runt = |tile: usize| run_bits(src.as_ref(), specs, tile, 2);
    let whole = runt(256);
    for tile in [9, 37, 100] {
        assert!(runt(tile) == whole, "tile {tile}");
    }
}

// ---------- fuzzy landforms ----------

/// Wood's feature of a cell from its own Evans 3x3 derivatives, written out
/// here (convex positive): the oracle for radius-1 scales.
fn wood_feature_3x3(d: &[f32], w: usize, h: usize, x: i64, y: i64, t: f64) -> Option<usize> {
    let z = |dx: i64, dy: i64| get(d, w, h, x + dx, y + dy);
    let mut s = 0.0;
    for dy in -1..=1 {
        for dx in -1..=1 {
            s += z(dx, dy);
        }
    }
    if s.is_nan() {
        return None;
    }
    let c2 = CELL * CELL;
    // x east, y north (dy = −1 is north).
    let p = (z(1, -1) + z(1, 0) + z(1, 1) - z(-1, -1) - z(-1, 0) - z(-1, 1)) / (6.0 * CELL);
    let q = (z(-1, -1) + z(0, -1) + z(1, -1) - z(-1, 1) - z(0, 1) - z(1, 1)) / (6.0 * CELL);
    let r = (z(-1, -1) + z(1, -1) + z(-1, 0) + z(1, 0) + z(-1, 1) + z(1, 1)
        - 2.0 * (z(0, -1) + z(0, 0) + z(0, 1)))
        / (3.0 * c2);
    let tt = (z(-1, -1) + z(0, -1) + z(1, -1) + z(-1, 1) + z(0, 1) + z(1, 1)
        - 2.0 * (z(-1, 0) + z(0, 0) + z(1, 0)))
        / (3.0 * c2);
    let sxy = (z(1, -1) + z(-1, 1) - z(-1, -1) - z(1, 1)) / (4.0 * c2);
    let g2 = p * p + q * q;
    if g2.sqrt().atan().to_degrees() > 1.0 {
        let kh = -(q * q * r - 2.0 * p * q * sxy + p * p * tt) / (g2 * (1.0 + g2).sqrt());
        return Some(if kh > t {
            1
        } else if kh < -t {
            4
        } else {
            3
        });
    }
    // Principal curvatures from the shape operator's eigenvalues.
    let g = 1.0 + g2;
    let hm = -((1.0 + q * q) * r - 2.0 * p * q * sxy + (1.0 + p * p) * tt) / (2.0 * g * g.sqrt());
    let k = (r * tt - sxy * sxy) / (g * g);
    let dd = (hm * hm - k).max(0.0).sqrt();
    let (kmin, kmax) = (hm - dd, hm + dd);
    Some(if kmin > t {
        0
    } else if kmax < -t {
        5
    } else if kmax > t && kmin < -t {
        2
    } else if kmax > t {
        1
    } else if kmin < -t {
        4
    } else {
        3
    })
}

#[test]
fn fuzzy_landform_closed_forms_and_brute_force() {
    let (w, h) = (21, 21);
    let c = 10.0;
    // A paraboloid hill, a bowl and a plane: at the centre every scale
    // agrees (peak, pit), so the membership is exactly 1.
    let hill: Vec<f32> = (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f64 - c, (i / w) as f64 - c);
            (100.0 - 0.05 * (x * x + y * y)) as f32
        })
        .collect();
    let bowl: Vec<f32> = hill.iter().map(|z| 200.0 - z).collect();
    let plane: Vec<f32> = (0..w * h).map(|i| (0.5 * (i % w) as f64) as f32).collect();
    let ci = 10 * w + 10;
    let o = run(
        &source(&hill, w, h),
        "fuzzy_landform:class=peak:scales=1/2/4,fuzzy_landform:class=pit",
        8,
        2,
    );
    assert_eq!((o[0][ci], o[1][ci]), (1.0, 0.0));
    let o = run(
        &source(&bowl, w, h),
        "fuzzy_landform:class=pit:scales=1/3/5,fuzzy_landform:class=peak",
        8,
        2,
    );
    assert_eq!((o[0][ci], o[1][ci]), (1.0, 0.0));
    let o = run1(
        &source(&plane, w, h),
        "fuzzy_landform:class=plane:scales=1/2/3",
    );
    for y in 3..h - 3 {
        for x in 3..w - 3 {
            assert_eq!(o[y * w + x], 1.0);
        }
    }
    // Brute force at a single 3x3 scale: membership is 0 or 1 by the oracle.
    let data = random_grid(23, 19, 41, 0.05);
    let src = source(&data, 23, 19);
    for (k, name) in ["peak", "ridge", "pass", "plane", "channel", "pit"]
        .iter()
        .enumerate()
    {
        let got = run1(
            &src,
            &format!("fuzzy_landform:class={name}:scales=1:threshold=0.001"),
        );
        let want: Vec<f64> = (0..23 * 19)
            .map(|i| {
                let (x, y) = ((i % 23) as i64, (i / 23) as i64);
                if data[i].is_nan() {
                    return f64::NAN;
                }
                match wood_feature_3x3(&data, 23, 19, x, y, 0.001) {
                    None => f64::NAN,
                    Some(f) => (f == k) as u8 as f64,
                }
            })
            .collect();
        check(name, &got, &want, 23, 0.0, 0.0);
    }
    // Tiled == untiled with several scales.
    let specs = "fuzzy_landform:class=ridge:scales=1/2/5,fuzzy_landform:class=channel:scales=2/3";
    let a = run(&src, specs, 64, 1);
    let b = run(&src, specs, 7, 2);
    for (x, y) in a.iter().zip(&b) {
        assert!(x
            .iter()
            .zip(y)
            .all(|(p, q)| p.to_bits() == q.to_bits() || (p.is_nan() && q.is_nan())));
    }
    // Bad values list what is accepted.
    let e = err("fuzzy_landform:class=summit");
    assert!(
        e.contains("peak, ridge, pass, plane, channel or pit"),
        "{e}"
    );
    let e = err("fuzzy_landform:scales=1,2");
    assert!(e.contains("unknown metric") || e.contains("scales"), "{e}");
    let e = err("fuzzy_landform:scales=1/x");
    assert!(e.contains("not a radius in cells"), "{e}");
    let e = err("fuzzy_landform:scales=2/40");
    assert!(e.contains("beyond the raster"), "{e}");
}
