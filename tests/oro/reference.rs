//! Real data: peaks with prominence ≥ 30 m on SRTM3 S33W071 (Aconcagua)
//! against akirmse/mountains' list in ../shared/reference (independent tool).
//! Runs only if ../shared (beside the repository) is present; prints the comparison figures.

use orogen::io::{open_raster, OpenOptions};
use orogen::oro::{self, EdgeConvention, PeakOptions};
use orogen::raster::{read_window, Window};
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
fn aconcagua_against_akirmse_mountains() {
    compare("srtm3_S33W071", 6929.0, 0);
}

/// The Alps tile has 103,743 void cells, which both tools treat as sea.
#[test]
fn alps_with_voids_against_akirmse_mountains() {
    compare("srtm3_N46E008", 4173.0, 0);
}

/// Compare our peaks (prominence ≥ 30, SeaLevel) on `name` with the reference;
/// `max_unmatched` reference peaks may stay unmatched.
fn compare(name: &str, highest: f32, max_unmatched: usize) {
    let shared = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared");
    let dem_path = shared.join(format!("data/{name}.tif"));
    let ref_path = shared.join(format!("reference/{name}_prominence30_mountains.csv"));
    if !dem_path.exists() || !ref_path.exists() {
        eprintln!("skipped: {} not present", dem_path.display());
        return;
    }
    let src = open_raster(&dem_path, &OpenOptions::default()).unwrap();
    let info = src.info().clone();
    let dem = read_window::<f32>(src.as_ref(), Window::full(info.width, info.height)).unwrap();
    let t0 = std::time::Instant::now();
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
    eprintln!(
        "peaks(): {:.2} s, {} peaks",
        t0.elapsed().as_secs_f64(),
        list.tree.peaks.len()
    );
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
                matched_at[k] = Some((i, pass));
            }
        }
    }
    let mut diffs = Vec::new();
    let (mut matched, mut plateau, mut exact_prom) = (0, 0, 0);
    for (k, r) in refs.iter().enumerate() {
        if let Some((i, pass)) = matched_at[k] {
            matched += 1;
            plateau += (pass == 2) as usize;
            let p = ours[i].1;
            if p.prominence == r.prom {
                exact_prom += 1;
            } else {
                diffs.push((r.lat, r.lon, r.elev, r.prom, p.prominence, r.saddle));
            }
        }
    }
    let missing: Vec<_> = refs
        .iter()
        .enumerate()
        .filter(|(k, _)| matched_at[*k].is_none())
        .map(|(_, r)| r)
        .collect();
    let extra: Vec<_> = ours
        .iter()
        .enumerate()
        .filter(|(i, _)| !used[*i])
        .map(|(_, o)| o)
        .collect();
    eprintln!(
        "reference {} peaks; ours {}; matched {matched} ({plateau} only on the summit plateau, 1.5-10 cells apart); \
         prominence exact {exact_prom}, differs {}; missing {}; extra {}",
        refs.len(),
        ours.len(),
        diffs.len(),
        missing.len(),
        extra.len()
    );
    for d in diffs.iter().take(20) {
        eprintln!(
            "  prominence differs (ref lat, lon, elev, ref prom, our prom, ref saddle): {d:?}"
        );
    }
    for m in missing.iter().take(20) {
        eprintln!(
            "  missing: {} {} elev {} prom {}",
            m.lat, m.lon, m.elev, m.prom
        );
    }
    for ((la, lo), p) in extra.iter().take(20) {
        eprintln!(
            "  extra: {la} {lo} elev {} prom {} on_edge {}",
            p.elevation, p.prominence, p.on_edge
        );
    }
    // Every prominence difference is an equal-height twin pair whose two
    // prominences are swapped (tie-breaking between equal summits).
    for d in &diffs {
        assert!(
            diffs.iter().any(|e| e.2 == d.2 && e.3 == d.4 && e.4 == d.3),
            "prominence difference not explained by a twin swap: {d:?}"
        );
    }
    let top = &list.tree.peaks[0];
    eprintln!(
        "highest: {} m, prominence {}, isolation {:?}",
        top.elevation, top.prominence, top.isolation
    );
    assert_eq!(top.elevation, highest);
    assert_eq!(top.prominence, highest as f64);
    assert!(
        missing.len() <= max_unmatched,
        "{} reference peaks not found",
        missing.len()
    );
    assert!(extra.len() <= max_unmatched, "{} extra peaks", extra.len());
    assert!(diffs.is_empty(), "{} prominence differences", diffs.len());
}
