//! Local erosion models: tiled == untiled bit for bit (every model, odd tile
//! sizes, several exchange periods, memory and disk states, 1 and 2 threads),
//! conservation of mass and water, hydraulic substeps against Mei et al.'s
//! scheme written out here, thermal's talus bound, diffusion of a Gaussian
//! hill against the closed form, parameter validation.

use orogen::erosion::tiled::{run_to_grids, run_untiled, Backend};
use orogen::erosion::{
    hash_unit, CellSize, Diffusion, DiffusionParams, Hydraulic, HydraulicParams, LocalModel,
    Thermal, ThermalParams,
};
use orogen::exec::EngineConfig;
use orogen::raster::{GeoRef, Grid, MemRaster};

fn cfg(threads: usize) -> EngineConfig {
    EngineConfig {
        threads,
        memory_budget: 1 << 30,
        progress: false,
        observer: None,
        engine: Default::default(),
    }
}

/// A bumpy terrain (sum of sines, a cone and a pit) with a few nodata holes.
fn terrain(w: usize, h: usize, holes: bool) -> Grid<f64> {
    Grid::from_fn(w, h, |x, y| {
        let (fx, fy) = (x as f64, y as f64);
        if holes && ((x == 5 && y == 7) || (x == w - 3 && y > h / 2 && y < h / 2 + 3)) {
            return f64::NAN;
        }
        let cone = 30.0 - ((fx - 0.6 * w as f64).hypot(fy - 0.4 * h as f64)) * 1.5;
        100.0
            + 8.0 * (fx * 0.37).sin() * (fy * 0.23).cos()
            + cone.max(0.0)
            + 3.0 * (fx * 1.7 + fy).sin()
    })
}

fn src(g: &Grid<f64>) -> MemRaster {
    MemRaster::from_grid(g.clone(), GeoRef::pixel())
}

fn hydraulic(steps: u64) -> Hydraulic {
    let p = HydraulicParams {
        rain: 0.05,
        rain_probability: 0.3,
        dt: 0.2,
        capacity: 0.05,
        settle: false,
        seed: 9,
        ..Default::default()
    };
    Hydraulic::new(p, steps, CellSize { dx: 2.0, dy: 3.0 }).unwrap()
}

fn thermal(steps: u64) -> Thermal {
    let p = ThermalParams {
        talus: 25.0,
        rate: 0.4,
        cell: None,
    };
    Thermal::new(p, steps, CellSize { dx: 1.0, dy: 1.5 }).unwrap()
}

fn diffusion(steps: u64) -> Diffusion {
    let p = DiffusionParams {
        diffusivity: 0.7,
        dt: 1.0,
        cell: None,
    };
    Diffusion::new(p, steps, CellSize { dx: 1.0, dy: 1.2 }).unwrap()
}

fn same_bits(a: &[Grid<f64>], b: &[Grid<f64>], what: &str) {
    assert_eq!(a.len(), b.len());
    for (f, (ga, gb)) in a.iter().zip(b).enumerate() {
        for (i, (x, y)) in ga.data().iter().zip(gb.data()).enumerate() {
            assert_eq!(
                x.to_bits(),
                y.to_bits(),
                "{what}: field {f}, cell {i}: {x} vs {y}"
            );
        }
    }
}

fn check_tiled<M: LocalModel>(model: &M, dem: &Grid<f64>) {
    let reference = run_untiled(model, dem);
    // The run must change the terrain (the comparison is not vacuous).
    let changed = reference[0]
        .data()
        .iter()
        .zip(dem.data())
        .filter(|(a, b)| a.is_finite() && (*a - *b).abs() > 1e-6)
        .count();
    assert!(
        changed > 50,
        "{}: only {changed} cells changed",
        model.name()
    );
    let s = src(dem);
    for tile in [7usize, 13, 64] {
        for k in [1usize, 3] {
            let (got, stats) = run_to_grids(model, &s, tile, k, &Backend::Memory, &cfg(2)).unwrap();
            assert_eq!(stats.ghost, k * model.radius());
            same_bits(
                &reference,
                &got,
                &format!("{} tile {tile} exchange {k}", model.name()),
            );
        }
    }
}

#[test]
fn hydraulic_tiled_equals_untiled() {
    check_tiled(&hydraulic(14), &terrain(45, 38, true));
}

#[test]
fn thermal_tiled_equals_untiled() {
    check_tiled(&thermal(9), &terrain(45, 38, true));
}

#[test]
fn diffusion_tiled_equals_untiled() {
    let m = diffusion(4);
    assert!(
        m.per_step > 1,
        "the test should cover several substeps per step"
    );
    check_tiled(&m, &terrain(45, 38, true));
}

#[test]
fn disk_states_and_threads_give_the_same_bits() {
    let dem = terrain(40, 33, true);
    let m = hydraulic(10);
    let s = src(&dem);
    let (one, _) = run_to_grids(&m, &s, 11, 2, &Backend::Memory, &cfg(1)).unwrap();
    let (two, _) = run_to_grids(&m, &s, 11, 2, &Backend::Memory, &cfg(2)).unwrap();
    same_bits(&one, &two, "1 vs 2 threads");
    let dir = tempfile::tempdir().unwrap();
    let (disk, _) = run_to_grids(
        &m,
        &s,
        11,
        2,
        &Backend::Disk(dir.path().to_path_buf()),
        &cfg(2),
    )
    .unwrap();
    same_bits(&one, &disk, "memory vs disk states");
    // Another seed gives another result.
    let mut p = m.params.clone();
    p.seed = 10;
    let other = Hydraulic::new(p, 10, m.cell).unwrap();
    let (o, _) = run_to_grids(&other, &s, 11, 2, &Backend::Memory, &cfg(2)).unwrap();
    assert!(o[0].data().iter().zip(one[0].data()).any(|(a, b)| a != b));
}

fn sum(g: &Grid<f64>) -> f64 {
    g.data().iter().filter(|v| !v.is_nan()).sum()
}

#[test]
fn hydraulic_conserves_mass_and_water() {
    let dem = terrain(64, 64, true);
    let m = hydraulic(200);
    let out = run_untiled(&m, &dem);
    let before = sum(&dem);
    let after = sum(&out[0]) + sum(&out[2]);
    let rel = ((after - before) / before).abs();
    eprintln!("hydraulic: terrain + sediment relative change {rel:e}");
    assert!(
        rel < 1e-9,
        "terrain + sediment changed by {rel:e} (relative)"
    );
    let eroded = out[0]
        .data()
        .iter()
        .zip(dem.data())
        .filter(|(a, b)| (*a - *b).abs() > 1e-3)
        .count();
    assert!(
        eroded > 200,
        "only {eroded} cells eroded or received sediment"
    );
    // Water balance, recomputed from the rain hash: the pipes move water
    // between cells without creating any, evaporation removes a fraction.
    let p = &m.params;
    let mut water = 0.0;
    for n in 0..m.steps {
        let mut rain = 0.0;
        for y in 0..64 {
            for x in 0..64 {
                if !dem.get(x, y).is_nan()
                    && hash_unit(p.seed, n, x as i64, y as i64) < p.rain_probability
                {
                    rain += p.rain / p.rain_probability;
                }
            }
        }
        water = (water + rain) * (1.0 - p.evaporation * p.dt);
    }
    let got = sum(&out[1]);
    assert!(
        ((got - water) / water).abs() < 1e-9,
        "water {got} vs balance {water}"
    );
    // Settling deposits the suspended sediment: terrain alone keeps the mass.
    let mut q = p.clone();
    q.settle = true;
    let settled = run_untiled(&Hydraulic::new(q, 200, m.cell).unwrap(), &dem);
    let rel = ((sum(&settled[0]) - before) / before).abs();
    assert!(rel < 1e-9, "settled terrain changed by {rel:e}");
    assert_eq!(sum(&settled[2]), 0.0);
}

#[test]
fn thermal_reaches_the_talus_slope_and_conserves_mass() {
    // A steep random-ish surface: slopes far above 30°.
    let dem = Grid::from_fn(36, 30, |x, y| {
        let k = hash_unit(3, 0, x as i64, y as i64);
        50.0 * k + 2.0 * x as f64
    });
    let talus = 30.0f64;
    let m = Thermal::new(
        ThermalParams {
            talus,
            rate: 0.5,
            cell: None,
        },
        3000,
        CellSize { dx: 1.0, dy: 1.0 },
    )
    .unwrap();
    let out = run_untiled(&m, &dem);
    let h = &out[0];
    let t = talus.to_radians().tan();
    let mut worst = 0.0f64;
    let mut worst_before = 0.0f64;
    for y in 0..30i64 {
        for x in 0..36i64 {
            for (dx, dy) in [(1i64, 0i64), (0, 1), (1, 1), (1, -1)] {
                let (nx, ny) = (x + dx, y + dy);
                if nx < 0 || ny < 0 || nx >= 36 || ny >= 30 {
                    continue;
                }
                let dist = ((dx * dx + dy * dy) as f64).sqrt();
                let s =
                    (h.get(x as usize, y as usize) - h.get(nx as usize, ny as usize)).abs() / dist;
                worst = worst.max(s);
                let s0 = (dem.get(x as usize, y as usize) - dem.get(nx as usize, ny as usize))
                    .abs()
                    / dist;
                worst_before = worst_before.max(s0);
            }
        }
    }
    eprintln!("thermal: steepest slope {worst} (tan), talus tan {t}");
    assert!(
        worst_before > 10.0 * t,
        "the test terrain should start steep"
    );
    assert!(
        worst <= t + 1e-4,
        "steepest slope {worst} (tan) above the talus {t} after 3000 steps"
    );
    let rel = ((sum(h) - sum(&dem)) / sum(&dem)).abs();
    assert!(rel < 1e-12, "thermal changed the mass by {rel:e}");
}

#[test]
fn diffusion_of_a_gaussian_hill_matches_the_closed_form() {
    // h = A σ0²/(σ0² + 2Dt) · exp(−r²/(2(σ0² + 2Dt))) solves ∂h/∂t = D∇²h
    // for a Gaussian of variance σ0² at t = 0.
    let (n, a, s0, d) = (161usize, 100.0f64, 6.0f64, 1.0f64);
    let c = (n / 2) as f64;
    let gauss = |x: usize, y: usize, var: f64, amp: f64| {
        let r2 = (x as f64 - c).powi(2) + (y as f64 - c).powi(2);
        amp * (-r2 / (2.0 * var)).exp()
    };
    let dem = Grid::from_fn(n, n, |x, y| gauss(x, y, s0 * s0, a));
    let steps = 40u64;
    let m = Diffusion::new(
        DiffusionParams {
            diffusivity: d,
            dt: 1.0,
            cell: None,
        },
        steps,
        CellSize::square(1.0),
    )
    .unwrap();
    let out = run_untiled(&m, &dem);
    let t = steps as f64;
    let var = s0 * s0 + 2.0 * d * t;
    let amp = a * s0 * s0 / var;
    let mut worst = 0.0f64;
    for y in 0..n {
        for x in 0..n {
            worst = worst.max((out[0].get(x, y) - gauss(x, y, var, amp)).abs());
        }
    }
    eprintln!("diffusion: max error {worst} (amplitude {amp})");
    // Amplitude 100 -> 31.0; FTCS is second order in dx/σ (measured 0.0042).
    assert!(worst < 1e-4 * a, "max error {worst} vs the closed form");
    let rel = ((sum(&out[0]) - sum(&dem)) / sum(&dem)).abs();
    assert!(rel < 1e-12, "diffusion changed the volume by {rel:e}");
}

#[test]
fn bad_parameters_are_refused() {
    let cell = CellSize::square(30.0);
    let err = |r: orogen::Result<()>| r.unwrap_err().to_string();
    let e = err(Hydraulic::new(
        HydraulicParams {
            capacity: -1.0,
            ..Default::default()
        },
        10,
        cell,
    )
    .map(|_| ()));
    assert!(e.contains("capacity"), "{e}");
    let e = err(Hydraulic::new(HydraulicParams::default(), 0, cell).map(|_| ()));
    assert!(e.contains("steps"), "{e}");
    let e = err(Hydraulic::new(
        HydraulicParams {
            dissolving: 5.0,
            ..Default::default()
        },
        10,
        cell,
    )
    .map(|_| ()));
    assert!(e.contains("dissolving"), "{e}");
    for talus in [90.0, 120.0, 0.0, f64::NAN] {
        let e = err(Thermal::new(
            ThermalParams {
                talus,
                ..Default::default()
            },
            10,
            cell,
        )
        .map(|_| ()));
        assert!(e.contains("talus"), "{e}");
    }
    let e = err(Diffusion::new(
        DiffusionParams {
            diffusivity: -0.1,
            ..Default::default()
        },
        10,
        cell,
    )
    .map(|_| ()));
    assert!(e.contains("diffusivity"), "{e}");
    let e = err(Diffusion::new(
        DiffusionParams {
            diffusivity: 1e9,
            dt: 1e9,
            cell: None,
        },
        1000,
        cell,
    )
    .map(|_| ()));
    assert!(e.contains("substeps"), "{e}");
}

/// The virtual-pipe substep of Mei, Decaudin & Hu 2007 (§3, eqs. 2–14) as
/// `orogen::erosion::hydraulic`'s module doc states it, written here on its
/// own: rain on every cell (probability 1), pipe fluxes scaled by K, water
/// update, velocity from the mean fluxes over the mean depth (clamped to one
/// cell per substep), donor-cell sediment transport through the same pipes,
/// dissolution/deposition against C = Kc·max(sin α, min_tilt)·|v|·min(1,
/// d/max_depth), evaporation. Cells on the raster's edge are walls; sin α
/// from central differences (own value at a wall, as the module's code
/// comment says). Returns (terrain, water, sediment) after `n` substeps.
fn mei_substeps(
    z: &Grid<f64>,
    p: &HydraulicParams,
    (lx, ly): (f64, f64),
    n: usize,
) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let (w, h) = (z.width(), z.height());
    let mut b = z.data().to_vec();
    let mut d = vec![0.0f64; w * h];
    let mut s = vec![0.0f64; w * h];
    // fluxes towards E (x+1), W (x−1), N (y−1), S (y+1)
    let mut f = vec![[0.0f64; 4]; w * h];
    let nb = |x: usize, y: usize, k: usize| -> Option<usize> {
        let (nx, ny) = match k {
            0 => (x as i64 + 1, y as i64),
            1 => (x as i64 - 1, y as i64),
            2 => (x as i64, y as i64 - 1),
            _ => (x as i64, y as i64 + 1),
        };
        (nx >= 0 && ny >= 0 && (nx as usize) < w && (ny as usize) < h)
            .then(|| ny as usize * w + nx as usize)
    };
    let len = [lx, lx, ly, ly];
    let area = lx * ly;
    let opposite = [1usize, 0, 3, 2];
    for _ in 0..n {
        // 1. rain
        for v in d.iter_mut() {
            *v += p.rain / p.rain_probability;
        }
        let d1 = d.clone();
        // 2. fluxes (eqs. 2–5)
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                let mut sum = 0.0;
                for k in 0..4 {
                    f[i][k] = match nb(x, y, k) {
                        Some(j) => {
                            let dh = (b[i] + d1[i]) - (b[j] + d1[j]);
                            (f[i][k] + p.dt * p.pipe_area * p.gravity * dh / len[k]).max(0.0)
                        }
                        None => 0.0,
                    };
                    sum += f[i][k];
                }
                if sum > 0.0 {
                    let kf = (d1[i] * area / (sum * p.dt)).min(1.0);
                    f[i].iter_mut().for_each(|v| *v *= kf);
                }
            }
        }
        // 3. water (eqs. 6–7) and velocity (eqs. 8–9)
        let mut d2 = vec![0.0; w * h];
        let mut speed = vec![0.0; w * h];
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                let inflow = |k: usize| nb(x, y, k).map_or(0.0, |j| f[j][opposite[k]]);
                let fin: f64 = (0..4).map(inflow).sum();
                let fout: f64 = f[i].iter().sum();
                d2[i] = d1[i] + p.dt * (fin - fout) / area;
                let wx = (inflow(1) - f[i][1] + f[i][0] - inflow(0)) / 2.0;
                let wy = (inflow(2) - f[i][2] + f[i][3] - inflow(3)) / 2.0;
                let dm = (d1[i] + d2[i]) / 2.0;
                speed[i] = if dm > 0.0 {
                    (wx / (ly * dm))
                        .hypot(wy / (lx * dm))
                        .min(lx.min(ly) / p.dt)
                } else {
                    0.0
                };
            }
        }
        // 4. sediment moves with the water (donor cell)
        let mut s2 = s.clone();
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                if d1[i] <= 0.0 {
                    continue;
                }
                for (k, &fk) in f[i].iter().enumerate() {
                    if let Some(j) = nb(x, y, k) {
                        let m = s[i] * fk * p.dt / (d1[i] * area);
                        s2[i] -= m;
                        s2[j] += m;
                    }
                }
            }
        }
        // 5. erosion and deposition (eqs. 10–12)
        let b0 = b.clone();
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                let at = |k: usize| nb(x, y, k).map_or(b0[i], |j| b0[j]);
                let gx = (at(0) - at(1)) / (2.0 * lx);
                let gy = (at(3) - at(2)) / (2.0 * ly);
                let t2 = gx * gx + gy * gy;
                let sin_a = (t2 / (1.0 + t2)).sqrt().max(p.min_tilt);
                let cap = p.capacity * sin_a * speed[i] * (d2[i] / p.max_depth).min(1.0);
                if cap > s2[i] {
                    let e = p.dt * p.dissolving * (cap - s2[i]);
                    b[i] -= e;
                    s2[i] += e;
                } else {
                    let e = p.dt * p.deposition * (s2[i] - cap);
                    b[i] += e;
                    s2[i] -= e;
                }
            }
        }
        s = s2;
        // 6. evaporation (eq. 14)
        for (v, &x) in d.iter_mut().zip(&d2) {
            *v = x * (1.0 - p.evaporation * p.dt);
        }
    }
    (b, d, s)
}

#[test]
fn hydraulic_substeps_follow_mei_et_al() {
    let (w, h) = (30, 26);
    let dem = terrain(w, h, false);
    let p = HydraulicParams {
        rain: 0.02,
        rain_probability: 1.0,
        dt: 0.2,
        capacity: 0.05,
        settle: false,
        ..Default::default()
    };
    let (lx, ly) = (2.0, 3.0);
    for n in [1usize, 2, 4] {
        let model = Hydraulic::new(p.clone(), n as u64, CellSize { dx: lx, dy: ly }).unwrap();
        let got = run_untiled(&model, &dem);
        let (b, d, s) = mei_substeps(&dem, &p, (lx, ly), n);
        // The walls' own rules reach two cells further in per substep.
        let m = 2 * n + 1;
        let mut eroded = 0;
        for y in m..h - m {
            for x in m..w - m {
                let i = y * w + x;
                for (field, want) in [(0usize, b[i]), (1, d[i]), (2, s[i])] {
                    let g = got[field].data()[i];
                    assert!(
                        (g - want).abs() <= 1e-9 * want.abs().max(1.0),
                        "substeps {n}, field {field}, cell ({x}, {y}): {g} vs Mei's {want}"
                    );
                }
                if (b[i] - dem.get(x, y)).abs() > 1e-6 {
                    eroded += 1;
                }
            }
        }
        // the comparison is not vacuous: the terrain moved on most cells
        assert!(
            eroded > (w - 2 * m) * (h - 2 * m) / 2,
            "substeps {n}: {eroded} cells changed"
        );
    }
}
