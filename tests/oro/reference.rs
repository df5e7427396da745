//! Real data: peaks with prominence ≥ 30 m on 300 x 300 crops of SRTM3
//! S33W071 (Aconcagua) and N46E008 (Bernese Alps, with voids), against
//! akirmse/mountains' list for the whole tiles (an independent tool; its
//! lines inside each crop are in `tests/data/oro/`, beside the crops).
//!
//! Cropping only removes terrain (the crop's outside is sea, as the tile's
//! is): every path of the crop is a path of the tile, so no peak's
//! prominence drops. A reference prominence p (key saddle at s = h − p) is
//! therefore the crop's too exactly when the crop itself holds a path from
//! the peak to strictly higher ground that never goes below s; the test
//! finds those peaks with its own flood fill and requires orogen to give
//! each of them the reference's prominence.

use orogen::io::{open_raster, OpenOptions};
use orogen::oro::{self, EdgeConvention, PeakOptions};
use orogen::raster::{read_window, Grid, Window};
use std::collections::VecDeque;
use std::path::Path;
struct Ref {
    lat: f64,
    lon: f64,
    elev: f64,
    prom: f64,
    saddle: Option<(f64, f64)>,
}

fn load_ref(path: &Path) -> Vec<Ref> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .map(|l| {
            let f: Vec<f64> = l.split(',').map(|x| x.trim().parse().unwrap()).collect();
            Ref {
                lat: f[0],
                lon: f[1],
                elev: f[2],
                saddle: (f[3] != 0.0 || f[4] != 0.0).then_some((f[3], f[4])),
                prom: f[5],
            }
        })
        .collect()
}

#[test]
fn aconcagua_crop_against_akirmse_mountains() {
    compare("srtm3_S33W071", 6929.0, 100);
}

/// The Alps crop has 8,021 void cells, which both tools treat as sea.
#[test]
fn alps_crop_with_voids_against_akirmse_mountains() {
    compare("srtm3_N46E008", 4173.0, 240);
}

/// Whether the crop holds a path from (x, y) to a cell higher than `h`
/// that never goes below `s` (8-connected, valid cells only: voids, NaN
/// or `nodata`, are sea).
fn reaches_higher(dem: &Grid<f32>, nodata: f32, x: usize, y: usize, h: f32, s: f32) -> bool {
    let (w, hh) = (dem.width(), dem.height());
    let mut seen = vec![false; w * hh];
    let mut q = VecDeque::from([(x, y)]);
    seen[y * w + x] = true;
    while let Some((cx, cy)) = q.pop_front() {
        for dy in -1i64..=1 {
            for dx in -1i64..=1 {
                let (nx, ny) = (cx as i64 + dx, cy as i64 + dy);
                if nx < 0 || ny < 0 || nx >= w as i64 || ny >= hh as i64 {
                    continue;
                }
                let (nx, ny) = (nx as usize, ny as usize);
                let v = dem.get(nx, ny);
                if seen[ny * w + nx] || v.is_nan() || v == nodata || v < s {
                    continue;
                }
                if v > h {
                    return true;
                }
                seen[ny * w + nx] = true;
                q.push_back((nx, ny));
            }
        }
    }
    false
}

/// Compare our peaks (prominence ≥ 30, SeaLevel) on the crop of `name` with
/// the reference: the highest is `highest` with its elevation as
/// prominence, and every reference peak whose prominence the crop preserves
/// (at least `min_checked` of them) is found with that prominence.
fn compare(name: &str, highest: f32, min_checked: usize) {
    let d = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/oro");
    let dem_path = d.join(format!("{name}_crop.tif"));
    let ref_path = d.join(format!("{name}_crop_prominence30_mountains.csv"));
    let src = open_raster(&dem_path, &OpenOptions::default()).unwrap();
    let info = src.info().clone();
    let dem = read_window::<f32>(src.as_ref(), Window::full(info.width, info.height)).unwrap();
    let nodata = info.georef.nodata.unwrap() as f32;
    let list = oro::peaks(
        &dem,
        &info.georef,
        &PeakOptions {
            min_prominence: 30.0,
            convention: EdgeConvention::SeaLevel,
            isolation: true,
        },
    )
    .unwrap();
    let refs = load_ref(&ref_path);
    let cell = info.georef.cell_size_units().0;
    let g = &info.georef;
    let ll = |c: u32, r: u32| {
        let (x, y) = g.pixel_to_map(c as f64 + 0.5, r as f64 + 0.5);
        (y, x)
    };
    let ours: Vec<_> = list
        .tree
        .peaks
        .iter()
        .map(|p| (ll(p.col, p.row), p))
        .collect();
    let mut used = vec![false; ours.len()];
    let mut matched_at = vec![None; refs.len()];
    // Pass 1: within 1.5 cells, same elevation. Pass 2 (flat summits, where the
    // tools pick different cells of the plateau): within 10 cells, same
    // elevation, and the reference's own cell lies on a plateau of that height.
    for (pass, tol) in [(1, 1.5), (2, 10.0)] {
        for (k, r) in refs.iter().enumerate() {
            if matched_at[k].is_some() {
                continue;
            }
            if pass == 2 {
                let (c, rr) = g.map_to_pixel(r.lon, r.lat).unwrap();
                let v = dem.get(c.floor() as usize, rr.floor() as usize) as f64;
                if v != r.elev {
                    continue;
                }
            }
            let best = ours
                .iter()
                .enumerate()
                .filter(|(i, ((la, lo), p))| {
                    !used[*i]
                        && (la - r.lat).abs() <= tol * cell
                        && (lo - r.lon).abs() <= tol * cell
                        && p.elevation as f64 == r.elev
                })
                .map(|(i, _)| i)
                .next();
            if let Some(i) = best {
                used[i] = true;
                matched_at[k] = Some(i);
            }
        }
    }
    // The reference peaks the crop preserves: a cell of the summit's height
    // within a cell of the reference position (positions are after that
    // tool's warping), from which the flood at the saddle's level reaches
    // higher ground inside the crop. Islands' highest peaks (no saddle) only
    // where they are the crop's highest.
    let (mut checked, mut diffs, mut missing) = (0, Vec::new(), Vec::new());
    for (k, r) in refs.iter().enumerate() {
        let (c, rr) = g.map_to_pixel(r.lon, r.lat).unwrap();
        let (c, rr) = (c.floor() as i64, rr.floor() as i64);
        let summit = (-1..=1)
            .flat_map(|dy| (-1..=1).map(move |dx| (c + dx, rr + dy)))
            .filter(|&(x, y)| x >= 0 && y >= 0 && x < 300 && y < 300)
            .map(|(x, y)| (x as usize, y as usize))
            .find(|&(x, y)| dem.get(x, y) as f64 == r.elev);
        let Some((x, y)) = summit else { continue };
        let preserved = match r.saddle {
            Some(_) => reaches_higher(&dem, nodata, x, y, r.elev as f32, (r.elev - r.prom) as f32),
            None => r.elev as f32 == highest,
        };
        if !preserved {
            continue;
        }
        checked += 1;
        match matched_at[k] {
            None => missing.push((r.lat, r.lon, r.elev, r.prom)),
            Some(i) if ours[i].1.prominence != r.prom => {
                diffs.push((r.lat, r.lon, r.elev, r.prom, ours[i].1.prominence))
            }
            Some(_) => {}
        }
    }
    eprintln!(
        "{name} crop: reference {} peaks, ours {}, {checked} with the prominence the crop preserves; \
         {} of them missing, {} with another prominence",
        refs.len(),
        ours.len(),
        missing.len(),
        diffs.len()
    );
    assert!(
        checked >= min_checked,
        "only {checked} reference peaks checked"
    );
    assert!(missing.is_empty(), "reference peaks not found: {missing:?}");
    // A difference may only be an equal-height twin pair whose two
    // prominences are swapped (tie-breaking between equal summits).
    for d in &diffs {
        assert!(
            diffs.iter().any(|e| e.2 == d.2 && e.3 == d.4 && e.4 == d.3),
            "prominence differs from the reference, not by a twin swap (lat, lon, elev, ref, ours): {d:?}"
        );
    }
    let top = &list.tree.peaks[0];
    assert_eq!(top.elevation, highest);
    assert_eq!(top.prominence, highest as f64);
}
