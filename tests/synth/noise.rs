//! The noise family (`orogen::synth::noise`, `orogen synth noise`): tiles
//! generated alone equal the whole-grid generation bit for bit, every kind;
//! statistics; the power-law slope of spectral synthesis (measured with a
//! naive DFT written here); determinism across threads through the CLI; bad
//! parameters.

use orogen::raster::{RasterSource, Window};
use orogen::synth::{Noise, NoiseKind, NoiseSource};
use std::process::Command;

fn params(kind: NoiseKind) -> Noise {
    Noise {
        kind,
        seed: 7,
        wavelength: 64.0,
        octaves: 6,
        warp: 12.0,
        ..Default::default()
    }
}

fn field(n: &Noise, win: Window) -> Vec<f64> {
    let mut v = vec![0.0; win.len()];
    n.field(win, &mut v);
    v
}

/// Windows of `t` x `t` cells covering `region`, each generated alone,
/// equal the same cells of `whole` (bitwise).
fn check_tiles(n: &Noise, region: Window, whole: &[f64], t: usize) {
    let mut y = 0;
    while y < region.h {
        let mut x = 0;
        while x < region.w {
            let win = Window::new(
                region.x + x as i64,
                region.y + y as i64,
                t.min(region.w - x),
                t.min(region.h - y),
            );
            let part = field(n, win);
            for r in 0..win.h {
                for c in 0..win.w {
                    let a = part[r * win.w + c];
                    let b = whole[(y + r) * region.w + x + c];
                    assert_eq!(
                        a.to_bits(),
                        b.to_bits(),
                        "{:?}: tile {t} at ({}, {}), cell ({}, {}): {a} != {b}",
                        n.kind,
                        win.x,
                        win.y,
                        c,
                        r
                    );
                }
            }
            x += t;
        }
        y += t;
    }
}

#[test]
fn tiles_alone_equal_the_whole_grid_every_kind() {
    // Near the origin and far out (coordinates of a 100000-cell raster).
    for region in [
        Window::new(0, 0, 300, 280),
        Window::new(99_600, 71_234, 300, 280),
    ] {
        for kind in NoiseKind::ALL {
            let n = params(kind);
            let whole = field(&n, region);
            for t in [7, 100, 257] {
                check_tiles(&n, region, &whole, t);
            }
            // Tiles of one cell: 150 cells spread over the region.
            for k in 0..150usize {
                let (c, r) = ((k * 97) % region.w, (k * 61 + k / 7) % region.h);
                let v = field(
                    &n,
                    Window::new(region.x + c as i64, region.y + r as i64, 1, 1),
                );
                assert_eq!(
                    v[0].to_bits(),
                    whole[r * region.w + c].to_bits(),
                    "{kind:?}: one-cell tile ({c}, {r})"
                );
            }
        }
    }
}

#[test]
fn source_reads_equal_field_and_elevation_formula() {
    for kind in NoiseKind::ALL {
        let n = params(kind);
        let src = NoiseSource::new(n.clone(), 100_000, 100_000, 30.0).unwrap();
        let win = Window::new(40_000, 123, 33, 17);
        let g = src.read_native(win).unwrap();
        let v = field(&n, win);
        for r in 0..win.h {
            for c in 0..win.w {
                let want = (n.base + n.amplitude * v[r * win.w + c]) as f32;
                assert_eq!(g.get_f64(c, r), want as f64);
            }
        }
    }
}

fn stats(v: &[f64]) -> (f64, f64, f64, f64) {
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let sd = (v.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / n).sqrt();
    let lo = v.iter().cloned().fold(f64::INFINITY, f64::min);
    let hi = v.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    (mean, sd, lo, hi)
}

#[test]
fn statistics_are_sane() {
    let win = Window::new(1000, 2000, 512, 512);
    for kind in NoiseKind::ALL {
        let n = Noise {
            wavelength: 128.0,
            ..params(kind)
        };
        let (mean, sd, lo, hi) = stats(&field(&n, win));
        eprintln!("{kind:?}: mean {mean:.4} sd {sd:.4} range [{lo:.4}, {hi:.4}]");
        assert!(sd > 0.05 && sd < 0.6, "{kind:?}: sd {sd}");
        assert!(hi - lo > 0.4, "{kind:?}: range {lo}..{hi}");
        match kind {
            // Bounded by construction.
            // Billow is 2|n| - 1: |n| averages about a quarter.
            NoiseKind::Billow => {
                assert!(lo >= -1.0 && hi <= 1.0, "{kind:?}: {lo}..{hi}");
                assert!(mean > -0.75 && mean < -0.25, "{kind:?}: mean {mean}");
            }
            NoiseKind::Fbm | NoiseKind::Simplex => {
                assert!(lo >= -1.0 && hi <= 1.0, "{kind:?}: {lo}..{hi}");
                assert!(mean.abs() < 0.25, "{kind:?}: mean {mean}");
            }
            NoiseKind::Ridged | NoiseKind::Warped => {
                assert!(lo >= -1.0 && hi <= 1.0, "{kind:?}: {lo}..{hi}");
                assert!(mean.abs() < 0.8, "{kind:?}: mean {mean}");
            }
            // Gaussian-like: scaled to about three standard deviations.
            NoiseKind::DiamondSquare | NoiseKind::Spectral => {
                assert!(lo > -2.0 && hi < 2.0, "{kind:?}: {lo}..{hi}");
                assert!(mean.abs() < 0.5, "{kind:?}: mean {mean}");
            }
        }
    }
    // Plain fBm of gradient noise has mean ~0 over many wavelengths.
    let n = Noise {
        wavelength: 32.0,
        ..params(NoiseKind::Fbm)
    };
    let (mean, _, _, _) = stats(&field(&n, win));
    assert!(mean.abs() < 0.05, "fbm mean {mean}");
    // Different seeds give different terrain.
    let a = field(&params(NoiseKind::Spectral), Window::new(0, 0, 64, 64));
    let b = field(
        &Noise {
            seed: 8,
            ..params(NoiseKind::Spectral)
        },
        Window::new(0, 0, 64, 64),
    );
    assert_ne!(a, b);
}

/// Radially averaged power spectrum of an n x n field (Hann-windowed
/// periodogram by a naive separable DFT), power per integer radius.
fn radial_spectrum(v: &[f64], n: usize) -> Vec<f64> {
    let hann: Vec<f64> = (0..n)
        .map(|i| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / n as f64).cos())
        .collect();
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    let (cs, sn): (Vec<f64>, Vec<f64>) = (0..n)
        .map(|k| {
            let a = 2.0 * std::f64::consts::PI * k as f64 / n as f64;
            (a.cos(), a.sin())
        })
        .unzip();
    // DFT along x for every row.
    let mut re = vec![0.0; n * n];
    let mut im = vec![0.0; n * n];
    for y in 0..n {
        for k in 0..n {
            let (mut a, mut b) = (0.0, 0.0);
            for x in 0..n {
                let s = (v[y * n + x] - mean) * hann[x] * hann[y];
                let t = (k * x) % n;
                a += s * cs[t];
                b -= s * sn[t];
            }
            re[y * n + k] = a;
            im[y * n + k] = b;
        }
    }
    // DFT along y, then accumulate |F|² by radius.
    let mut sum = vec![0.0; n];
    let mut cnt = vec![0usize; n];
    for k in 0..n {
        for l in 0..n {
            let (mut a, mut b) = (0.0, 0.0);
            for y in 0..n {
                let t = (l * y) % n;
                let (c, s) = (cs[t], sn[t]);
                a += re[y * n + k] * c + im[y * n + k] * s;
                b += im[y * n + k] * c - re[y * n + k] * s;
            }
            let fx = if k <= n / 2 {
                k as f64
            } else {
                k as f64 - n as f64
            };
            let fy = if l <= n / 2 {
                l as f64
            } else {
                l as f64 - n as f64
            };
            let r = (fx * fx + fy * fy).sqrt().round() as usize;
            if r < n {
                sum[r] += a * a + b * b;
                cnt[r] += 1;
            }
        }
    }
    sum.iter()
        .zip(&cnt)
        .map(|(s, &c)| if c > 0 { s / c as f64 } else { 0.0 })
        .collect()
}

/// Least-squares slope of log P against log f over radii [r0, r1].
fn loglog_slope(p: &[f64], r0: usize, r1: usize) -> f64 {
    let pts: Vec<(f64, f64)> = (r0..=r1).map(|r| ((r as f64).ln(), p[r].ln())).collect();
    let n = pts.len() as f64;
    let mx = pts.iter().map(|p| p.0).sum::<f64>() / n;
    let my = pts.iter().map(|p| p.1).sum::<f64>() / n;
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx) * (p.0 - mx)).sum();
    sxy / sxx
}

#[test]
fn spectral_synthesis_has_the_power_law_slope() {
    let n = 128;
    for beta in [2.0, 3.0] {
        let p = Noise {
            kind: NoiseKind::Spectral,
            beta,
            wavelength: 1024.0,
            seed: 3,
            ..Default::default()
        };
        // Average the spectra of 4 windows to tame the periodogram's variance.
        let mut avg = vec![0.0; n];
        for k in 0..4 {
            let v = field(&p, Window::new(k * 5000, 777 * k, n, n));
            for (a, s) in avg.iter_mut().zip(radial_spectrum(&v, n)) {
                *a += s;
            }
        }
        // Radii 4..56 of 128: wavelengths from 32 cells down to 2.3 cells,
        // across four octave bands (band 0 and three interpolated bands).
        let slope = loglog_slope(&avg, 4, 56);
        eprintln!("beta {beta}: measured slope {slope:.3}");
        assert!(
            (slope + beta).abs() < 0.3,
            "beta {beta}: radially averaged power spectrum slope {slope}"
        );
    }
}

fn orogen() -> Command {
    Command::new(env!("CARGO_BIN_EXE_orogen"))
}

fn run_ok(cmd: &mut Command) {
    let out = cmd.output().unwrap();
    assert!(
        out.status.success(),
        "{cmd:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

fn run_err(cmd: &mut Command) -> String {
    let out = cmd.output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(1), "{cmd:?}: {err}");
    assert!(!err.contains("panicked"), "{cmd:?}: {err}");
    assert!(err.starts_with("error: "), "{cmd:?}: {err}");
    err
}

#[test]
fn cli_same_bytes_for_any_thread_count_and_work_tile() {
    let dir = tempfile::tempdir().unwrap();
    for kind in [
        "fbm",
        "ridged",
        "billow",
        "simplex",
        "warped",
        "diamond-square",
        "spectral",
    ] {
        let mut outs = Vec::new();
        for (threads, tile) in [("1", "1024"), ("2", "64"), ("2", "100")] {
            let p = dir.path().join(format!("{kind}_{threads}_{tile}.tif"));
            run_ok(
                orogen()
                    .args(["synth", "noise", "--kind", kind, "--size", "300x200"])
                    .args(["--wavelength", "100", "--seed", "5", "-q"])
                    .args(["--threads", threads, "--tile", tile, "-o"])
                    .arg(&p),
            );
            outs.push(std::fs::read(&p).unwrap());
        }
        assert_eq!(outs[0], outs[1], "{kind}: 1 vs 2 threads");
        assert_eq!(outs[0], outs[2], "{kind}: work tile 1024 vs 100");
    }
    // A zstd tile store equals the GeoTIFF, cell for cell (info --stats).
    let store = dir.path().join("s.tiles");
    run_ok(
        orogen()
            .args(["synth", "noise", "--kind", "warped", "--size", "300x200"])
            .args(["--wavelength", "100", "--seed", "5", "-q", "--zstd"])
            .args(["--store-tile", "64", "-o"])
            .arg(&store),
    );
    let stats = |p: &std::path::Path| {
        let out = orogen()
            .args(["info", "--json", "--stats"])
            .arg(p)
            .output()
            .unwrap();
        let s = String::from_utf8_lossy(&out.stdout).into_owned();
        let j: serde_json::Value = serde_json::from_str(&s[..s.rfind('}').unwrap() + 1]).unwrap();
        j["stats"].clone()
    };
    assert_eq!(stats(&store), stats(&dir.path().join("warped_1_1024.tif")));
}

#[test]
fn bad_parameters_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let o = dir.path().join("x.tif");
    for (args, needle) in [
        (vec!["--octaves", "0"], "octaves"),
        (vec!["--gain", "1"], "gain"),
        (vec!["--gain", "NaN"], "gain"),
        (vec!["--size", "0"], "size"),
        (vec!["--size", "0x5"], "size"),
        (vec!["--wavelength", "1"], "wavelength"),
        (vec!["--octaves", "24"], "finest octave"),
        (
            vec!["--kind", "spectral", "--lacunarity", "3"],
            "lacunarity",
        ),
        (vec!["--kind", "spectral", "--beta", "9"], "beta"),
        (vec!["--kind", "warped", "--blend", "2"], "blend"),
        (vec!["--kind", "ridged", "--ridge-offset", "0"], "offset"),
        (vec!["--cell=-3"], "cell"),
    ] {
        let err = run_err(
            orogen()
                .args(["synth", "noise", "-q"])
                .args(&args)
                .arg("-o")
                .arg(&o),
        );
        assert!(err.contains(needle), "{args:?}: {err}");
        assert!(!o.exists(), "{args:?} left {o:?} behind");
    }
    // The library says the same.
    let bad = Noise {
        octaves: 0,
        ..Default::default()
    };
    assert!(NoiseSource::new(bad, 10, 10, 1.0).is_err());
    assert!(NoiseSource::new(Noise::default(), 0, 10, 1.0).is_err());
    assert!(NoiseSource::new(Noise::default(), 10, 10, f64::NAN).is_err());
}

/// Diamond-square against the textbook in-place algorithm on one finite
/// array (Fournier et al. 1982 / Miller 1986 loop structure), fed with the
/// same counter-based random numbers: the tiled, level-cropped
/// implementation must give the same field far from the array's border.
#[test]
fn diamond_square_equals_the_in_place_algorithm() {
    use orogen::synth::diamond_square::{displacement, levels};
    let p = Noise {
        kind: NoiseKind::DiamondSquare,
        wavelength: 16.0,
        gain: 0.6,
        seed: 11,
        ..Default::default()
    };
    let l_max = levels(p.wavelength);
    let s = 1i64 << l_max;
    assert_eq!(s, 16);
    // The array covers global [-2S, 3S]²; every point of [0, S]² depends
    // only on points closer than 2S.
    let n = (5 * s + 1) as usize;
    let g = |i: usize| i as i64 - 2 * s;
    let mut a = vec![f64::NAN; n * n];
    for y in (0..n).step_by(s as usize) {
        for x in (0..n).step_by(s as usize) {
            a[y * n + x] = displacement(p.seed, 0, g(x), g(y));
        }
    }
    let mut sigma = 1.0;
    let mut var = 1.0;
    for l in 1..=l_max {
        sigma *= p.gain;
        var += sigma * sigma;
        let half = (s >> l) as usize;
        let step = 2 * half;
        // Square step: centres of the squares of side `step`.
        for y in (half..n - half).step_by(step) {
            for x in (half..n - half).step_by(step) {
                let m = (a[(y - half) * n + x - half]
                    + a[(y - half) * n + x + half]
                    + a[(y + half) * n + x - half]
                    + a[(y + half) * n + x + half])
                    / 4.0;
                a[y * n + x] = m + sigma * displacement(p.seed, l, g(x), g(y));
            }
        }
        // Diamond step: edge midpoints, skipped on the array's border.
        for y in (0..n).step_by(half) {
            let x0 = if (y / half).is_multiple_of(2) {
                half
            } else {
                0
            };
            for x in (x0..n).step_by(step) {
                if x < half || y < half || x + half >= n || y + half >= n {
                    continue;
                }
                let m = (a[y * n + x - half]
                    + a[y * n + x + half]
                    + a[(y - half) * n + x]
                    + a[(y + half) * n + x])
                    / 4.0;
                a[y * n + x] = m + sigma * displacement(p.seed, l, g(x), g(y));
            }
        }
    }
    let k = 1.0 / (2.5 * f64::sqrt(var));
    let win = Window::new(0, 0, s as usize + 1, s as usize + 1);
    let v = field(&p, win);
    for y in 0..=s as usize {
        for x in 0..=s as usize {
            let want = a[(y + 2 * s as usize) * n + x + 2 * s as usize] * k;
            let got = v[y * win.w + x];
            assert!((got - want).abs() < 1e-12, "({x}, {y}): {got} vs {want}");
        }
    }
}

/// The row kernel of fbm, billow and ridged (gradients folded into A·fx + B
/// per lattice column, runs of cells) against sums of the point-by-point
/// gradient noise `lattice_noise` (the textbook bilinear blend of the four
/// corner dot products), with the ridged multifractal's recurrence written
/// out here (Musgrave 2003).
#[test]
fn row_kernel_equals_pointwise_sums() {
    use orogen::synth::noise::lattice_noise;
    let win = Window::new(12_345, 678, 97, 53);
    for kind in [NoiseKind::Fbm, NoiseKind::Billow, NoiseKind::Ridged] {
        let p = Noise {
            wavelength: 40.0,
            octaves: 7,
            ..params(kind)
        };
        let octs = p.octaves();
        let norm: f64 = octs.iter().map(|o| o.1).sum();
        let v = field(&p, win);
        for r in 0..win.h {
            for c in 0..win.w {
                let x = (win.x + c as i64) as f64 + 0.5;
                let y = (win.y + r as i64) as f64 + 0.5;
                let (mut sum, mut wt) = (0.0, 1.0f64);
                for (o, amp) in &octs {
                    let n = lattice_noise(x * o.freq + o.ox, y * o.freq + o.oy, o.seed);
                    sum += amp
                        * match kind {
                            NoiseKind::Fbm => n,
                            NoiseKind::Billow => 2.0 * n.abs() - 1.0,
                            _ => {
                                let s = (p.ridge_offset - n.abs()).powi(2) * wt;
                                wt = (s * p.ridge_gain).clamp(0.0, 1.0);
                                s
                            }
                        };
                }
                let want = match kind {
                    NoiseKind::Ridged => 2.0 * sum / (norm * p.ridge_offset.powi(2)) - 1.0,
                    _ => sum / norm,
                };
                let got = v[r * win.w + c];
                assert!(
                    (got - want).abs() < 1e-12,
                    "{kind:?} ({c}, {r}): {got} vs {want}"
                );
            }
        }
    }
    // Gradient noise vanishes at lattice points.
    for (ix, iy) in [(0, 0), (5, -3), (100_000, 7)] {
        assert_eq!(lattice_noise(ix as f64, iy as f64, 99), 0.0);
    }
}
