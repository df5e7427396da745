//! Shared helpers of the synthesis tests: real DEMs (the copies in
//! `tests/data/oro/`), a hand-made profile, the shipped profiles, the
//! brute-force prominence, the recovery of a tree's peaks on its render (by
//! `orogen::oro::peaks`) and windows of a synthetic source against the whole.

#![allow(dead_code)] // each test binary uses a subset

use orogen::io::{open_raster, OpenOptions};
use orogen::oro::stats::SplitMix64;
use orogen::raster::{read_window, GeoRef, Grid, Window};
use orogen::synth::orometric::*;
use std::path::PathBuf;

/// A real DEM: the copy in `tests/data/oro/` (so `cargo test` needs nothing
/// outside the repository). Its absence fails the test.
pub fn shared(name: &str) -> PathBuf {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let local = root.join("tests/data/oro").join(name);
    assert!(
        local.exists(),
        "{} is missing: the real-data checks need the repository's copy",
        local.display()
    );
    local
}

pub fn load(name: &str) -> (Grid<f32>, GeoRef) {
    let p = shared(name);
    let src = open_raster(&p, &OpenOptions::default()).unwrap();
    let (w, h) = (src.info().width, src.info().height);
    let g = read_window::<f32>(&*src, Window::full(w, h)).unwrap();
    (g, src.info().georef.clone())
}

/// A profile from hand-made peak values (no DEM needed).
pub fn toy_profile() -> SynthProfile {
    let mut r = SplitMix64(99);
    let mut s = PeakSamples::default();
    for _ in 0..400 {
        let u = r.unit();
        let e = 600.0 + 1400.0 * u;
        let p = 30.0 + 500.0 * r.unit().powi(3) * u;
        s.elevation.push(e);
        s.prominence.push(p);
        s.dominance.push(p / e);
        s.isolation_km.push(0.3 + 2.5 * r.unit().powi(2));
        s.isolation_dir.push((r.unit() * 8.0).floor());
        s.saddle_km.push(0.2 + 1.5 * r.unit());
        s.saddle_dir.push((r.unit() * 8.0).floor());
    }
    s.area_km2 = 400.0 / 0.25;
    SynthProfile::from_samples(&[s], 30.0, "toy", vec!["hand".into()]).unwrap()
}

/// Prominence by definition: h − the highest, over strictly higher peaks
/// (ties: lower index is higher), of the lowest saddle on the tree path.
pub fn brute_prominence(t: &SynthTree) -> Vec<f64> {
    let n = t.peaks.len();
    let mut adj = vec![Vec::new(); n];
    for s in &t.saddles {
        adj[s.peaks[0]].push((s.peaks[1], s.elevation));
        adj[s.peaks[1]].push((s.peaks[0], s.elevation));
    }
    let h: Vec<f64> = t.peaks.iter().map(|p| p.elevation).collect();
    (0..n)
        .map(|i| {
            // Path minima from i to every peak (DFS on the tree).
            let mut minv = vec![f64::NAN; n];
            minv[i] = f64::INFINITY;
            let mut stack = vec![i];
            while let Some(a) = stack.pop() {
                for &(b, z) in &adj[a] {
                    if minv[b].is_nan() {
                        minv[b] = minv[a].min(z);
                        stack.push(b);
                    }
                }
            }
            let mut best = f64::NEG_INFINITY;
            for j in 0..n {
                if h[j] > h[i] || (h[j] == h[i] && j < i) {
                    best = best.max(minv[j]);
                }
            }
            if best.is_finite() {
                h[i] - best
            } else {
                h[i]
            }
        })
        .collect()
}

/// A profile shipped in `configs/profiles/`.
pub fn shipped(name: &str) -> SynthProfile {
    SynthProfile::load(
        &PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("configs/profiles")
            .join(name),
    )
    .unwrap()
}

/// The peaks `orogen::oro::peaks` finds on a render of prominence at least
/// `thr` (sea-level edge convention, no isolation): the oracle of the
/// terrain models, which shares no code with the synthesis.
pub fn found_peaks(dem: &Grid<f32>, georef: &GeoRef, thr: f64) -> orogen::oro::DivideTree {
    orogen::oro::peaks(
        dem,
        georef,
        &orogen::oro::PeakOptions {
            min_prominence: thr,
            convention: orogen::oro::EdgeConvention::SeaLevel,
            isolation: false,
        },
    )
    .unwrap()
    .tree
}

/// The owner peak of each saddle of `t` ([`assign::owners`]).
pub fn saddle_owners(t: &SynthTree) -> Vec<usize> {
    let h: Vec<f64> = t.peaks.iter().map(|p| p.elevation).collect();
    let hs: Vec<f64> = t.saddles.iter().map(|s| s.elevation).collect();
    assign::owners(&h, &t.edges(), &hs)
}

/// Per peak, the raster bound of its key saddle's elevation: on a grid the
/// pass is read at cell centres next to the saddle point, up to one cell
/// along the ridge, so at most the ridge gradient there (over a run of at
/// least `min_run` m) × one cell above it. 0 for the peak without a key saddle.
pub fn key_saddle_bounds(t: &SynthTree, own: &[usize], min_run: f64) -> Vec<f64> {
    let mut bound = vec![0.0f64; t.peaks.len()];
    for (e, &o) in own.iter().enumerate() {
        let s = &t.saddles[e];
        let g = s
            .peaks
            .iter()
            .map(|&q| {
                let p = &t.peaks[q];
                (p.elevation - s.elevation) / (p.x - s.x).hypot(p.y - s.y).max(min_run)
            })
            .fold(0.0, f64::max);
        bound[o] = g * t.cell;
    }
    bound
}

/// The tree's peaks clearly above its threshold (by more than twice the
/// terrain noise `noise`, which may move a borderline one across it) found
/// again in `found` within a cell, at their elevation within the noise:
/// (peaks expected, peaks whose prominence is also right within twice the
/// noise and the key-saddle bound `sbound`). `also(i, hit)` is called for
/// each expected peak `i` with the peak found for it, after those checks.
pub fn recovered_peaks(
    t: &SynthTree,
    found: &orogen::oro::DivideTree,
    noise: f64,
    sbound: &[f64],
    mut also: impl FnMut(usize, Option<&orogen::oro::Peak>),
) -> (usize, usize) {
    let prom = t.prominences();
    let (mut want, mut ok) = (0, 0);
    for (i, p) in t.peaks.iter().enumerate() {
        if prom[i] < t.min_prominence + 2.0 * noise + 1.0 {
            continue;
        }
        want += 1;
        let (c, r) = ((p.x / t.cell) as i64, (p.y / t.cell) as i64);
        let hit = found
            .peaks
            .iter()
            .find(|q| (q.col as i64 - c).abs() <= 1 && (q.row as i64 - r).abs() <= 1);
        if let Some(q) = hit {
            let dz = (q.elevation as f64 - p.elevation).abs();
            assert!(dz <= noise + 0.01, "peak {i}: elevation off by {dz} m");
            let dp = (q.prominence - prom[i]).abs();
            if dp <= 2.0 * noise + sbound[i] + 0.01 {
                ok += 1;
            } else {
                println!("peak {i}: prominence {} vs {}", q.prominence, prom[i]);
            }
        } else {
            println!("peak {i} at ({c}, {r}) not recovered");
        }
        also(i, hit);
    }
    (want, ok)
}

/// Every window of side `tile` (one of `tiles`; the last in each row and
/// column clipped) read from `src` equals the same cells of `whole`, bit for
/// bit: a synthetic source is a pure function of the cell.
pub fn assert_windows_equal_whole<T: orogen::raster::Cell>(
    src: &dyn orogen::raster::RasterSource,
    whole: &Grid<T>,
    tiles: &[usize],
    what: &str,
) {
    let (w, h) = (whole.width(), whole.height());
    for &tile in tiles {
        for ty in (0..h).step_by(tile) {
            for tx in (0..w).step_by(tile) {
                let win = Window::new(tx as i64, ty as i64, tile.min(w - tx), tile.min(h - ty));
                let part: Grid<T> = read_window(src, win).unwrap();
                for y in 0..win.h {
                    for x in 0..win.w {
                        assert_eq!(
                            part.get(x, y).to_f64().to_bits(),
                            whole.get(tx + x, ty + y).to_f64().to_bits(),
                            "{what}: tile {tile} at ({}, {})",
                            tx + x,
                            ty + y
                        );
                    }
                }
            }
        }
    }
}

/// Run `cmd`, which must succeed (its stderr in the failure message).
pub fn succeeds(cmd: &mut std::process::Command) {
    let st = cmd.output().unwrap();
    assert!(
        st.status.success(),
        "{cmd:?}: {}",
        String::from_utf8_lossy(&st.stderr)
    );
}
