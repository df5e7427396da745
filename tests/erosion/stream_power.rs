//! Stream power (Braun & Willett 2013), constrained erosion (Argudo et al.
//! 2019 §6.3) and multi-resolution erosion: library and CLI checks against
//! oracles that share no code with the solver (closed-form steady state with
//! receivers and areas recomputed by brute force, closed-form resampling).

use orogen::erosion::constrained::{erode_constrained, ConstrainedParams};
use orogen::erosion::multires::erode_multires;
use orogen::erosion::stream_power::{
    stream_power, BaseHeight, Boundary, Depressions, StreamPower, StreamPowerParams, Uplift,
};
use orogen::raster::Grid;
use std::path::Path;
use std::process::Command;

/// Deterministic pseudo-random numbers in [0, 1) (64-bit LCG, top bits).
fn rng(seed: u64) -> impl FnMut() -> f64 {
    let mut s = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn noisy_block(w: usize, h: usize, amp: f64, seed: u64) -> Grid<f64> {
    let mut r = rng(seed);
    Grid::from_fn(w, h, |_, _| amp * r())
}

/// Oracle: steepest-descent receiver (largest drop / distance among strictly
/// lower 8-neighbours) recomputed from the final heights.
fn oracle_receiver(g: &Grid<f64>, x: usize, y: usize, cell: f64) -> Option<(usize, usize, f64)> {
    let mut best: Option<(usize, usize, f64, f64)> = None;
    for (dx, dy) in crate::common::EAST8 {
        let (nx, ny) = (x as i64 + dx, y as i64 + dy);
        if nx < 0 || ny < 0 || nx >= g.width() as i64 || ny >= g.height() as i64 {
            continue;
        }
        let d = cell * ((dx * dx + dy * dy) as f64).sqrt();
        let s = (g.get(x, y) - g.get(nx as usize, ny as usize)) / d;
        if s > 0.0 && best.is_none_or(|b| s > b.3) {
            best = Some((nx as usize, ny as usize, d, s));
        }
    }
    best.map(|b| (b.0, b.1, b.2))
}

/// Run to steady state on a uniformly uplifted block and check, on every
/// interior cell, s = (u/K)^(1/n) · A^(−m/n) with A counted by walking every
/// cell's path down the oracle receivers.
fn steady_state(n_exp: f64, dep: Depressions) {
    let (w, h, cell) = (48usize, 40usize, 100.0);
    let (u, k, m) = (1e-3, 1e-5, 0.5);
    let mut g = noisy_block(w, h, 1.0, 7);
    let p = StreamPowerParams {
        k,
        m,
        n: n_exp,
        dt: 2e4,
        depressions: dep,
        base_height: BaseHeight::Zero,
        ..Default::default()
    };
    let mut sp = StreamPower::new(&mut g, cell, &p).unwrap();
    let mut converged = false;
    for _ in 0..20000 {
        let before = g.clone();
        sp.step(&mut g, &Uplift::Uniform(u)).unwrap();
        let change = g
            .data()
            .iter()
            .zip(before.data())
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        if change < 1e-9 {
            converged = true;
            break;
        }
    }
    assert!(converged, "no steady state (n = {n_exp})");
    // Oracle areas: each cell adds its area to every cell on its downstream path.
    let mut area = vec![0.0f64; w * h];
    for y0 in 0..h {
        for x0 in 0..w {
            let (mut x, mut y) = (x0, y0);
            loop {
                area[y * w + x] += cell * cell;
                if x == 0 || y == 0 || x == w - 1 || y == h - 1 {
                    break;
                }
                let (nx, ny, _) = oracle_receiver(&g, x, y, cell)
                    .unwrap_or_else(|| panic!("interior pit at {x},{y} at steady state"));
                x = nx;
                y = ny;
            }
        }
    }
    let mut checked = 0;
    let mut worst = 0.0f64;
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let (rx, ry, d) = oracle_receiver(&g, x, y, cell).unwrap();
            let s = (g.get(x, y) - g.get(rx, ry)) / d;
            let a = area[y * w + x];
            let expect = (u / k).powf(1.0 / n_exp) * a.powf(-m / n_exp);
            let rel = (s - expect).abs() / expect;
            worst = worst.max(rel);
            checked += 1;
        }
    }
    assert_eq!(checked, (w - 2) * (h - 2));
    assert!(
        worst < 1e-4,
        "n = {n_exp}: slope-area relation off by {worst:.2e}"
    );
    // The relation is not trivially met: the relief is large and varied.
    let max = g.data().iter().cloned().fold(0.0, f64::max);
    assert!(max > 50.0, "relief {max}");
}

#[test]
fn steady_state_slope_area_n1() {
    steady_state(1.0, Depressions::Fill);
}

#[test]
fn steady_state_slope_area_n2() {
    steady_state(2.0, Depressions::Fill);
}

#[test]
fn steady_state_slope_area_basin_graph() {
    steady_state(1.0, Depressions::BasinGraph);
}

/// A step with an enormous dt stays finite, never raises a cell without
/// uplift, never goes below the lowest base level, for n < 1, = 1, > 1.
#[test]
fn stable_at_huge_dt() {
    for n in [0.7, 1.0, 2.0] {
        for dep in [
            Depressions::Fill,
            Depressions::BasinGraph,
            Depressions::None,
        ] {
            let mut g = noisy_block(30, 25, 500.0, 3);
            let p = StreamPowerParams {
                n,
                dt: 1e12,
                depressions: dep,
                base_height: BaseHeight::Zero,
                ..Default::default()
            };
            let mut sp = StreamPower::new(&mut g, 30.0, &p).unwrap();
            let mean0 = g.data().iter().sum::<f64>() / g.len() as f64;
            for _ in 0..3 {
                let before = g.clone();
                sp.step(&mut g, &Uplift::Uniform(0.0)).unwrap();
                for (a, b) in g.data().iter().zip(before.data()) {
                    assert!(a.is_finite(), "n={n} {dep:?}: NaN");
                    assert!(a <= b, "n={n} {dep:?}: a cell rose {b} -> {a}");
                    assert!(*a >= 0.0, "n={n} {dep:?}: below base level");
                }
            }
            // With depressions routed, every cell drains to the zero borders
            // and the relief collapses within a few huge steps.
            if dep != Depressions::None {
                let mean = g.data().iter().sum::<f64>() / g.len() as f64;
                assert!(mean < 0.2 * mean0, "n={n} {dep:?}: mean {mean0} -> {mean}");
            }
        }
    }
}

/// Same input, same bytes (twice, with every option that changes the path).
#[test]
fn deterministic() {
    let run = || {
        let mut g = noisy_block(40, 33, 100.0, 11);
        let umap = Grid::from_fn(40, 33, |x, _| 1e-3 * (1.0 + x as f64 / 40.0));
        let p = StreamPowerParams {
            n: 1.5,
            kd: 0.05,
            dt: 500.0,
            depressions: Depressions::BasinGraph,
            boundary: Boundary::parse("south,west").unwrap(),
            ..Default::default()
        };
        stream_power(&mut g, 25.0, &p, &Uplift::Map(&umap), 20).unwrap();
        g.data().iter().map(|v| v.to_bits()).collect::<Vec<_>>()
    };
    assert_eq!(run(), run());
}

/// Diffusion alone (K = 0) on a 1-D parabola with fixed ends: the explicit
/// substeps follow the closed form ∂h/∂t = Kd·h'' = −2·Kd·a for h = a·x(L−x)
/// in the interior (uniform lowering) — checked after one step.
#[test]
fn diffusion_lowers_a_parabola_uniformly() {
    let (w, h, cell) = (41usize, 3usize, 10.0);
    let a = 0.01;
    let l = (w - 1) as f64 * cell;
    let mut g = Grid::from_fn(w, h, |x, _| {
        let xm = x as f64 * cell;
        a * xm * (l - xm)
    });
    let p = StreamPowerParams {
        k: 0.0,
        kd: 1.0,
        dt: 10.0,
        boundary: Boundary::parse("east,west").unwrap(),
        ..Default::default()
    };
    let before = g.clone();
    stream_power(&mut g, cell, &p, &Uplift::Uniform(0.0), 1).unwrap();
    // Interior cells away from the ends: drop = 2·Kd·a·dt exactly for a
    // parabola (the discrete Laplacian of a quadratic is exact), while the
    // influence of the fixed ends has not reached them in 10 years.
    for x in 10..w - 10 {
        for y in 0..h {
            let drop = before.get(x, y) - g.get(x, y);
            assert!((drop - 2.0 * a * 10.0).abs() < 1e-9, "x={x}: drop {drop}");
        }
    }
}

#[test]
fn bad_parameters_are_clear_errors() {
    let g = noisy_block(8, 8, 1.0, 1);
    let cases: Vec<(StreamPowerParams, &str)> = vec![
        (
            StreamPowerParams {
                k: -1e-5,
                ..Default::default()
            },
            "K (erodibility)",
        ),
        (
            StreamPowerParams {
                dt: 0.0,
                ..Default::default()
            },
            "dt",
        ),
        (
            StreamPowerParams {
                n: 0.0,
                ..Default::default()
            },
            "n = 0",
        ),
        (
            StreamPowerParams {
                m: f64::NAN,
                ..Default::default()
            },
            "m = NaN",
        ),
        (
            StreamPowerParams {
                kd: -1.0,
                ..Default::default()
            },
            "Kd",
        ),
        (
            StreamPowerParams {
                boundary: Boundary::parse("none").unwrap(),
                ..Default::default()
            },
            "no base level",
        ),
    ];
    for (p, want) in cases {
        let mut h = g.clone();
        let e = stream_power(&mut h, 10.0, &p, &Uplift::Uniform(0.0), 5).unwrap_err();
        assert!(e.to_string().contains(want), "{e} (wanted {want})");
        assert_eq!(h, g, "input changed on error");
    }
    let mut h = g.clone();
    let e = stream_power(&mut h, 10.0, &Default::default(), &Uplift::Uniform(0.0), 0).unwrap_err();
    assert!(e.to_string().contains("steps = 0"), "{e}");
    let e = stream_power(&mut h, 0.0, &Default::default(), &Uplift::Uniform(0.0), 1).unwrap_err();
    assert!(e.to_string().contains("cell size"), "{e}");
    let e = stream_power(
        &mut h,
        1.0,
        &Default::default(),
        &Uplift::Uniform(f64::NAN),
        1,
    )
    .unwrap_err();
    assert!(e.to_string().contains("uplift"), "{e}");
    let small = Grid::new(3, 3, 0.0);
    let e = stream_power(&mut h, 1.0, &Default::default(), &Uplift::Map(&small), 1).unwrap_err();
    assert!(e.to_string().contains("uplift map is 3x3"), "{e}");
    assert!(Boundary::parse("up").is_err());
}

/// Nodata cells are left alone and their neighbours are base levels.
#[test]
fn nodata_is_outside_and_its_neighbours_are_base_levels() {
    let mut g = noisy_block(20, 20, 50.0, 5);
    let hole = (10, 10);
    g.set(hole.0, hole.1, f64::NAN);
    let before = g.clone();
    let p = StreamPowerParams {
        boundary: Boundary::parse("none").unwrap(),
        dt: 1e4,
        ..Default::default()
    };
    stream_power(&mut g, 10.0, &p, &Uplift::Uniform(1e-3), 10).unwrap();
    assert!(g.get(hole.0, hole.1).is_nan());
    for (dx, dy) in [(1i64, 0i64), (-1, -1), (0, 1)] {
        let (x, y) = ((hole.0 as i64 + dx) as usize, (hole.1 as i64 + dy) as usize);
        assert_eq!(g.get(x, y), before.get(x, y), "base level moved");
    }
    // Far cells were uplifted and eroded: they changed.
    assert_ne!(g.get(2, 2), before.get(2, 2));
}

fn smooth_terrain(w: usize, h: usize) -> Grid<f32> {
    Grid::from_fn(w, h, |x, y| {
        let (fx, fy) = (x as f64 / w as f64, y as f64 / h as f64);
        let edge = (fx * (1.0 - fx) * fy * (1.0 - fy) * 16.0).sqrt();
        (800.0 * edge
            + 60.0 * (fx * 17.0).sin() * (fy * 13.0).cos()
            + 30.0 * (fx * 41.0 + fy * 7.0).sin()) as f32
    })
}

/// Fixed points end at their targets; the rest of the terrain was eroded, and
/// without the constraint the same points would have dropped.
#[test]
fn constrained_erosion_keeps_fixed_points() {
    let (w, h, cell) = (64usize, 56usize, 50.0);
    let g0 = smooth_terrain(w, h);
    let fixed = vec![(20, 20), (40, 30), (30, 40), (24, 22), (50, 12)];
    let p = ConstrainedParams {
        stream: StreamPowerParams {
            k: 2e-4,
            dt: 1000.0,
            ..Default::default()
        },
        iterations: 8,
        steps_per_iteration: 5,
        ..Default::default()
    };
    let radius = 8.0 * cell;
    let mut g = g0.clone();
    erode_constrained(&mut g, cell, &fixed, radius, &p).unwrap();
    for &(x, y) in &fixed {
        let (a, b) = (g.get(x, y), g0.get(x, y));
        assert!((a - b).abs() < 2e-3, "fixed point {x},{y}: {b} -> {a}");
    }
    // Cells farther than R from every fixed point: eroded, not compensated.
    let (mut drop, mut count) = (0.0f64, 0usize);
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let far = fixed.iter().all(|&(fx, fy)| {
                let (dx, dy) = (x as f64 - fx as f64, y as f64 - fy as f64);
                (dx * dx + dy * dy).sqrt() * cell >= radius
            });
            if far {
                drop += (g0.get(x, y) - g.get(x, y)) as f64;
                count += 1;
            }
        }
    }
    assert!(count > 1000);
    assert!(
        drop / count as f64 > 5.0,
        "mean erosion {}",
        drop / count as f64
    );
    // Unconstrained: the fixed points do move.
    let mut free = g0.map(|v| v as f64);
    stream_power(&mut free, cell, &p.stream, &Uplift::Uniform(0.0), 40).unwrap();
    let moved = fixed
        .iter()
        .map(|&(x, y)| (free.get(x, y) - g0.get(x, y) as f64).abs())
        .fold(0.0, f64::max);
    assert!(
        moved > 1.0,
        "unconstrained erosion did not move the fixed points"
    );
    // Bad inputs.
    let mut g = g0.clone();
    assert!(erode_constrained(&mut g, cell, &[(w, 0)], radius, &p).is_err());
    assert!(erode_constrained(&mut g, cell, &fixed, -1.0, &p).is_err());
    let zero = ConstrainedParams {
        iterations: 0,
        ..p.clone()
    };
    assert!(erode_constrained(&mut g, cell, &fixed, radius, &zero).is_err());
}

/// With an erosion that does nothing, the cascade returns the input (the
/// detail differences telescope) for any levels; the callback sees each
/// level's size and cell size.
#[test]
fn multires_identity_and_levels() {
    let (w, h, cell) = (60usize, 45usize, 10.0);
    let g = smooth_terrain(w, h).map(|v| v as f64);
    for levels in [vec![40.0, 20.0, 10.0], vec![35.0, 25.0], vec![10.0]] {
        let mut seen = Vec::new();
        let out = erode_multires(&g, cell, &levels, |lv, c, k| {
            seen.push((lv.width(), lv.height(), c, k));
            Ok(())
        })
        .unwrap();
        assert_eq!((out.width(), out.height()), (w, h));
        for (a, b) in out.data().iter().zip(g.data()) {
            assert!((a - b).abs() < 1e-9, "{levels:?}: {a} vs {b}");
        }
        for (k, (lw, lh, c, kk)) in seen.iter().enumerate() {
            assert_eq!(*kk, k);
            let want = (w as f64 * cell / levels[k]).round() as usize;
            assert_eq!(*lw, want);
            assert_eq!(*lh, (h as f64 * cell / levels[k]).round() as usize);
            assert!(
                (c - levels[k]).abs() / levels[k] < 0.05,
                "{c} vs {}",
                levels[k]
            );
        }
    }
    // Stream power through the cascade erodes.
    let p = StreamPowerParams {
        k: 1e-4,
        ..Default::default()
    };
    let out = erode_multires(&g, cell, &[40.0, 20.0, 10.0], |lv, c, _| {
        stream_power(lv, c, &p, &Uplift::Uniform(0.0), 20)
    })
    .unwrap();
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    assert!(mean(out.data()) < mean(g.data()) - 1.0);
    assert!(erode_multires(&g, cell, &[5.0], |_, _, _| Ok(())).is_err());
    assert!(erode_multires(&g, cell, &[10.0, 20.0], |_, _, _| Ok(())).is_err());
}

fn write_asc(path: &std::path::Path, g: &Grid<f32>, cell: f64) {
    let mut s = format!(
        "ncols {}\nnrows {}\nxllcorner 0\nyllcorner 0\ncellsize {cell}\nNODATA_value -9999\n",
        g.width(),
        g.height()
    );
    for y in 0..g.height() {
        let row: Vec<String> = g.row(y).iter().map(|v| format!("{v}")).collect();
        s.push_str(&row.join(" "));
        s.push('\n');
    }
    std::fs::write(path, s).unwrap();
}

fn read_asc(path: &std::path::Path) -> Vec<f32> {
    let s = std::fs::read_to_string(path).unwrap();
    s.lines()
        .skip(6)
        .flat_map(|l| l.split_whitespace().map(|t| t.parse::<f32>().unwrap()))
        .collect()
}

/// Panics with the command's error output unless it succeeded.
fn succeeded(st: &std::process::Output) {
    assert!(
        st.status.success(),
        "{}",
        String::from_utf8_lossy(&st.stderr)
    );
}

/// `orogen erode --model stream-power INPUT ARGS -o OUT`, run to completion.
fn erode_sp(input: &Path, args: &[&str], out: &Path) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_orogen"))
        .args(["erode", "--model", "stream-power", input.to_str().unwrap()])
        .args(args)
        .args(["-o", out.to_str().unwrap()])
        .output()
        .unwrap()
}

#[test]
fn cli_erode_sp() {
    let dir = tempfile::tempdir().unwrap();
    let g = smooth_terrain(32, 24);
    let input = dir.path().join("dem.asc");
    write_asc(&input, &g, 30.0);
    let out = dir.path().join("out.asc");
    let st = erode_sp(
        &input,
        &[
            "--steps",
            "7",
            "--dt",
            "500",
            "--k",
            "1e-4",
            "--uplift",
            "2e-3",
            "--depressions",
            "basin-graph",
            "-q",
        ],
        &out,
    );
    succeeded(&st);
    let got = read_asc(&out);
    let mut lib = g.map(|v| v as f64);
    let p = StreamPowerParams {
        k: 1e-4,
        dt: 500.0,
        depressions: Depressions::BasinGraph,
        ..Default::default()
    };
    stream_power(&mut lib, 30.0, &p, &Uplift::Uniform(2e-3), 7).unwrap();
    assert_eq!(got.len(), lib.len());
    for (a, b) in got.iter().zip(lib.data()) {
        assert!(
            (*a as f64 - b).abs() <= 1e-3 * b.abs().max(1.0),
            "{a} vs {b}"
        );
    }
    // Fixed points from a CSV of cells: kept.
    let csv = dir.path().join("pts.csv");
    std::fs::write(&csv, "col,row\n10,10\n20,12\n").unwrap();
    let out2 = dir.path().join("fixed.asc");
    let pts = csv.to_str().unwrap();
    let fixed = [
        "--steps",
        "20",
        "--k",
        "1e-4",
        "--fixed-points",
        pts,
        "--radius",
        "150",
        "-q",
    ];
    let st = erode_sp(&input, &fixed, &out2);
    succeeded(&st);
    let got = read_asc(&out2);
    for (x, y) in [(10usize, 10usize), (20, 12)] {
        let (a, b) = (got[y * 32 + x], g.get(x, y));
        assert!((a - b).abs() < 2e-3, "{a} vs {b}");
    }
    // Bad parameters: non-zero exit, one clear sentence, no output.
    for (args, want) in [
        (vec!["--steps", "5", "--k=-1"], "K (erodibility)"),
        (vec!["--steps", "0"], "steps"),
        (
            vec!["--steps", "5", "--radius", "100"],
            "--fixed-points and --radius",
        ),
        (
            vec!["--steps", "5", "--talus", "30"],
            "does not apply to --model stream-power",
        ),
        (
            vec!["--steps", "5", "--exchange", "4"],
            "applies to the hydraulic",
        ),
    ] {
        let bad = dir.path().join("bad.asc");
        let st = erode_sp(&input, &args, &bad);
        assert!(!st.status.success());
        let err = String::from_utf8_lossy(&st.stderr);
        assert!(err.contains(want), "{args:?}: {err}");
        assert!(!bad.exists());
    }
}
