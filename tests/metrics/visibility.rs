//! Horizons and visibility against oracles that share no code with them:
//! the line-sweep horizons against the ray walk (bit for bit) and a brute
//! force in this file; zenith, nadir, accessibility, horizon angle and the
//! visibility index against brute-force loops; the R3 viewshed against an
//! exact-integer line-of-sight written here, a flat plane, a wall and the
//! curvature horizon distance (closed forms); tiled == untiled for every new
//! registry metric; bad parameters.

#![allow(clippy::needless_range_loop)] // index loops read like the definitions

use orogen::metrics::horizon::{tangents, HorizonMethod};
use orogen::metrics::visibility::{accumulate_viewshed, viewshed, ViewshedOptions};
use orogen::metrics::{parse_specs, MultiMetric};
use orogen::raster::{read_view, Crs, GeoRef, Grid, MemRaster, RasterSource, TileLayout};

/// Heights in 0..range (small ranges make many exact ties) with ~1/nd nodata.
fn random_grid(w: usize, h: usize, seed: u64, range: u64, nd: u64) -> Vec<f32> {
    let mut r = Rng(seed);
    (0..w * h)
        .map(|_| {
            let v = r.next();
            if nd > 0 && v.is_multiple_of(nd) {
                f32::NAN
            } else {
                ((v >> 8) % range) as f32 * 0.5
            }
        })
        .collect()
}

/// [`random_grid`] scaled and shifted off the half-metre lattice: no exact
/// ties between terrain and sight lines, where two formulations of the
/// line of sight could round differently.
fn irregular_grid(w: usize, h: usize, seed: u64, range: u64, nd: u64) -> Vec<f32> {
    random_grid(w, h, seed, range, nd)
        .iter()
        .enumerate()
        .map(|(i, v)| v * 1.01317 + 0.0173 * (i % 7) as f32)
        .collect()
}

use crate::common::{get as at, run, run_bits, source, Rng, CELL, RAYS16};

/// Brute-force largest and smallest elevation angle (radians) of ray `dir`
/// from (x, y) within `cutoff` metres: every cell of the square, kept if it
/// lies on the ray.
fn brute_ray(d: &[f32], w: usize, h: usize, x: i64, y: i64, dir: usize, cutoff: f64) -> (f64, f64) {
    let (sx, sy) = RAYS16[dir];
    let z0 = at(d, w, h, x, y);
    let (mut hi, mut lo) = (f64::NEG_INFINITY, f64::INFINITY);
    let r = (cutoff / CELL).ceil() as i64 + 1;
    for dy in -r..=r {
        for dx in -r..=r {
            let k = if sx != 0 { dx / sx } else { dy / sy };
            let on_ray = k >= 1 && k * sx == dx && k * sy == dy;
            let dist = ((dx * dx + dy * dy) as f64).sqrt() * CELL;
            let z = at(d, w, h, x + dx, y + dy);
            if on_ray && dist <= cutoff * (1.0 + 1e-12) && !z.is_nan() {
                let t = ((z - z0) / dist).atan();
                hi = hi.max(t);
                lo = lo.min(t);
            }
        }
    }
    (hi, lo)
}

/// The sweep finds the same cells as the rays (bit-equal tangents), and both
/// agree with the brute force, for 16 directions, upper and lower horizons,
/// several cutoffs and tile sizes, on grids full of ties and nodata.
#[test]
fn sweep_equals_rays_and_brute_force() {
    for (seed, (w, h), range) in [
        (1u64, (23usize, 19usize), 4u64),
        (2, (31, 27), 200),
        (3, (17, 40), 2),
    ] {
        let d = random_grid(w, h, seed, range, 9);
        let src = source(&d, w, h);
        for cutoff_cells in [1usize, 3, 7] {
            let cutoff = cutoff_cells as f64 * CELL * 1.05;
            for tile in [5usize, 8, 64] {
                let layout = TileLayout::new(w, h, tile);
                for id in 0..layout.count() {
                    let view = read_view::<f32>(&src, &layout, id, cutoff_cells).unwrap();
                    let n = view.core.w * view.core.h;
                    for dir in 0..16 {
                        for lower in [false, true] {
                            let [a, b] = [HorizonMethod::Rays, HorizonMethod::Sweep].map(|m| {
                                let mut t = vec![0.0; n];
                                tangents(&view, cutoff_cells, cutoff, dir, lower, m, &mut t);
                                t
                            });
                            for i in 0..n {
                                assert!(
                                    a[i].to_bits() == b[i].to_bits(),
                                    "seed {seed} tile {tile} dir {dir} lower {lower} cell {i}: rays {} sweep {}",
                                    a[i],
                                    b[i]
                                );
                                let (x, y) = (
                                    view.core.x + (i % view.core.w) as i64,
                                    view.core.y + (i / view.core.w) as i64,
                                );
                                let (hi, lo) = brute_ray(&d, w, h, x, y, dir, cutoff);
                                let want = if lower { lo } else { hi };
                                let got = b[i];
                                if at(&d, w, h, x, y).is_nan() {
                                    assert!(got.is_nan());
                                } else if want.is_infinite() {
                                    assert_eq!(
                                        got,
                                        if lower {
                                            f64::INFINITY
                                        } else {
                                            f64::NEG_INFINITY
                                        }
                                    );
                                } else {
                                    assert!(
                                        (got.atan() - want).abs() < 1e-12,
                                        "brute {want} got {}",
                                        got.atan()
                                    );
                                }
                            }
                        }
                    }
                }
            }
        }
    }
}

/// Zenith, nadir, accessibility and the horizon angle per direction against
/// brute force; the openness family is unchanged by the sweep (its own tests
/// in curvature_and_windows.rs).
#[test]
fn zenith_nadir_accessibility_horizon_brute_force() {
    let (w, h) = (26, 21);
    let d = random_grid(w, h, 7, 120, 11);
    let src = source(&d, w, h);
    let cutoff = 45.0;
    for dirs in [8usize, 16] {
        let specs = format!("zenith:radius=45m:directions={dirs},nadir:radius=45m:directions={dirs},accessibility:radius=45m:directions={dirs},horizon:radius=45m:dir=135,horizon:radius=45m:dir=26.565");
        let out = run(&src, &specs, 6, 2);
        for y in 0..h as i64 {
            for x in 0..w as i64 {
                let i = y as usize * w + x as usize;
                let z0 = at(&d, w, h, x, y);
                let (mut hmax, mut lmin, mut acc, mut nd) =
                    (f64::NEG_INFINITY, f64::INFINITY, 0.0, 0.0);
                for dir in 0..dirs {
                    let (hi, lo) = brute_ray(&d, w, h, x, y, dir, cutoff);
                    if z0.is_nan() || hi == f64::NEG_INFINITY {
                        continue;
                    }
                    hmax = hmax.max(hi);
                    lmin = lmin.min(lo);
                    acc += hi.max(0.0).cos().powi(2);
                    nd += 1.0;
                }
                let want = if nd == 0.0 {
                    [f64::NAN; 3]
                } else {
                    [90.0 - hmax.to_degrees(), 90.0 + lmin.to_degrees(), acc / nd]
                };
                for k in 0..3 {
                    let g = out[k][i] as f64;
                    assert!(
                        (want[k].is_nan() && g.is_nan()) || (g - want[k]).abs() < 1e-4,
                        "dirs {dirs} metric {k} ({x},{y}): {g} vs {}",
                        want[k]
                    );
                }
                // dir=135 is RAYS16[3] = (1, 1); 26.565 is (1, -2) = RAYS16[8].
                for (k, dir) in [(3usize, 3usize), (4, 8)] {
                    let (hi, _) = brute_ray(&d, w, h, x, y, dir, cutoff);
                    let want = if z0.is_nan() || hi == f64::NEG_INFINITY {
                        f64::NAN
                    } else {
                        hi.to_degrees()
                    };
                    let g = out[k][i] as f64;
                    assert!(
                        (want.is_nan() && g.is_nan()) || (g - want).abs() < 1e-4,
                        "horizon dir {dir} ({x},{y}): {g} vs {want}"
                    );
                }
            }
        }
    }
    // A pit of slope k: every horizon at atan k, so zenith = 90 - atan k and
    // accessibility = cos²(atan k) = 1/(1+k²) at the centre.
    let (w, h) = (31, 31);
    let k = 0.4;
    let data: Vec<f32> = (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f64 - 15.0, (i / w) as f64 - 15.0);
            (k * CELL * (x * x + y * y).sqrt()) as f32
        })
        .collect();
    let out = run(
        &source(&data, w, h),
        "zenith:radius=100m,accessibility:radius=100m:directions=16",
        9,
        1,
    );
    let c = 15 * w + 15;
    assert!((out[0][c] as f64 - (90.0 - k.atan().to_degrees())).abs() < 1e-4);
    assert!((out[1][c] as f64 - 1.0 / (1.0 + k * k)).abs() < 1e-6);
}

/// Per cell, nodata: `None`; else `(seen, of)`: how many of the valid cells
/// `targets(x, y)` lists the R3 line of sight [`los_exact`] sees from the
/// eye `heights.0` above the cell, targets `heights.1` above theirs.
fn visible_counts<I: Iterator<Item = (i64, i64)>>(
    d: &[f32],
    w: usize,
    h: usize,
    heights: (f64, f64),
    targets: impl Fn(i64, i64) -> I,
) -> Vec<Option<(usize, usize)>> {
    (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as i64, (i / w) as i64);
            if d[i].is_nan() {
                return None;
            }
            let valid: Vec<(i64, i64)> = targets(x, y)
                .filter(|&(tx, ty)| !at(d, w, h, tx, ty).is_nan())
                .collect();
            let seen = valid
                .iter()
                .filter(|&&t| los_exact(d, w, (x, y), t, heights.0, heights.1))
                .count();
            Some((seen, valid.len()))
        })
        .collect()
}

/// R3 line of sight with exact integer crossings (an independent
/// formulation): is target (tx, ty) visible from (ox, oy)?
fn los_exact(d: &[f32], w: usize, o: (i64, i64), t: (i64, i64), ho: f64, ht: f64) -> bool {
    let z = |x: i64, y: i64| d[y as usize * w + x as usize] as f64;
    let eye = z(o.0, o.1) + ho;
    let tgt = z(t.0, t.1) + ht;
    let (dx, dy) = (t.0 - o.0, t.1 - o.1);
    // Column crossings: x = o.0 + j·sign(dx), j = 1..|dx|-1; y = o.1 + j·dy/|dx|.
    for (n, along_x) in [(dx.abs(), true), (dy.abs(), false)] {
        for j in 1..n {
            let (num, den) = if along_x {
                (j * dy, dx.abs())
            } else {
                (j * dx, dy.abs())
            };
            let q = num.div_euclid(den);
            let r = num.rem_euclid(den);
            let (a, b) = if along_x {
                let x = o.0 + j * dx.signum();
                (z(x, o.1 + q), if r == 0 { 0.0 } else { z(x, o.1 + q + 1) })
            } else {
                let y = o.1 + j * dy.signum();
                (z(o.0 + q, y), if r == 0 { 0.0 } else { z(o.0 + q + 1, y) })
            };
            let terrain = if r == 0 {
                a
            } else {
                a + (b - a) * r as f64 / den as f64
            };
            if terrain.is_nan() {
                continue;
            }
            let frac = j as f64 / n as f64;
            if terrain > eye + frac * (tgt - eye) {
                return false;
            }
        }
    }
    true
}

#[test]
fn viewshed_matches_exact_line_of_sight() {
    let (w, h) = (29, 23);
    for seed in 0..4u64 {
        let d = random_grid(w, h, 100 + seed, 60, 15);
        let g = Grid::from_vec(w, h, d.clone()).unwrap();
        let mut r = Rng(seed);
        for _ in 0..3 {
            let (ox, oy) = (
                (r.next() % w as u64) as usize,
                (r.next() % h as u64) as usize,
            );
            if g.get(ox, oy).is_nan() {
                continue;
            }
            let o = ViewshedOptions {
                observer_height: [0.0, 1.7, 12.0][(r.next() % 3) as usize],
                target_height: [0.0, 2.5][(r.next() % 2) as usize],
                radius_m: 150.0,
                curvature: None,
            };
            let v = viewshed(&g, (CELL, CELL), (ox, oy), &o).unwrap();
            let (mut vis, mut hid) = (0, 0);
            for ty in 0..h {
                for tx in 0..w {
                    let dist = (((tx as f64 - ox as f64).powi(2)
                        + (ty as f64 - oy as f64).powi(2))
                    .sqrt())
                        * CELL;
                    let want = if g.get(tx, ty).is_nan() || dist > 150.0 {
                        255
                    } else {
                        u8::from(los_exact(
                            &d,
                            w,
                            (ox as i64, oy as i64),
                            (tx as i64, ty as i64),
                            o.observer_height,
                            o.target_height,
                        ))
                    };
                    assert_eq!(
                        v.get(tx, ty),
                        want,
                        "seed {seed} observer ({ox},{oy}) target ({tx},{ty})"
                    );
                    vis += usize::from(want == 1);
                    hid += usize::from(want == 0);
                }
            }
            assert!(
                vis > 5 && hid > 5,
                "a test that cannot fail: {vis} visible, {hid} hidden"
            );
        }
    }
}

/// Options of a viewshed from `height` above the ground within `radius_m`,
/// targets on the ground, no curvature.
fn eye(height: f64, radius_m: f64) -> ViewshedOptions {
    ViewshedOptions {
        observer_height: height,
        radius_m,
        ..Default::default()
    }
}

#[test]
fn viewshed_closed_forms() {
    // Flat plane: everything within the radius is visible, nothing beyond.
    let (w, h) = (41, 35);
    let g = Grid::new(w, h, 100.0f32);
    let v = viewshed(&g, (CELL, CELL), (20, 17), &eye(1.7, 123.0)).unwrap();
    for y in 0..h {
        for x in 0..w {
            let dist = ((x as f64 - 20.0).powi(2) + (y as f64 - 17.0).powi(2)).sqrt() * CELL;
            assert_eq!(
                v.get(x, y),
                if dist <= 123.0 { 1 } else { 255 },
                "({x},{y})"
            );
        }
    }
    // A wall higher than the eye at column 25 hides every cell behind it.
    let mut g = Grid::new(w, h, 0.0f32);
    for y in 0..h {
        g.set(25, y, 5.0);
    }
    let v = viewshed(&g, (CELL, CELL), (10, 17), &eye(2.0, 1e6)).unwrap();
    for y in 0..h {
        for x in 0..w {
            assert_eq!(v.get(x, y), u8::from(x <= 25), "wall ({x},{y})");
        }
    }
    // Earth curvature with refraction k: on a sea-level plane, a target at
    // distance D is hidden once the bulge t·D²(1−k)/(2R) exceeds the eye height;
    // the horizon distance is √(2Rh/(1−k)).
    let (w, h) = (260, 3);
    let g = Grid::new(w, h, 0.0f32);
    let cell = 100.0;
    let k = 0.13;
    let o = ViewshedOptions {
        observer_height: 10.0,
        radius_m: 1e7,
        curvature: Some(k),
        ..Default::default()
    };
    let v = viewshed(&g, (cell, cell), (0, 1), &o).unwrap();
    let horizon = (2.0 * 6_371_000.0 * 10.0 / (1.0 - k)).sqrt();
    for x in 2..w {
        let dist = x as f64 * cell;
        if dist < 0.97 * horizon {
            assert_eq!(v.get(x, 1), 1, "{dist} m is before the horizon {horizon}");
        } else if dist > 1.03 * horizon {
            assert_eq!(v.get(x, 1), 0, "{dist} m is beyond the horizon {horizon}");
        }
    }
}

#[test]
fn cumulative_and_fuzzy_viewsheds() {
    let (w, h) = (25, 20);
    let d = irregular_grid(w, h, 55, 40, 0);
    let g = Grid::from_vec(w, h, d.clone()).unwrap();
    let o = eye(3.0, 1e6);
    let obs = [(3usize, 4usize), (20, 15), (12, 10)];
    let mut count = Grid::new(w, h, 0f32);
    let mut fuzzy = Grid::new(w, h, 0f32);
    let (b1, b2) = (50.0, 40.0);
    for &p in &obs {
        accumulate_viewshed(&g, (CELL, CELL), p, &o, None, &mut count).unwrap();
        accumulate_viewshed(&g, (CELL, CELL), p, &o, Some((b1, b2)), &mut fuzzy).unwrap();
    }
    for ty in 0..h {
        for tx in 0..w {
            let (mut n, mut f) = (0.0, 0.0);
            for &(ox, oy) in &obs {
                if los_exact(
                    &d,
                    w,
                    (ox as i64, oy as i64),
                    (tx as i64, ty as i64),
                    3.0,
                    0.0,
                ) {
                    n += 1.0;
                    let dist = ((tx as f64 - ox as f64).powi(2) + (ty as f64 - oy as f64).powi(2))
                        .sqrt()
                        * CELL;
                    // Fisher 1994's membership, written out.
                    f += if dist <= b1 {
                        1.0
                    } else {
                        1.0 / (1.0 + ((dist - b1) / b2).powi(2))
                    };
                }
            }
            assert_eq!(count.get(tx, ty) as f64, n, "count ({tx},{ty})");
            assert!(
                (fuzzy.get(tx, ty) as f64 - f).abs() < 1e-5,
                "fuzzy ({tx},{ty})"
            );
        }
    }
}

/// Visibility index with 8 rays == the share of the R3-visible targets on
/// the axes and diagonals (where R3 crosses cell centres only), brute force.
#[test]
fn visibility_index_matches_r3_on_the_rays() {
    let (w, h) = (24, 22);
    let d = random_grid(w, h, 77, 50, 13);
    let src = source(&d, w, h);
    for (height, target) in [(1.7, 0.0), (0.0, 3.0)] {
        let spec = format!("visibility_index:radius=50m:height={height}:target={target}");
        let out = run(&src, &spec, 7, 2);
        // The targets on the axes and diagonals within 50 m.
        let on_rays = |x: i64, y: i64| {
            RAYS16
                .into_iter()
                .take(8)
                .flat_map(|(sx, sy)| (1..=5i64).map(move |s| (s * sx, s * sy)))
                .filter(|&(dx, dy)| {
                    ((dx * dx + dy * dy) as f64).sqrt() * CELL <= 50.0 * (1.0 + 1e-12)
                })
                .map(move |(dx, dy)| (x + dx, y + dy))
        };
        let counts = visible_counts(&d, w, h, (height, target), on_rays);
        for (i, c) in counts.iter().enumerate() {
            let g = out[0][i] as f64;
            let Some((seen, n)) = *c else {
                assert!(g.is_nan());
                continue;
            };
            let want = if n == 0 {
                f64::NAN
            } else {
                seen as f64 / n as f64
            };
            assert!(
                (want.is_nan() && g.is_nan()) || (g - want).abs() < 1e-6,
                "({}, {}) h={height}: {g} vs {want}",
                i % w,
                i / w
            );
        }
    }
}

/// The exact visibility index against the share of R3-visible cells of the
/// disk computed with the exact-integer line of sight of this file.
#[test]
fn visibility_index_exact_brute_force() {
    let (w, h) = (19, 17);
    let d = irregular_grid(w, h, 31, 80, 10);
    let src = source(&d, w, h);
    let out = run(
        &src,
        "visibility_index_exact:radius=42m:height=1.3:target=0.4",
        6,
        2,
    );
    // Every other cell within 42 m.
    let in_disk = |x: i64, y: i64| {
        (0..h as i64)
            .flat_map(move |ty| (0..w as i64).map(move |tx| (tx, ty)))
            .filter(move |&(tx, ty)| {
                let dist2 = (((tx - x).pow(2) + (ty - y).pow(2)) as f64) * CELL * CELL;
                (tx, ty) != (x, y) && dist2 <= 42.0 * 42.0
            })
    };
    let counts = visible_counts(&d, w, h, (1.3, 0.4), in_disk);
    let mut distinct = std::collections::BTreeSet::new();
    for (i, c) in counts.iter().enumerate() {
        let g = out[0][i] as f64;
        let Some((seen, n)) = *c else {
            assert!(g.is_nan());
            continue;
        };
        let want = seen as f64 / n as f64;
        assert!(
            (g - want).abs() < 1e-6,
            "({}, {}): {g} vs {want}",
            i % w,
            i / w
        );
        distinct.insert(seen);
    }
    assert!(distinct.len() > 10, "a varied test: {distinct:?}");
}

const NEW: &str = "visibility_index_exact:radius=3c,horizon:radius=4c:dir=45,zenith:radius=40m,nadir:radius=4c:directions=16,accessibility:radius=4c,visibility_index:radius=3c:directions=16,solar_direct:lat=34.3:radius=4c:hour=9.5,solar_global:lat=34.3:radius=4c:step=60:day=355,solar_annual:lat=34.3:radius=3c:days=60:step=120:directions=8,heat_index";

fn check_tiled(src: &dyn RasterSource, specs: &str, tiles: &[usize]) {
    let i = src.info();
    let whole = run_bits(src, specs, i.width.max(i.height), 1);
    for (k, g) in whole.iter().enumerate() {
        let valid = g.iter().filter(|&&v| v != u32::MAX).count();
        assert!(valid > g.len() / 2, "metric {k} mostly nodata");
        assert!(g.iter().any(|&v| v != g[0]), "metric {k} constant");
    }
    for &tile in tiles {
        let got = run_bits(src, specs, tile, 2);
        for k in 0..whole.len() {
            if let Some(c) = (0..whole[k].len()).find(|&c| got[k][c] != whole[k][c]) {
                panic!(
                    "{specs}: metric {k} tile {tile} cell {c}: {} vs {}",
                    f32::from_bits(got[k][c]),
                    f32::from_bits(whole[k][c])
                );
            }
        }
    }
}

#[test]
fn tiled_equals_untiled_new_metrics() {
    let src = orogen::io::open_raster(
        std::path::Path::new("tests/data/bigtujunga_crop.tif"),
        &Default::default(),
    )
    .unwrap();
    check_tiled(src.as_ref(), NEW, &[7, 64]);
    // Tile size 1 on a random grid with holes.
    let (w, h) = (23, 17);
    let d = random_grid(w, h, 9, 300, 17);
    let small = source(&d, w, h);
    check_tiled(&small, NEW, &[1, 5]);
    // One pass (shared horizon scans) == each metric alone, duplicates included.
    let specs = format!("{NEW},zenith:radius=4c,accessibility:radius=4c,nadir:radius=4c");
    let whole = run_bits(&small, &specs, 8, 1);
    for (k, s) in specs.split(',').enumerate() {
        let alone = run_bits(&small, s, 8, 1);
        assert!(
            alone[0] == whole[k],
            "{s} alone differs from the multi pass"
        );
    }
    // Geographic raster: per-row cell sizes and latitudes (lat=auto).
    let asc = orogen::io::open_raster(
        std::path::Path::new("tests/data/landlab_SRTMGL3_frontrange.asc"),
        &Default::default(),
    )
    .unwrap();
    let info = asc.info().clone();
    let data = asc
        .read_native(orogen::raster::Window::full(info.width, info.height))
        .unwrap();
    let mut g = info.georef.clone();
    g.crs = Crs::wgs84();
    g.georeferenced = true;
    let geo = MemRaster::new(data, g, "frontrange");
    check_tiled(
        &geo,
        "zenith:radius=300m,accessibility:radius=300m:directions=16,solar_global:radius=300m:step=60,heat_index",
        &[13, 64],
    );
}

fn err(src: &dyn RasterSource, specs: &str) -> String {
    match parse_specs(specs) {
        Err(e) => e.to_string(),
        Ok(s) => MultiMetric::new(&s, src.info()).unwrap_err().to_string(),
    }
}

#[test]
fn bad_parameters() {
    let (w, h) = (20, 20);
    let src = source(&vec![1.0; w * h], w, h);
    // Each refused spec and what its error says.
    for (spec, says) in [
        ("zenith:radius=-5m", &["positive"][..]),
        ("visibility_index:radius=500m", &["beyond the raster"]),
        ("horizon:dir=30", &["lattice direction", "26.57"]),
        ("visibility_index:height=-1", &["outside"]),
        ("solar_direct:day=400", &["day", "366"]),
        ("solar_global:lat=95", &["-90"]),
    ] {
        let e = err(&src, spec);
        assert!(says.iter().all(|w| e.contains(w)), "{spec}: {e}");
    }
    // A projected CRS orogen cannot invert needs lat=; UTM gets its centre's latitude.
    let g = Grid::from_vec(w, h, vec![1.0f32; w * h]).unwrap();
    let lambert = MemRaster::from_grid(
        g,
        GeoRef::north_up(500_000.0, 4_000_000.0, CELL, Crs::projected(2180)),
    );
    let e = err(&lambert, "solar_global");
    assert!(e.contains("lat="), "{e}");
    let ok = parse_specs("solar_global").unwrap();
    let m = MultiMetric::new(&ok, src.info()).unwrap();
    // UTM 11N, northing 4000 km: about 36.1 degrees north (PROJ: 36.1438).
    let lat = m.metrics()[0].spec.value("lat").unwrap();
    assert!((lat - 36.1438).abs() < 1e-3, "{lat}");
    let big = source(&vec![1.0; 150 * 150], 150, 150);
    let e = err(&big, "visibility_index_exact:radius=120c");
    assert!(
        e.contains("above its limit") && e.contains("visibility_index"),
        "{e}"
    );
    // Viewshed: observer outside, on nodata, bad radius and heights.
    let g = Grid::new(w, h, 1.0f32);
    let o = ViewshedOptions::default();
    let e = viewshed(&g, (1.0, 1.0), (20, 3), &o)
        .unwrap_err()
        .to_string();
    assert!(e.contains("outside"), "{e}");
    let mut gn = g.clone();
    gn.set(2, 2, f32::NAN);
    let e = viewshed(&gn, (1.0, 1.0), (2, 2), &o)
        .unwrap_err()
        .to_string();
    assert!(e.contains("nodata"), "{e}");
    for bad in [-1.0, 0.0, f64::NAN] {
        let o = ViewshedOptions {
            radius_m: bad,
            ..Default::default()
        };
        let e = viewshed(&g, (1.0, 1.0), (2, 2), &o)
            .unwrap_err()
            .to_string();
        assert!(e.contains("positive distance"), "{e}");
    }
    let o = ViewshedOptions {
        observer_height: -2.0,
        ..Default::default()
    };
    assert!(viewshed(&g, (1.0, 1.0), (2, 2), &o).is_err());
}
