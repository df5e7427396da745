//! The asymmetry index (`asymmetry_index`) against oracles that share no
//! code with it: direct loops over windows with full sorts for the
//! medians, closed forms on ridges; tiled == untiled bit for bit; bad
//! parameters.

#![allow(clippy::needless_range_loop)] // index loops read like the definitions

use crate::common::{
    assert_tiled_equals_untiled, check, facing_gradients, random_terrain_by, ridge, run1, source,
    spec_err as err, CELL,
};

/// Random terrain (smooth + noise, values rounded to 1/8) with nodata holes.
fn random_grid(w: usize, h: usize, seed: u64, holes: f64) -> Vec<f32> {
    // Short wavelengths in both axes: every window sees slopes facing all ways.
    random_terrain_by(w, h, seed, holes, 8.0, |x, y| {
        30.0 * (0.9 * x + 0.3 * y).sin() + 20.0 * (0.8 * y - 0.2 * x).cos()
    })
}

/// Median by a full sort (mean of the two middle values for an even count).
fn median(mut v: Vec<f64>) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(|a, b| a.partial_cmp(b).unwrap());
    let n = v.len();
    Some(if n % 2 == 1 {
        v[n / 2]
    } else {
        (v[n / 2 - 1] + v[n / 2]) / 2.0
    })
}

/// Poulos et al.'s index by its definition: the gradients of the window's
/// cells facing `az` ± `tol` and the opposite way (gradient > 5%), medians.
fn asymmetry_oracle(data: &[f32], w: usize, h: usize, r: i64, az: f64, tol: f64) -> Vec<f64> {
    (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as i64, (i / w) as i64);
            if data[i].is_nan() {
                return f64::NAN;
            }
            let (pos, neg) = facing_gradients(data, w, h, (x, y), r, az, tol);
            match (median(pos), median(neg)) {
                (Some(a), Some(b)) => (a / b).log10(),
                _ => f64::NAN,
            }
        })
        .collect()
}

// ---------- asymmetry index ----------

#[test]
fn asymmetry_index_brute_force() {
    let (w, h) = (29, 26);
    let data = random_grid(w, h, 7, 0.03);
    let src = source(&data, w, h);
    for (r, az, tol) in [
        (3i64, 0.0, 45.0),
        (5, 60.0, 30.0),
        (2, 270.0, 90.0),
        (8, 135.0, 45.0),
        (1, 0.0, 45.0),
    ] {
        let got = run1(
            &src,
            &format!("asymmetry_index:radius={r}c:azimuth={az}:tolerance={tol}"),
        );
        let want = asymmetry_oracle(&data, w, h, r, az, tol);
        let finite = want.iter().filter(|v| v.is_finite()).count();
        assert!(
            finite > w * h / 8,
            "oracle mostly nodata for r={r}: {finite}"
        );
        check("asymmetry_index", &got, &want, w, 1e-5, 1e-5);
    }
}

#[test]
fn asymmetry_index_ridges_and_a_skewed_side() {
    let (w, h, crest, r) = (15usize, 25usize, 12usize, 4usize);
    // 2:1 ridge: the medians are the two side gradients (the crest row's
    // (gn - gs)/2 is one row among several), so the index is log10 2
    // facing north and -log10 2 facing south.
    let (gn, gs) = (0.8, 0.4);
    let src = source(&ridge(w, h, crest, gn, gs), w, h);
    let n = run1(&src, &format!("asymmetry_index:radius={r}c"));
    let s = run1(&src, &format!("asymmetry_index:radius={r}c:azimuth=180"));
    let want = (gn / gs).log10();
    for y in crest - 2..=crest + 2 {
        for x in r + 1..w - r - 1 {
            let v = n[y * w + x] as f64;
            assert!((v - want).abs() < 1e-6, "({x},{y}) {v} want {want}");
            assert!((s[y * w + x] as f64 + want).abs() < 1e-6);
        }
    }
    // A symmetric ridge (0.4 m/m both sides) whose north side has one steep
    // step (3.0 m/m between rows crest-5 and crest-4): Horn's gradient is
    // 1.7 on those two rows, 0.4 elsewhere, 0 on the crest row (flat, left
    // out). In the radius-5 window at the crest, 2 of the 5 north rows are
    // steep: the median stays 0.4 (index 0), the mean becomes 0.92
    // (hillslope_asymmetry = log10(0.92 / 0.4) = 0.36).
    let r = 5usize;
    let mut prof = vec![0.0f64; h];
    for y in (0..crest).rev() {
        let g = if y == crest - 5 { 3.0 } else { 0.4 };
        prof[y] = prof[y + 1] - g * CELL;
    }
    for y in crest + 1..h {
        prof[y] = -0.4 * (y - crest) as f64 * CELL;
    }
    let d: Vec<f32> = (0..w * h).map(|i| prof[i / w] as f32).collect();
    let src = source(&d, w, h);
    let med = run1(&src, &format!("asymmetry_index:radius={r}c"));
    let mean = run1(&src, &format!("hillslope_asymmetry:radius={r}c"));
    let want = asymmetry_oracle(&d, w, h, r as i64, 0.0, 45.0);
    check("asymmetry_index (cliff)", &med, &want, w, 1e-5, 1e-5);
    let (x, y) = (w / 2, crest);
    let (a, b) = (med[y * w + x] as f64, mean[y * w + x] as f64);
    assert!(a.abs() < 1e-6, "median index at the crest {a}");
    let mean_n: f64 = (2.0 * 1.7 + 3.0 * 0.4) / 5.0;
    assert!(
        (b - (mean_n / 0.4).log10()).abs() < 1e-5,
        "mean index at the crest {b}"
    );
}

#[test]
fn asymmetry_index_plane_is_nodata() {
    let (w, h) = (12usize, 12usize);
    let plane: Vec<f32> = (0..w * h)
        .map(|i| (0.3 * (i / w) as f64 * CELL) as f32)
        .collect();
    let got = run1(&source(&plane, w, h), "asymmetry_index:radius=3c");
    assert!(got.iter().all(|v| v.is_nan()));
}

#[test]
fn tiled_equals_untiled_bit_for_bit() {
    let (w, h) = (41, 37);
    let data = random_grid(w, h, 23, 0.03);
    let src = source(&data, w, h);
    let specs = "asymmetry_index:radius=5c:azimuth=90,asymmetry_index:radius=2c:azimuth=250,asymmetry_index:radius=9c:azimuth=80:tolerance=60";
    assert_tiled_equals_untiled(&src, specs, w * h / 3);
}

#[test]
fn bad_parameters_are_clear_errors() {
    assert!(err("asymmetry_index:tolerance=0").contains("tolerance"));
    assert!(err("asymmetry_index:tolerance=120").contains("0 < tolerance <= 90"));
    assert!(err("asymmetry_index:radius=-3c").contains("asymmetry_index"));
    assert!(err("asymmetry_index:radius=50c").contains("beyond the raster"));
    assert!(err("asymmetry_index:azimuth=north").contains("azimuth"));
}
