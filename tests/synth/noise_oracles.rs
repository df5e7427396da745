//! The lattice-noise kinds against their papers' definitions, through the
//! public field only (no hash, no kernel of the generator is used here).
//!
//! - fBm (Musgrave 2003, ch. 16) is Σ aₖ nₖ / Σ aₖ: the octaves nₖ are
//!   recovered from the fields of 1, 2, … K octaves (the first k octaves of
//!   any noise are the same), at the frequencies and lattice offsets
//!   [`Noise::octaves`] states.
//! - Each octave is Perlin's gradient noise ("Improving Noise", SIGGRAPH
//!   2002): inside a lattice cell, √2·Σ_corners w(u)w(v)·(g·d) with the
//!   quintic fade 6t⁵ − 15t⁴ + 10t³. That is linear in the four corner
//!   gradients, so they are fitted by least squares to the cell's samples;
//!   the fit must be exact (residual ≤ 1e-9), every gradient a unit vector in
//!   one of the 32 directions k·11.25° the module documents, the same
//!   gradient seen from all four cells around a lattice point (continuity),
//!   and the directions spread over the 32.
//! - Billow (Perlin 1985, each octave folded to 2|n| − 1) and the ridged
//!   multifractal (Musgrave 2003: s = (offset − |n|)² times the previous
//!   octave's weight, weight = clamp(s·gain, 0, 1), rescaled to [-1, 1] by
//!   2/(Σaₖ·offset²) − 1) are rebuilt from the recovered octaves.
//! - Simplex noise (Perlin 2001, as in Gustavson 2005): inside each
//!   simplex, Σ over its three corners of (0.5 − |d|²)⁴·(G·d), linear in
//!   the three scaled gradients G: fitted the same way, exact, all of one
//!   length (the normalisation) and on the 32 directions.
//!
//! Domain-warped noise is not covered here (its warp uses seeds the public
//! API does not expose); diamond-square and spectral synthesis have their
//! own oracles in `noise.rs`.

use orogen::raster::Window;
use orogen::synth::{Noise, NoiseKind};

fn field(n: &Noise, win: Window) -> Vec<f64> {
    let mut v = vec![0.0; win.len()];
    n.field(win, &mut v);
    v
}

fn fade(t: f64) -> f64 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

/// Solves the least-squares problem min |A x − b| (rows of `a`, `n`
/// unknowns) by the normal equations and Gaussian elimination with partial
/// pivoting; returns x and the largest absolute residual.
fn least_squares(rows: &[(Vec<f64>, f64)], n: usize) -> (Vec<f64>, f64) {
    let mut m = vec![vec![0.0; n + 1]; n];
    for (a, b) in rows {
        for i in 0..n {
            for j in 0..n {
                m[i][j] += a[i] * a[j];
            }
            m[i][n] += a[i] * b;
        }
    }
    for c in 0..n {
        let p = (c..n)
            .max_by(|&i, &j| m[i][c].abs().total_cmp(&m[j][c].abs()))
            .unwrap();
        m.swap(c, p);
        assert!(m[c][c].abs() > 1e-18, "singular fit");
        let pivot = m[c].clone();
        for (r, row) in m.iter_mut().enumerate() {
            if r != c {
                let f = row[c] / pivot[c];
                for (x, p) in row[c..].iter_mut().zip(&pivot[c..]) {
                    *x -= f * p;
                }
            }
        }
    }
    let x: Vec<f64> = (0..n).map(|i| m[i][n] / m[i][i]).collect();
    let res = rows
        .iter()
        .map(|(a, b)| (a.iter().zip(&x).map(|(p, q)| p * q).sum::<f64>() - b).abs())
        .fold(0.0, f64::max);
    (x, res)
}

/// Checks a fitted gradient: length `len` (relative 1e-6) and a direction
/// k·11.25°; returns k.
fn direction_of(g: (f64, f64), len: f64, what: &str) -> usize {
    let l = (g.0 * g.0 + g.1 * g.1).sqrt();
    assert!(
        (l - len).abs() <= 1e-6 * len,
        "{what}: |g| = {l}, expected {len}"
    );
    let k = g.1.atan2(g.0).rem_euclid(std::f64::consts::TAU) / (std::f64::consts::TAU / 32.0);
    assert!(
        (k - k.round()).abs() < 1e-5,
        "{what}: direction {k} x 11.25 deg is not one of the 32"
    );
    k.round() as usize % 32
}

/// Fits every lattice cell of one octave of gradient noise sampled at the
/// cells of `win` (values `v`, lattice coordinates x' = (c + ½)·freq + ox);
/// asserts the fit is exact and the gradients unit, on the 32 directions and
/// continuous; returns how many lattice points and which directions were seen.
fn check_perlin_octave(
    v: &[f64],
    win: Window,
    freq: f64,
    ox: f64,
    oy: f64,
    what: &str,
) -> (usize, [bool; 32]) {
    use std::collections::HashMap;
    // per lattice cell: (fx, fy, value) of its samples
    type Samples = Vec<(f64, f64, f64)>;
    let mut cells: HashMap<(i64, i64), Samples> = HashMap::new();
    for r in 0..win.h {
        for c in 0..win.w {
            let x = ((win.x + c as i64) as f64 + 0.5) * freq + ox;
            let y = ((win.y + r as i64) as f64 + 0.5) * freq + oy;
            let (ix, iy) = (x.floor() as i64, y.floor() as i64);
            cells.entry((ix, iy)).or_default().push((
                x - ix as f64,
                y - iy as f64,
                v[r * win.w + c],
            ));
        }
    }
    let mut grads: HashMap<(i64, i64), (f64, f64)> = HashMap::new();
    let mut seen = [false; 32];
    let s2 = std::f64::consts::SQRT_2;
    let mut fitted = 0;
    for (&(ix, iy), pts) in &cells {
        if pts.len() < 24 {
            continue; // a sliver of a cell at the window's edge
        }
        fitted += 1;
        let rows: Vec<(Vec<f64>, f64)> = pts
            .iter()
            .map(|&(fx, fy, n)| {
                let (u, w) = (fade(fx), fade(fy));
                let (c00, c10, c01, c11) =
                    ((1.0 - u) * (1.0 - w), u * (1.0 - w), (1.0 - u) * w, u * w);
                (
                    vec![
                        s2 * c00 * fx,
                        s2 * c00 * fy,
                        s2 * c10 * (fx - 1.0),
                        s2 * c10 * fy,
                        s2 * c01 * fx,
                        s2 * c01 * (fy - 1.0),
                        s2 * c11 * (fx - 1.0),
                        s2 * c11 * (fy - 1.0),
                    ],
                    n,
                )
            })
            .collect();
        let (g, res) = least_squares(&rows, 8);
        assert!(
            res <= 1e-9,
            "{what}: cell ({ix}, {iy}) is not Perlin's interpolation (residual {res})"
        );
        for (k, (dx, dy)) in [(0, 0), (1, 0), (0, 1), (1, 1)].into_iter().enumerate() {
            let gk = (g[2 * k], g[2 * k + 1]);
            seen[direction_of(gk, 1.0, what)] = true;
            let p = (ix + dx, iy + dy);
            if let Some(&prev) = grads.get(&p) {
                assert!(
                    (prev.0 - gk.0).abs() < 1e-6 && (prev.1 - gk.1).abs() < 1e-6,
                    "{what}: lattice point {p:?} has gradient {prev:?} in one cell and {gk:?} in another"
                );
            } else {
                grads.insert(p, gk);
            }
        }
    }
    assert!(fitted > 0, "{what}: no whole lattice cell in the window");
    (grads.len(), seen)
}

fn fbm(seed: u64, octaves: u32) -> Noise {
    Noise {
        kind: NoiseKind::Fbm,
        seed,
        octaves,
        wavelength: 40.0,
        lacunarity: 2.0,
        gain: 0.5,
        ..Noise::default()
    }
}

/// The octaves n₀ … n_{K−1} of the K-octave fBm of `base`, recovered from the
/// fields of 1 … K octaves: F_{k+1}·N_{k+1} − F_k·N_k = a_k·n_k.
fn octaves_of(base: &Noise, win: Window) -> Vec<Vec<f64>> {
    let octs = base.octaves();
    let mut prev = vec![0.0; win.len()];
    let mut norm_prev = 0.0;
    let mut out = Vec::new();
    for (k, (_, amp)) in octs.iter().enumerate() {
        let f = field(
            &Noise {
                octaves: k as u32 + 1,
                ..base.clone()
            },
            win,
        );
        let norm = norm_prev + amp;
        out.push(
            f.iter()
                .zip(&prev)
                .map(|(a, b)| (a * norm - b * norm_prev) / amp)
                .collect(),
        );
        prev = f;
        norm_prev = norm;
    }
    out
}

#[test]
fn fbm_is_a_sum_of_perlin_gradient_noise_octaves() {
    let win = Window::new(12_345, -6_789, 200, 160);
    for seed in [7u64, 1 << 40] {
        let base = fbm(seed, 4);
        let octs = base.octaves();
        // the stated frequencies and amplitudes
        for (k, (o, a)) in octs.iter().enumerate() {
            assert!((o.freq - 2f64.powi(k as i32) / 40.0).abs() < 1e-15);
            assert!((a - 0.5f64.powi(k as i32)).abs() < 1e-15);
        }
        let ns = octaves_of(&base, win);
        let mut seen = [false; 32];
        let mut points = 0;
        for (k, n) in ns.iter().enumerate() {
            let o = octs[k].0;
            let (p, s) = check_perlin_octave(
                n,
                win,
                o.freq,
                o.ox,
                o.oy,
                &format!("seed {seed} octave {k}"),
            );
            points += p;
            for d in 0..32 {
                seen[d] |= s[d];
            }
            // octaves with different seeds are different fields
            if k > 0 {
                assert_ne!(ns[k], ns[k - 1]);
            }
        }
        assert!(points > 1500, "{points} lattice points fitted");
        let dirs = seen.iter().filter(|&&s| s).count();
        assert_eq!(
            dirs, 32,
            "seed {seed}: only {dirs} of the 32 gradient directions occur"
        );
    }
}

#[test]
fn billow_and_ridged_are_musgraves_sums_of_the_same_octaves() {
    let win = Window::new(-3_000, 777, 120, 90);
    let base = fbm(11, 5);
    let ns = octaves_of(&base, win);
    let amps: Vec<f64> = base.octaves().iter().map(|o| o.1).collect();
    let norm: f64 = amps.iter().sum();
    let billow = field(
        &Noise {
            kind: NoiseKind::Billow,
            ..base.clone()
        },
        win,
    );
    for (i, &got) in billow.iter().enumerate() {
        let want: f64 = ns
            .iter()
            .zip(&amps)
            .map(|(n, a)| a * (2.0 * n[i].abs() - 1.0))
            .sum::<f64>()
            / norm;
        assert!(
            (got - want).abs() < 1e-12,
            "billow cell {i}: {got} vs {want}"
        );
    }
    for (offset, gain) in [(1.0, 2.0), (0.8, 3.0)] {
        let ridged = field(
            &Noise {
                kind: NoiseKind::Ridged,
                ridge_offset: offset,
                ridge_gain: gain,
                ..base.clone()
            },
            win,
        );
        for (i, &got) in ridged.iter().enumerate() {
            let (mut sum, mut weight) = (0.0, 1.0f64);
            for (n, a) in ns.iter().zip(&amps) {
                let s = (offset - n[i].abs()).powi(2) * weight;
                weight = (s * gain).clamp(0.0, 1.0);
                sum += a * s;
            }
            let want = 2.0 * sum / (norm * offset * offset) - 1.0;
            assert!(
                (got - want).abs() < 1e-12,
                "ridged (offset {offset}, gain {gain}) cell {i}: {got} vs {want}"
            );
        }
    }
}

#[test]
fn simplex_octave_is_gustavsons_simplex_noise() {
    use std::collections::HashMap;
    // Skew and unskew of the 2-D simplex lattice (Gustavson 2005).
    let f2 = (3f64.sqrt() - 1.0) / 2.0;
    let g2 = (3.0 - 3f64.sqrt()) / 6.0;
    let win = Window::new(5_000, 9_000, 150, 150);
    let noise = Noise {
        kind: NoiseKind::Simplex,
        seed: 3,
        octaves: 1,
        wavelength: 24.0,
        ..Noise::default()
    };
    let o = noise.octaves()[0].0;
    let v = field(&noise, win);
    // samples grouped by simplex: (i, j, upper)
    type Sample = (f64, f64, f64);
    let mut simplices: HashMap<(i64, i64, bool), Vec<Sample>> = HashMap::new();
    for r in 0..win.h {
        for c in 0..win.w {
            let x = ((win.x + c as i64) as f64 + 0.5) * o.freq + o.ox;
            let y = ((win.y + r as i64) as f64 + 0.5) * o.freq + o.oy;
            let s = (x + y) * f2;
            let (i, j) = ((x + s).floor(), (y + s).floor());
            let t = (i + j) * g2;
            let (x0, y0) = (x - (i - t), y - (j - t));
            simplices
                .entry((i as i64, j as i64, x0 <= y0))
                .or_default()
                .push((x0, y0, v[r * win.w + c]));
        }
    }
    let mut grads: HashMap<(i64, i64), (f64, f64)> = HashMap::new();
    let mut seen = [false; 32];
    let mut scale = None;
    for (&(i, j, upper), pts) in &simplices {
        if pts.len() < 40 {
            continue;
        }
        let (i1, j1) = if upper { (0, 1) } else { (1, 0) };
        // corners: (offset in lattice, displacement from the sample)
        let corners = |x0: f64, y0: f64| {
            [
                ((0i64, 0i64), (x0, y0)),
                ((i1, j1), (x0 - i1 as f64 + g2, y0 - j1 as f64 + g2)),
                ((1, 1), (x0 - 1.0 + 2.0 * g2, y0 - 1.0 + 2.0 * g2)),
            ]
        };
        let rows: Vec<(Vec<f64>, f64)> = pts
            .iter()
            .map(|&(x0, y0, n)| {
                let mut a = Vec::with_capacity(6);
                for (_, (dx, dy)) in corners(x0, y0) {
                    let t = (0.5 - dx * dx - dy * dy).max(0.0);
                    let t4 = t * t * t * t;
                    a.push(t4 * dx);
                    a.push(t4 * dy);
                }
                (a, n)
            })
            .collect();
        let (g, res) = least_squares(&rows, 6);
        assert!(
            res <= 1e-9,
            "simplex ({i}, {j}, {upper}): not Gustavson's sum (residual {res})"
        );
        for (k, ((di, dj), _)) in corners(0.0, 0.0).into_iter().enumerate() {
            let gk = (g[2 * k], g[2 * k + 1]);
            let len = *scale.get_or_insert((gk.0 * gk.0 + gk.1 * gk.1).sqrt());
            seen[direction_of(gk, len, "simplex")] = true;
            let p = (i + di, j + dj);
            if let Some(&prev) = grads.get(&p) {
                assert!(
                    (prev.0 - gk.0).abs() < 1e-6 * len && (prev.1 - gk.1).abs() < 1e-6 * len,
                    "simplex lattice point {p:?}: {prev:?} vs {gk:?}"
                );
            } else {
                grads.insert(p, gk);
            }
        }
    }
    assert!(grads.len() > 40, "{} lattice points", grads.len());
    assert!(
        seen.iter().filter(|&&s| s).count() >= 28,
        "directions {seen:?}"
    );
    // The normalisation keeps the field within [-1, 1] (the module's claim)
    // and uses most of it.
    let (lo, hi) = v
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &x| (a.min(x), b.max(x)));
    assert!(lo >= -1.0 && hi <= 1.0 && hi - lo > 1.0, "range {lo}..{hi}");
}
