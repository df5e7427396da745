//! Routing and areas on a geographic (lat/lon) DEM against oracles with the
//! true geometry: distances between cell centres are geodesics on the WGS 84
//! ellipsoid by Vincenty's inverse formula (written here, sharing nothing
//! with `orogen::raster`), and cell areas are checked against the
//! ellipsoid's total area. The DEM is a 300 x 300 crop of SRTM3 N46E008
//! (3" cells at 46.5°N: 64 m east-west, 93 m north-south), so square-cell
//! routing would be wrong on a large share of the cells.

use orogen::exec::EngineConfig;
use orogen::hydro::d8_directions;
use orogen::ops::{accumulate, fill, flow, Target};
use orogen::raster::{read_window, AnyGrid, GeoRef, Grid, MemRaster, RasterSource, Window};

use crate::common::test_data;
use crate::NB;

/// Geodesic distance in metres between two points on WGS 84 (Vincenty, T.
/// (1975), "Direct and inverse solutions of geodesics on the ellipsoid with
/// application of nested equations", Survey Review 23(176), 88–93, the
/// inverse formula iterated to 1e-13 rad).
fn vincenty(lat1: f64, lon1: f64, lat2: f64, lon2: f64) -> f64 {
    let a = 6_378_137.0f64;
    let f = 1.0 / 298.257_223_563;
    let b = a * (1.0 - f);
    let l = (lon2 - lon1).to_radians();
    let u1 = ((1.0 - f) * lat1.to_radians().tan()).atan();
    let u2 = ((1.0 - f) * lat2.to_radians().tan()).atan();
    let (su1, cu1) = u1.sin_cos();
    let (su2, cu2) = u2.sin_cos();
    let mut lam = l;
    let (mut ss, mut cs, mut sigma, mut c2a, mut c2sm) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for _ in 0..200 {
        let (sl, cl) = lam.sin_cos();
        ss = ((cu2 * sl).powi(2) + (cu1 * su2 - su1 * cu2 * cl).powi(2)).sqrt();
        if ss == 0.0 {
            return 0.0;
        }
        cs = su1 * su2 + cu1 * cu2 * cl;
        sigma = ss.atan2(cs);
        let sa = cu1 * cu2 * sl / ss;
        c2a = 1.0 - sa * sa;
        c2sm = if c2a != 0.0 {
            cs - 2.0 * su1 * su2 / c2a
        } else {
            0.0
        };
        let c = f / 16.0 * c2a * (4.0 + f * (4.0 - 3.0 * c2a));
        let prev = lam;
        lam = l
            + (1.0 - c) * f * sa * (sigma + c * ss * (c2sm + c * cs * (-1.0 + 2.0 * c2sm * c2sm)));
        if (lam - prev).abs() < 1e-13 {
            break;
        }
    }
    let u2s = c2a * (a * a - b * b) / (b * b);
    let aa = 1.0 + u2s / 16384.0 * (4096.0 + u2s * (-768.0 + u2s * (320.0 - 175.0 * u2s)));
    let bb = u2s / 1024.0 * (256.0 + u2s * (-128.0 + u2s * (74.0 - 47.0 * u2s)));
    let ds = bb
        * ss
        * (c2sm
            + bb / 4.0
                * (cs * (-1.0 + 2.0 * c2sm * c2sm)
                    - bb / 6.0 * c2sm * (-3.0 + 4.0 * ss * ss) * (-3.0 + 4.0 * c2sm * c2sm)));
    b * aa * (sigma - ds)
}

/// The crop, filled by orogen (the routers' input), with its georeference.
fn filled_crop() -> (Grid<f32>, GeoRef) {
    let src = orogen::io::open_raster(
        &test_data("oro/srtm3_N46E008_crop.tif"),
        &Default::default(),
    )
    .expect("the crop opens");
    assert!(src.info().georef.crs.geographic, "the crop is lat/lon");
    let t = Target::memory(&std::env::temp_dir());
    fill::run(src.as_ref(), &Default::default(), &t, &cfg(1 << 30)).expect("fill runs");
    let (AnyGrid::F32(g), georef) = t.take_memory().expect("fill output") else {
        panic!("fill writes f32")
    };
    // nodata (a value below the data) read back as NaN
    let (w, h) = (g.width(), g.height());
    let nan = read_window::<f32>(&MemRaster::from_grid(g, georef.clone()), Window::full(w, h))
        .expect("read back");
    assert!(nan.data().iter().any(|v| v.is_nan()), "the crop has voids");
    (nan, georef.with_nodata(None))
}

fn cfg(budget: u64) -> EngineConfig {
    EngineConfig {
        threads: 2,
        memory_budget: budget,
        ..Default::default()
    }
}

/// Centre (lat, lon) of cell (x, y), from the transform's six numbers.
fn centre(t: &[f64; 6], x: i64, y: i64) -> (f64, f64) {
    let (xf, yf) = (x as f64 + 0.5, y as f64 + 0.5);
    (t[3] + xf * t[4] + yf * t[5], t[0] + xf * t[1] + yf * t[2])
}

/// Geodesic distance from cell (x, y) to its neighbour k.
fn dist(t: &[f64; 6], x: i64, y: i64, k: usize) -> f64 {
    let (la, lo) = centre(t, x, y);
    let (lb, lob) = centre(t, x + NB[k].0, y + NB[k].1);
    vincenty(la, lo, lb, lob)
}

/// Cells of the interior (all 8 neighbours valid and on the grid).
fn interior(z: &Grid<f32>) -> Vec<(usize, usize)> {
    let (w, h) = (z.width(), z.height());
    let mut v = Vec::new();
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let ok = !z.get(x, y).is_nan()
                && NB.iter().all(|&(dx, dy)| {
                    !z.get((x as i64 + dx) as usize, (y as i64 + dy) as usize)
                        .is_nan()
                });
            if ok {
                v.push((x, y));
            }
        }
    }
    v
}

fn mem(g: &Grid<f32>, georef: &GeoRef) -> MemRaster {
    MemRaster::from_grid(g.clone(), georef.clone())
}

fn flow_codes(src: &dyn RasterSource, tile: Option<usize>) -> Grid<u8> {
    let mut t = Target::memory(&std::env::temp_dir());
    t.tile = tile;
    flow::run(src, &Default::default(), &t, &cfg(1 << 30)).expect("flow runs");
    let (AnyGrid::U8(g), _) = t.take_memory().expect("flow output") else {
        panic!("flow writes u8")
    };
    g
}

#[test]
fn d8_follows_the_true_steepest_descent() {
    let (z, georef) = filled_crop();
    let t = georef.transform;
    let d8 = flow_codes(&mem(&z, &georef), None);
    // tiled with odd tiles: the same bytes
    for tile in [37, 64] {
        assert_eq!(
            flow_codes(&mem(&z, &georef), Some(tile)).data(),
            d8.data(),
            "tile {tile}"
        );
    }
    let (mut checked, mut square_differs) = (0usize, 0usize);
    for (x, y) in interior(&z) {
        let zc = z.get(x, y) as f64;
        let mut s: Vec<(f64, usize)> = (0..8)
            .map(|k| {
                let zn = z.get((x as i64 + NB[k].0) as usize, (y as i64 + NB[k].1) as usize) as f64;
                ((zc - zn) / dist(&t, x as i64, y as i64, k), k)
            })
            .collect();
        s.sort_by(|a, b| b.0.total_cmp(&a.0));
        // a unique steepest descent (margin 1e-6 relative)
        if s[0].0 <= 0.0 || s[0].0 - s[1].0 <= 1e-6 * s[0].0 {
            continue;
        }
        checked += 1;
        let code = d8.get(x, y);
        assert_eq!(code, 1u8 << s[0].1, "cell ({x}, {y}): slopes {s:?}");
        // the square-cell rule (1 and √2) for comparison
        let sq = (0..8)
            .map(|k| {
                let zn = z.get((x as i64 + NB[k].0) as usize, (y as i64 + NB[k].1) as usize) as f64;
                (zc - zn) / if k % 2 == 1 { 2f64.sqrt() } else { 1.0 }
            })
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(&b.1).then(b.0.cmp(&a.0)))
            .unwrap()
            .0;
        if sq != s[0].1 {
            square_differs += 1;
        }
    }
    assert!(checked > 60_000, "{checked} cells checked");
    // At 46.5°N square cells send a large share elsewhere: the test has teeth.
    let share = square_differs as f64 / checked as f64;
    assert!(
        share > 0.15,
        "square cells differ on {share:.3} of the cells only"
    );
    // the library's square-cell router is the old rule, and differs here
    let square = d8_directions(&z);
    assert_ne!(square.data(), d8.data());
}

#[test]
fn dinf_facets_use_the_true_legs() {
    use orogen::hydro::dinf::dinf_on;
    use orogen::raster::neighbours::CellGeometry;
    let (z, georef) = filled_crop();
    let t = georef.transform;
    let geo = CellGeometry::of_rows(&georef, 0, z.height());
    let r = dinf_on(&z, &geo).expect("dinf");
    // Tarboton's facets (e1, e2) in his order, with the angle a = ac·π/2 + af·r.
    const F: [(usize, usize, f64, f64); 8] = [
        (0, 7, 0.0, 1.0),
        (6, 7, 1.0, -1.0),
        (6, 5, 1.0, 1.0),
        (4, 5, 2.0, -1.0),
        (4, 3, 2.0, 1.0),
        (2, 3, 3.0, -1.0),
        (2, 1, 3.0, 1.0),
        (0, 1, 4.0, -1.0),
    ];
    let mut checked = 0;
    for (x, y) in interior(&z) {
        let (xi, yi) = (x as i64, y as i64);
        let e0 = z.get(x, y) as f64;
        let at = |k: usize| z.get((xi + NB[k].0) as usize, (yi + NB[k].1) as usize) as f64;
        let mut best: Vec<(f64, f64)> = F
            .iter()
            .map(|&(k1, k2, ac, af)| {
                let d1 = dist(&t, xi, yi, k1);
                let (la, lo) = centre(&t, xi + NB[k1].0, yi + NB[k1].1);
                let (lb, lob) = centre(&t, xi + NB[k2].0, yi + NB[k2].1);
                let d2 = vincenty(la, lo, lb, lob);
                let (s1, s2) = ((e0 - at(k1)) / d1, (at(k1) - at(k2)) / d2);
                let rmax = d2.atan2(d1);
                let rr = s2.atan2(s1);
                let (rr, s) = if rr <= 0.0 {
                    (0.0, s1)
                } else if rr >= rmax {
                    (rmax, (e0 - at(k2)) / d1.hypot(d2))
                } else {
                    (rr, s1.hypot(s2))
                };
                let mut a = ac * std::f64::consts::FRAC_PI_2 + af * rr;
                if a >= 2.0 * std::f64::consts::PI {
                    a = 0.0;
                }
                (s, a)
            })
            .collect();
        best.sort_by(|a, b| b.0.total_cmp(&a.0));
        if best[0].0 <= 0.0 || best[0].0 - best[1].0 <= 1e-6 * best[0].0 {
            continue;
        }
        checked += 1;
        let got = r.angle.get(x, y) as f64;
        let want = best[0].1 as f32 as f64;
        // angles within 1e-5 rad (f32 output; the plane legs and the
        // geodesics agree to ~1e-9)
        let diff = (got - want)
            .abs()
            .min(2.0 * std::f64::consts::PI - (got - want).abs());
        assert!(diff < 1e-5, "cell ({x}, {y}): angle {got} want {want}");
    }
    assert!(checked > 60_000, "{checked} cells checked");
}

#[test]
fn mfd_weights_use_the_true_distances() {
    use orogen::hydro::mfd::{mfd_flow_on, MfdMethod};
    use orogen::raster::neighbours::CellGeometry;
    let (z, georef) = filled_crop();
    let t = georef.transform;
    let geo = CellGeometry::of_rows(&georef, 0, z.height());
    let f = mfd_flow_on(&z, MfdMethod::Freeman, &geo).expect("mfd");
    let mut checked = 0;
    for (x, y) in interior(&z) {
        let (xi, yi) = (x as i64, y as i64);
        let zc = z.get(x, y) as f64;
        // Freeman 1991: fractions ∝ tan β ^ 1.1 over the lower neighbours
        let w: Vec<f64> = (0..8)
            .map(|k| {
                let zn = z.get((xi + NB[k].0) as usize, (yi + NB[k].1) as usize) as f64;
                if zn < zc {
                    ((zc - zn) / dist(&t, xi, yi, k)).powf(1.1)
                } else {
                    0.0
                }
            })
            .collect();
        let sum: f64 = w.iter().sum();
        if sum <= 0.0 {
            continue;
        }
        checked += 1;
        let got = f.fractions(x, y).expect("a valid cell");
        for k in 0..8 {
            assert!(
                (got[k] - w[k] / sum).abs() < 1e-7,
                "cell ({x}, {y}) neighbour {k}: {} vs {}",
                got[k],
                w[k] / sum
            );
        }
    }
    assert!(checked > 60_000, "{checked} cells checked");
}

#[test]
fn divergent_accumulation_on_lat_lon_is_the_same_tiled() {
    let (z, georef) = filled_crop();
    let src = mem(&z, &georef);
    for method in [
        accumulate::AccumulateMethod::Dinf,
        accumulate::AccumulateMethod::Freeman,
    ] {
        let opts = accumulate::AccumulateOptions {
            method,
            ..Default::default()
        };
        let run = |budget: u64, tile: Option<usize>| {
            let dir = tempfile::tempdir().unwrap();
            let mut t = Target::new(dir.path().join("acc.tif"));
            t.tile = tile;
            accumulate::run(&src, &opts, &t, &cfg(budget)).expect("accumulate");
            let r = orogen::io::open_raster(&t.path, &Default::default()).unwrap();
            read_window::<f64>(r.as_ref(), Window::full(300, 300)).unwrap()
        };
        let whole = run(1 << 30, None);
        let tiled = run(1 << 20, Some(37));
        assert_eq!(
            whole.data().iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            tiled.data().iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            "{method:?}"
        );
    }
}

/// Area in m² of the zone between latitudes `a` and `b` (degrees) and 1° of
/// longitude on WGS 84, by Simpson's rule on the area element M(φ)·N(φ)·cos φ
/// (the radii of curvature: an oracle independent of the closed form the
/// library uses).
fn zone_area(a: f64, b: f64) -> f64 {
    let (ra, e2) = (6_378_137.0f64, 0.006_694_379_990_141_317f64);
    let el = |phi: f64| {
        let w = (1.0 - e2 * phi.sin().powi(2)).sqrt();
        let m = ra * (1.0 - e2) / (w * w * w);
        let n = ra / w;
        m * n * phi.cos()
    };
    let (p0, p1) = (a.to_radians(), b.to_radians());
    let k = 2000;
    let hstep = (p1 - p0) / k as f64;
    let mut s = el(p0) + el(p1);
    for i in 1..k {
        s += el(p0 + i as f64 * hstep) * if i % 2 == 1 { 4.0 } else { 2.0 };
    }
    (s * hstep / 3.0).abs() * 1f64.to_radians()
}

/// A global 1° grid whose D8 directions all point east, the last column an
/// outlet: each row's accumulation at the outlet is the row's area.
fn global_east() -> MemRaster {
    let georef = GeoRef {
        transform: [-180.0, 1.0, 0.0, 90.0, 0.0, -1.0],
        crs: orogen::raster::Crs::wgs84(),
        ..GeoRef::pixel()
    };
    let mut georef = georef;
    georef.georeferenced = true;
    let g = Grid::from_fn(360, 180, |x, _| if x == 359 { 0u8 } else { 1u8 });
    MemRaster::from_grid(g, georef.with_nodata(Some(255.0)))
}

fn acc_of(
    src: &dyn RasterSource,
    opts: &accumulate::AccumulateOptions,
    tile: Option<usize>,
    budget: u64,
) -> Grid<f64> {
    let dir = tempfile::tempdir().unwrap();
    let mut t = Target::new(dir.path().join("acc.tif"));
    t.tile = tile;
    accumulate::run(src, opts, &t, &cfg(budget)).expect("accumulate");
    let r = orogen::io::open_raster(&t.path, &Default::default()).unwrap();
    let i = r.info();
    read_window::<f64>(r.as_ref(), Window::full(i.width, i.height)).unwrap()
}

#[test]
fn accumulated_areas_are_the_ellipsoids() {
    let src = global_east();
    let opts = accumulate::AccumulateOptions {
        units: accumulate::AreaUnits::Km2,
        ..Default::default()
    };
    let acc = acc_of(&src, &opts, None, 1 << 30);
    // each row: 360 cells of 1°, the zone's area (f32 weights: 1e-6 relative)
    for y in [0usize, 45, 89, 90, 134, 179] {
        let lat0 = 90.0 - y as f64;
        let want = 360.0 * zone_area(lat0 - 1.0, lat0) / 1e6;
        let got = acc.get(359, y);
        assert!(
            (got - want).abs() < 1e-6 * want,
            "row {y}: {got} km² vs {want}"
        );
    }
    // the whole grid: the area of the WGS 84 ellipsoid, 510 065 621.7 km²
    let total: f64 = (0..180).map(|y| acc.get(359, y)).sum();
    // (f32 weights: within 1e-7 relative)
    assert!(
        (total - 510_065_621.7).abs() < 1e-7 * 510_065_621.7,
        "{total} km²"
    );
    // the same across odd tiles
    let tiled = acc_of(&src, &opts, Some(37), 1 << 30);
    assert_eq!(acc.data(), tiled.data());
    // m2 = 1e6 km2; a cell at 60°N holds half the area of one at the equator
    let m2 = acc_of(
        &src,
        &accumulate::AccumulateOptions {
            units: accumulate::AreaUnits::M2,
            ..Default::default()
        },
        None,
        1 << 30,
    );
    let (c60, c0) = (m2.get(0, 29), m2.get(0, 89));
    assert!((c60 / c0 - 0.5).abs() < 0.005, "{c60} / {c0}");
}

#[test]
fn specific_catchment_area_on_square_and_lat_lon_cells() {
    // projected 30 m cells: SCA = cells × 900 m² / 30 m
    let g = Grid::from_fn(7, 5, |x, _| if x == 6 { 0u8 } else { 1u8 });
    let georef = GeoRef::north_up(
        500_000.0,
        4_100_000.0,
        30.0,
        orogen::raster::Crs::projected(32633),
    );
    let src = MemRaster::from_grid(g, georef.with_nodata(Some(255.0)));
    let sca = acc_of(
        &src,
        &accumulate::AccumulateOptions {
            units: accumulate::AreaUnits::Sca,
            ..Default::default()
        },
        None,
        1 << 30,
    );
    for x in 0..7 {
        assert_eq!(sca.get(x, 2), (x + 1) as f64 * 30.0, "column {x}");
    }
    // lat/lon, D∞ on the real crop: SCA × √(cell area) = m² accumulation,
    // in memory and across tiles
    let (z, georef) = filled_crop();
    let dem = mem(&z, &georef);
    let o = |units| accumulate::AccumulateOptions {
        method: accumulate::AccumulateMethod::Dinf,
        units,
        ..Default::default()
    };
    let a = acc_of(&dem, &o(accumulate::AreaUnits::M2), None, 1 << 30);
    let s = acc_of(&dem, &o(accumulate::AreaUnits::Sca), None, 1 << 30);
    let a_tiled = acc_of(&dem, &o(accumulate::AreaUnits::M2), Some(37), 1 << 20);
    let s_tiled = acc_of(&dem, &o(accumulate::AreaUnits::Sca), Some(37), 1 << 20);
    let first = |p: &Grid<f64>, q: &Grid<f64>| {
        p.data()
            .iter()
            .zip(q.data())
            .position(|(u, v)| u.to_bits() != v.to_bits())
    };
    assert_eq!(first(&a, &a_tiled), None, "m2");
    assert_eq!(first(&s, &s_tiled), None, "sca");
    for y in [0usize, 150, 299] {
        let w = georef.cell_area_m2(y as i64).unwrap().sqrt();
        for x in [3usize, 150, 296] {
            if a.get(x, y) >= 0.0 {
                assert!(
                    (s.get(x, y) * w - a.get(x, y)).abs() <= 1e-9 * a.get(x, y),
                    "({x}, {y})"
                );
            }
        }
    }
}

#[test]
fn areas_need_georeferencing() {
    let g = Grid::from_fn(4, 3, |x, _| if x == 3 { 0u8 } else { 1u8 });
    let src = MemRaster::from_grid(g, GeoRef::pixel().with_nodata(Some(255.0)));
    let dir = tempfile::tempdir().unwrap();
    let t = Target::new(dir.path().join("acc.tif"));
    let opts = accumulate::AccumulateOptions {
        units: accumulate::AreaUnits::Km2,
        ..Default::default()
    };
    let e = accumulate::run(&src, &opts, &t, &cfg(1 << 30))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("no georeferencing") && e.contains("--units cells"),
        "{e}"
    );
    assert!(!t.path.exists());
}
