//! Metrics against oracles that share no code with them: closed forms on
//! analytic surfaces (planes, paraboloids, a sphere cap, cones and pits) and
//! brute-force double loops over windows on random grids with nodata holes,
//! run tiled through `LocalEngine`.

#![allow(clippy::needless_range_loop)] // index loops read like the definitions

use crate::common::{check, get as at, run, source, Rng, CELL, COMPASS8};

fn close(got: f32, want: f64, rel: f64, abs: f64) -> bool {
    if want.is_nan() {
        return got.is_nan();
    }
    (got as f64 - want).abs() <= abs + rel * want.abs()
}

/// Fails with `what`, the value and the expectation unless [`close`].
#[track_caller]
fn assert_close(got: f32, want: f64, rel: f64, abs: f64, what: std::fmt::Arguments) {
    assert!(close(got, want, rel, abs), "{what}: {got} vs {want}");
}

/// Map coordinates (metres) of the centre of cell (col, row).
fn xy(col: usize, row: usize) -> (f64, f64) {
    ((col as f64 + 0.5) * CELL, -(row as f64 + 0.5) * CELL)
}

#[test]
fn tilted_plane_closed_forms() {
    let (w, h) = (23, 19);
    // Heights are multiples of 0.625: exact in f32.
    let (a, b) = (0.25, -0.125); // dz/dx (east), dz/dy (north)
    let data: Vec<f32> = (0..w * h)
        .map(|i| {
            let (x, y) = xy(i % w, i / w);
            (a * x + b * y) as f32
        })
        .collect();
    let src = source(&data, w, h);
    let out = run(
        &src,
        "dzdx,dzdy,slope,aspect,northness,eastness,laplacian,mean_curvature,gaussian_curvature,profile_curvature,plan_curvature,tpi:radius=2c,relief:radius=2c,tri_riley,tri,rugosity,variance:radius=3c,roughness:radius=2c,sky_view_approx",
        7,
        2,
    );
    let g: f64 = (a * a + b * b).sqrt();
    let svf_approx = (1.0 + g.atan().cos()) / 2.0;
    let slope = g.atan().to_degrees();
    // Downslope direction (−a, −b): azimuth clockwise from north.
    let mut aspect = (-a).atan2(-b).to_degrees();
    if aspect < 0.0 {
        aspect += 360.0;
    }
    let riley = (6.0f64 * (a * a + b * b)).sqrt() * CELL;
    let mut wilson = 0.0;
    for (dx, dy) in COMPASS8 {
        wilson += (a * dx as f64 + b * dy as f64).abs() * CELL / 8.0;
    }
    let rug = (1.0 + a * a + b * b).sqrt();
    let var3 = (a * a + b * b) * CELL * CELL * (3.0 * 4.0 / 3.0);
    let relief2 = (a.abs() + b.abs()) * CELL * 4.0;
    let interior = |x: usize, y: usize, m: usize| x >= m && y >= m && x + m < w && y + m < h;
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            let edge1 = !interior(x, y, 1);
            let chk = |k: usize, want: f64, rel: f64, abs: f64| {
                let g = out[k][i];
                // 3x3 metrics are nodata on the raster's outer ring.
                if edge1 && (k <= 10 || (13..=15).contains(&k)) {
                    assert!(g.is_nan(), "metric {k} at edge ({x},{y}) = {g}");
                    return;
                }
                assert_close(g, want, rel, abs, format_args!("metric {k} at ({x},{y})"));
            };
            chk(0, a, 1e-6, 1e-9);
            chk(1, b, 1e-6, 1e-9);
            chk(2, slope, 1e-6, 0.0);
            chk(3, aspect, 1e-6, 0.0);
            chk(
                4,
                aspect.to_radians().cos() * slope.to_radians().sin(),
                1e-6,
                1e-9,
            );
            chk(
                5,
                aspect.to_radians().sin() * slope.to_radians().sin(),
                1e-6,
                1e-9,
            );
            for k in 6..=10 {
                chk(k, 0.0, 0.0, 1e-7);
            }
            if interior(x, y, 2) {
                chk(11, 0.0, 0.0, 1e-9);
                chk(12, relief2, 1e-6, 1e-4);
            }
            chk(13, riley, 1e-6, 0.0);
            chk(14, wilson, 1e-6, 0.0);
            chk(15, rug, 1e-6, 0.0);
            if interior(x, y, 3) {
                chk(16, var3, 1e-6, 0.0);
            }
            if interior(x, y, 3) {
                chk(17, 0.0, 0.0, 1e-4);
            }
            if interior(x, y, 1) {
                chk(18, svf_approx, 1e-6, 0.0);
            } else {
                assert!(out[18][i].is_nan());
            }
        }
    }
}

#[test]
fn paraboloid_laplacian_and_apex_curvatures() {
    let (w, h) = (21, 21);
    let (aa, bb) = (0.01, 0.025);
    let (cx, cy) = xy(10, 10);
    let data: Vec<f32> = (0..w * h)
        .map(|i| {
            let (x, y) = xy(i % w, i / w);
            (aa * (x - cx).powi(2) + bb * (y - cy).powi(2)) as f32
        })
        .collect();
    let src = source(&data, w, h);
    let out = run(
        &src,
        "laplacian,mean_curvature,gaussian_curvature,min_curvature,max_curvature",
        5,
        1,
    );
    let lap = 2.0 * aa + 2.0 * bb;
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            // f32 storage of z limits the second difference to ~1e-5 / 100.
            assert_close(
                out[0][y * w + x],
                lap,
                1e-4,
                1e-6,
                format_args!("({x},{y})"),
            );
        }
    }
    let c = 10 * w + 10;
    // At the apex p = q = 0: H = −(A + B) (convex positive), K = 4AB,
    // principal curvatures −2B and −2A.
    assert!(close(out[1][c], -(aa + bb), 1e-6, 0.0), "{}", out[1][c]);
    assert!(close(out[2][c], 4.0 * aa * bb, 1e-6, 0.0), "{}", out[2][c]);
    assert!(close(out[3][c], -2.0 * bb, 1e-6, 0.0), "{}", out[3][c]);
    assert!(close(out[4][c], -2.0 * aa, 1e-6, 0.0), "{}", out[4][c]);
}

#[test]
fn wood_quadric_exact_on_paraboloid_with_holes() {
    let (w, h) = (25, 23);
    let (aa, bb) = (1.0 / 400.0, 1.0 / 100.0);
    let (cx, cy) = xy(12, 11);
    let mut r = Rng(17);
    let data: Vec<f32> = (0..w * h)
        .map(|i| {
            let (x, y) = xy(i % w, i / w);
            let z = aa * (x - cx - 15.0).powi(2)
                + bb * (y - cy + 5.0).powi(2)
                + 0.004 * (x - cx) * (y - cy);
            if r.next().is_multiple_of(9) && i != 11 * w + 12 {
                f32::NAN
            } else {
                z as f32
            }
        })
        .collect();
    let src = source(&data, w, h);
    let out = run(
        &src,
        "mean_curvature:radius=3c,gaussian_curvature:radius=3c,profile_curvature:radius=30m,plan_curvature:radius=3c",
        8,
        2,
    );
    // Analytic derivatives of the quadratic, then the differential geometry
    // of a graph z(x, y) (do Carmo 1976, sec. 3-3): H, K, and the normal
    // curvature along the gradient (profile) and the contour's plane curvature.
    for y in 3..h - 3 {
        for x in 3..w - 3 {
            let i = y * w + x;
            if data[i].is_nan() {
                assert!(out[0][i].is_nan());
                continue;
            }
            let (px, py) = xy(x, y);
            let (u, v) = (px - cx, py - cy);
            let zx = 2.0 * aa * (u - 15.0) + 0.004 * v;
            let zy = 2.0 * bb * (v + 5.0) + 0.004 * u;
            let (zxx, zyy, zxy) = (2.0 * aa, 2.0 * bb, 0.004);
            let g = 1.0 + zx * zx + zy * zy;
            let hh = -((1.0 + zy * zy) * zxx - 2.0 * zx * zy * zxy + (1.0 + zx * zx) * zyy)
                / (2.0 * g.powf(1.5));
            let kk = (zxx * zyy - zxy * zxy) / (g * g);
            // Second derivative along the unit gradient direction, over (1+|∇z|²)^{3/2}.
            let gn = (zx * zx + zy * zy).sqrt();
            let (ex, ey) = (zx / gn, zy / gn);
            let dss = zxx * ex * ex + 2.0 * zxy * ex * ey + zyy * ey * ey;
            let kv = -dss / g.powf(1.5);
            // Contour curvature: second derivative across the gradient over |∇z|.
            let dtt = zxx * ey * ey - 2.0 * zxy * ex * ey + zyy * ex * ex;
            let kp = -dtt / gn;
            assert_close(out[0][i], hh, 1e-5, 1e-12, format_args!("H ({x},{y})"));
            assert_close(out[1][i], kk, 1e-5, 1e-14, format_args!("K ({x},{y})"));
            assert_close(out[2][i], kv, 1e-5, 1e-12, format_args!("kv ({x},{y})"));
            assert_close(out[3][i], kp, 1e-5, 1e-12, format_args!("kp ({x},{y})"));
        }
    }
}

#[test]
fn sphere_cap_curvature_is_one_over_r() {
    let (w, h) = (41, 41);
    let rr = 5000.0;
    let (cx, cy) = xy(20, 20);
    // f64 heights relative to the cap's top keep f32 rounding small.
    let data: Vec<f32> = (0..w * h)
        .map(|i| {
            let (x, y) = xy(i % w, i / w);
            let d2 = (x - cx).powi(2) + (y - cy).powi(2);
            ((rr * rr - d2).sqrt() - rr) as f32
        })
        .collect();
    let src = source(&data, w, h);
    let out = run(
        &src,
        "mean_curvature,gaussian_curvature,min_curvature,max_curvature,profile_curvature,tangential_curvature,plan_curvature",
        16,
        2,
    );
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let i = y * w + x;
            let (px, py) = xy(x, y);
            let rho = ((px - cx).powi(2) + (py - cy).powi(2)).sqrt();
            assert_close(out[0][i], 1.0 / rr, 2e-3, 0.0, format_args!("H ({x},{y})"));
            assert_close(
                out[1][i],
                1.0 / (rr * rr),
                4e-3,
                0.0,
                format_args!("K ({x},{y})"),
            );
            if rho > 50.0 {
                // Principal, normal-section curvatures all 1/R; the contour is
                // a circle of radius ρ: plan curvature 1/ρ.
                for k in 2..=5 {
                    assert_close(
                        out[k][i],
                        1.0 / rr,
                        5e-2,
                        0.0,
                        format_args!("k{k} ({x},{y})"),
                    );
                }
                assert_close(
                    out[6][i],
                    1.0 / rho,
                    2e-2,
                    0.0,
                    format_args!("kp ({x},{y})"),
                );
            }
        }
    }
}

#[test]
fn pit_and_cone_openness_and_sky_view() {
    let (w, h) = (31, 31);
    let k = 0.4;
    let (cx, cy) = xy(15, 15);
    for (sign, dirs) in [(1.0, 8), (-1.0, 8), (1.0, 16), (-1.0, 16)] {
        let data: Vec<f32> = (0..w * h)
            .map(|i| {
                let (x, y) = xy(i % w, i / w);
                (sign * k * ((x - cx).powi(2) + (y - cy).powi(2)).sqrt()) as f32
            })
            .collect();
        let src = source(&data, w, h);
        let out = run(
            &src,
            &format!("openness:radius=100m:directions={dirs},openness_neg:radius=100m:directions={dirs},sky_view:radius=100m:directions={dirs}"),
            9,
            2,
        );
        let c = 15 * w + 15;
        // Every ray from the apex rises (pit) or falls (cone) at angle atan k.
        let beta = sign * k.atan().to_degrees();
        assert_close(
            out[0][c],
            90.0 - beta,
            1e-6,
            0.0,
            format_args!("pos {sign} {dirs}"),
        );
        assert_close(
            out[1][c],
            90.0 + beta,
            1e-6,
            0.0,
            format_args!("neg {sign} {dirs}"),
        );
        let svf = 1.0 - beta.max(0.0).to_radians().sin();
        assert_close(out[2][c], svf, 1e-6, 0.0, format_args!("svf {sign} {dirs}"));
    }
    // Flat ground: openness 90°, sky view 1 everywhere.
    let src = source(&vec![7.0; 100], 10, 10);
    let out = run(
        &src,
        "openness:radius=3c,openness_neg:radius=3c,sky_view:radius=3c",
        4,
        1,
    );
    for i in 0..100 {
        assert_eq!((out[0][i], out[1][i], out[2][i]), (90.0, 90.0, 1.0));
    }
}

/// Integer-valued heights in 0..200 with ~8 % nodata.
fn random_grid(w: usize, h: usize, seed: u64) -> Vec<f32> {
    let mut r = Rng(seed);
    (0..w * h)
        .map(|_| {
            let v = r.next();
            if v.is_multiple_of(12) {
                f32::NAN
            } else {
                ((v >> 8) % 200) as f32
            }
        })
        .collect()
}

/// Naive window statistics of the square of half-side r, or of the disk of
/// radius r: (n, mean, variance, mean without centre, max, min).
fn naive_window_shape(
    d: &[f32],
    w: usize,
    h: usize,
    x: i64,
    y: i64,
    r: i64,
    disk: bool,
) -> (f64, f64, f64, f64, f64, f64) {
    let mut vals = Vec::new();
    for dy in -r..=r {
        for dx in -r..=r {
            if disk && dx * dx + dy * dy > r * r {
                continue;
            }
            let v = at(d, w, h, x + dx, y + dy);
            if !v.is_nan() {
                vals.push(v);
            }
        }
    }
    let n = vals.len() as f64;
    let mean = vals.iter().sum::<f64>() / n;
    let var = vals.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / n;
    let c = at(d, w, h, x, y);
    let others = (vals.iter().sum::<f64>() - c) / (n - 1.0);
    let mx = vals.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let mn = vals.iter().cloned().fold(f64::INFINITY, f64::min);
    (n, mean, var, others, mx, mn)
}

/// Mean, variance, stdev, TPI and normalised TPI (and, for the square,
/// relief) of windows of half-side `r` for each of `radii`, on a random
/// `w` x `h` grid, against `naive_window_shape` at each tile size of `tiles`.
fn window_statistics_brute_force(
    (w, h): (usize, usize),
    seed: u64,
    radii: &[i64],
    tiles: &[usize],
    disk: bool,
) {
    let d = random_grid(w, h, seed);
    let src = source(&d, w, h);
    let (shape, names): (&str, &[&str]) = if disk {
        (":shape=disk", &["mean", "variance", "stdev", "tpi", "ntpi"])
    } else {
        ("", &["mean", "variance", "stdev", "tpi", "ntpi", "relief"])
    };
    for &r in radii {
        let specs: Vec<String> = names
            .iter()
            .map(|m| format!("{m}:radius={r}c{shape}"))
            .collect();
        let specs = specs.join(",");
        let mut want = vec![vec![f64::NAN; w * h]; names.len()];
        for y in 0..h as i64 {
            for x in 0..w as i64 {
                let c = at(&d, w, h, x, y);
                if c.is_nan() {
                    continue;
                }
                let (n, mean, var, others, mx, mn) = naive_window_shape(&d, w, h, x, y, r, disk);
                let i = y as usize * w + x as usize;
                let tpi = if n > 1.0 { c - others } else { f64::NAN };
                want[0][i] = mean;
                want[1][i] = var;
                want[2][i] = var.sqrt();
                want[3][i] = tpi;
                want[4][i] = if var == 0.0 && !tpi.is_nan() {
                    0.0
                } else {
                    tpi / var.sqrt()
                };
                if !disk {
                    want[5][i] = mx - mn;
                }
            }
        }
        let kind = if disk { "disk " } else { "" };
        for &tile in tiles {
            let out = run(&src, &specs, tile, 2);
            for k in 0..names.len() {
                let name = format!("{kind}r{r} tile{tile} m{k}");
                check(&name, &out[k], &want[k], w, 2e-7, 1e-9);
            }
        }
    }
}

#[test]
fn windowed_statistics_brute_force() {
    window_statistics_brute_force((37, 29), 7, &[1, 2, 5], &[1, 7, 64], false);
}

#[test]
fn tri_laplacian_rugosity_brute_force() {
    let (w, h) = (19, 17);
    let d = random_grid(w, h, 11);
    let src = source(&d, w, h);
    let out = run(&src, "tri_riley,tri,laplacian,rugosity", 5, 2);
    for y in 0..h as i64 {
        for x in 0..w as i64 {
            let i = y as usize * w + x as usize;
            let c = at(&d, w, h, x, y);
            let mut nb = Vec::new();
            for dy in -1..=1 {
                for dx in -1..=1 {
                    nb.push((dx, dy, at(&d, w, h, x + dx, y + dy)));
                }
            }
            if nb.iter().any(|v| v.2.is_nan()) {
                for k in 0..4 {
                    assert!(out[k][i].is_nan());
                }
                continue;
            }
            let riley = nb.iter().map(|v| (v.2 - c).powi(2)).sum::<f64>().sqrt();
            let wilson = nb.iter().map(|v| (v.2 - c).abs()).sum::<f64>() / 8.0;
            let z = |dx: i64, dy: i64| at(&d, w, h, x + dx, y + dy);
            let lap = (z(-1, 0) + z(1, 0) - 2.0 * c + z(0, -1) + z(0, 1) - 2.0 * c) / (CELL * CELL);
            // Jenness 2004: 8 triangles (centre, neighbour, next neighbour)
            // with half-length edges; area from the cross product.
            // The ring clockwise from the north-west corner.
            let ring = |k: usize| COMPASS8[(k + 7) % 8];
            let mut area = 0.0;
            for k in 0..8 {
                let (ax, ay) = ring(k);
                let (bx, by) = ring(k + 1);
                let u = [
                    ax as f64 * CELL / 2.0,
                    ay as f64 * CELL / 2.0,
                    (z(ax, ay) - c) / 2.0,
                ];
                let v = [
                    bx as f64 * CELL / 2.0,
                    by as f64 * CELL / 2.0,
                    (z(bx, by) - c) / 2.0,
                ];
                let cr = [
                    u[1] * v[2] - u[2] * v[1],
                    u[2] * v[0] - u[0] * v[2],
                    u[0] * v[1] - u[1] * v[0],
                ];
                area += 0.5 * (cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]).sqrt();
            }
            let rug = area / (CELL * CELL);
            assert!(close(out[0][i], riley, 2e-7, 0.0), "riley ({x},{y})");
            assert!(close(out[1][i], wilson, 2e-7, 0.0), "wilson ({x},{y})");
            assert!(close(out[2][i], lap, 2e-7, 1e-12), "lap ({x},{y})");
            assert_close(
                out[3][i],
                rug,
                1e-6,
                0.0,
                format_args!("rugosity ({x},{y})"),
            );
        }
    }
}

#[test]
fn roughness_brute_force() {
    let (w, h) = (23, 21);
    let d = random_grid(w, h, 5);
    let src = source(&d, w, h);
    let r = 3i64;
    // Unit normals from Horn's gradient written out by hand.
    let normal = |x: i64, y: i64| -> Option<[f64; 3]> {
        let z = |dx: i64, dy: i64| at(&d, w, h, x + dx, y + dy);
        let mut any_nan = false;
        for dy in -1..=1 {
            for dx in -1..=1 {
                any_nan |= z(dx, dy).is_nan();
            }
        }
        if any_nan {
            return None;
        }
        let p = (z(1, -1) + 2.0 * z(1, 0) + z(1, 1) - z(-1, -1) - 2.0 * z(-1, 0) - z(-1, 1))
            / (8.0 * CELL);
        let q = (z(-1, -1) + 2.0 * z(0, -1) + z(1, -1) - z(-1, 1) - 2.0 * z(0, 1) - z(1, 1))
            / (8.0 * CELL);
        let n = (p * p + q * q + 1.0).sqrt();
        Some([-p / n, -q / n, 1.0 / n])
    };
    let mut want = vec![f64::NAN; w * h];
    for y in 0..h as i64 {
        for x in 0..w as i64 {
            if at(&d, w, h, x, y).is_nan() {
                continue;
            }
            let (mut s, mut n) = ([0.0; 3], 0.0);
            for dy in -r..=r {
                for dx in -r..=r {
                    if let Some(v) = normal(x + dx, y + dy) {
                        for k in 0..3 {
                            s[k] += v[k];
                        }
                        n += 1.0;
                    }
                }
            }
            if n > 0.0 {
                let rb = ((s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt() / n).min(1.0);
                want[y as usize * w + x as usize] = (-2.0 * rb.ln()).sqrt().to_degrees();
            }
        }
    }
    for tile in [1, 6, 64] {
        let out = run(&src, "roughness:radius=3c", tile, 2);
        let name = format!("roughness tile {tile}");
        check(&name, &out[0], &want, w, 1e-6, 1e-5);
    }
}

#[test]
fn horizon_brute_force() {
    let (w, h) = (25, 22);
    let d = random_grid(w, h, 3);
    let src = source(&d, w, h);
    let cutoff = 45.0; // metres: 4 cells along axes, 3 along diagonals, 2 along knight moves
    for dirs in [8usize, 16] {
        let out = run(
            &src,
            &format!("openness:radius=45m:directions={dirs},openness_neg:radius=45m:directions={dirs},sky_view:radius=45m:directions={dirs}"),
            4,
            2,
        );
        let steps: Vec<(i64, i64)> = if dirs == 8 {
            crate::common::EAST8.to_vec()
        } else {
            vec![
                (1, 0),
                (1, 1),
                (0, 1),
                (-1, 1),
                (-1, 0),
                (-1, -1),
                (0, -1),
                (1, -1),
                (1, 2),
                (2, 1),
                (2, -1),
                (1, -2),
                (-1, -2),
                (-2, -1),
                (-2, 1),
                (-1, 2),
            ]
        };
        for y in 0..h as i64 {
            for x in 0..w as i64 {
                let i = y as usize * w + x as usize;
                let z0 = at(&d, w, h, x, y);
                let (mut pos, mut neg, mut svf, mut nd) = (0.0, 0.0, 0.0, 0.0);
                if !z0.is_nan() {
                    for &(sx, sy) in &steps {
                        // Scan the whole square and keep the cells on this ray.
                        let (mut hi, mut lo) = (f64::NEG_INFINITY, f64::INFINITY);
                        for dy in -5i64..=5 {
                            for dx in -5i64..=5 {
                                let k = if sx != 0 { dx / sx } else { dy / sy };
                                let on_ray = k >= 1 && k * sx == dx && k * sy == dy;
                                let dist = ((dx * dx + dy * dy) as f64).sqrt() * CELL;
                                let z = at(&d, w, h, x + dx, y + dy);
                                if on_ray && dist <= cutoff && !z.is_nan() {
                                    let t = ((z - z0) / dist).atan();
                                    hi = hi.max(t);
                                    lo = lo.min(t);
                                }
                            }
                        }
                        if hi > f64::NEG_INFINITY {
                            pos += 90.0 - hi.to_degrees();
                            neg += 90.0 + lo.to_degrees();
                            svf += hi.max(0.0).sin();
                            nd += 1.0;
                        }
                    }
                }
                let (p, n, s) = if nd > 0.0 {
                    (pos / nd, neg / nd, 1.0 - svf / nd)
                } else {
                    (f64::NAN, f64::NAN, f64::NAN)
                };
                assert_close(
                    out[0][i],
                    p,
                    1e-6,
                    1e-6,
                    format_args!("pos {dirs} ({x},{y})"),
                );
                assert_close(
                    out[1][i],
                    n,
                    1e-6,
                    1e-6,
                    format_args!("neg {dirs} ({x},{y})"),
                );
                assert_close(
                    out[2][i],
                    s,
                    1e-6,
                    1e-7,
                    format_args!("svf {dirs} ({x},{y})"),
                );
            }
        }
    }
}

#[test]
fn top_hats_brute_force() {
    let (w, h) = (26, 21);
    let d = random_grid(w, h, 23);
    let src = source(&d, w, h);
    for r in [1i64, 2, 4] {
        // Erosion and dilation at every valid cell (valid neighbours only).
        let mut ero = vec![f64::NAN; w * h];
        let mut dil = vec![f64::NAN; w * h];
        for y in 0..h as i64 {
            for x in 0..w as i64 {
                if at(&d, w, h, x, y).is_nan() {
                    continue;
                }
                let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
                for dy in -r..=r {
                    for dx in -r..=r {
                        let v = at(&d, w, h, x + dx, y + dy);
                        if !v.is_nan() {
                            lo = lo.min(v);
                            hi = hi.max(v);
                        }
                    }
                }
                ero[y as usize * w + x as usize] = lo;
                dil[y as usize * w + x as usize] = hi;
            }
        }
        let mut white = vec![f64::NAN; w * h];
        let mut black = vec![f64::NAN; w * h];
        for y in 0..h as i64 {
            for x in 0..w as i64 {
                let z = at(&d, w, h, x, y);
                if z.is_nan() {
                    continue;
                }
                let (mut open, mut close) = (f64::NEG_INFINITY, f64::INFINITY);
                for dy in -r..=r {
                    for dx in -r..=r {
                        let (xx, yy) = (x + dx, y + dy);
                        if xx < 0 || yy < 0 || xx >= w as i64 || yy >= h as i64 {
                            continue;
                        }
                        let i = yy as usize * w + xx as usize;
                        if !ero[i].is_nan() {
                            open = open.max(ero[i]);
                            close = close.min(dil[i]);
                        }
                    }
                }
                white[y as usize * w + x as usize] = z - open;
                black[y as usize * w + x as usize] = close - z;
                assert!(z - open >= 0.0 && close - z >= 0.0);
            }
        }
        for tile in [1, 7, 64] {
            let out = run(
                &src,
                &format!("tophat_white:radius={r}c,tophat_black:radius={r}c"),
                tile,
                2,
            );
            let name = format!("white r{r} tile {tile}");
            check(&name, &out[0], &white, w, 0.0, 0.0);
            let name = format!("black r{r} tile {tile}");
            check(&name, &out[1], &black, w, 0.0, 0.0);
        }
    }
}

#[test]
fn disk_window_statistics_brute_force() {
    window_statistics_brute_force((31, 27), 29, &[1, 3, 6], &[1, 8, 64], true);
}
