//! Shared helpers of the orometric-synthesis tests: real DEMs (the copies in
//! `tests/data/oro/`), a hand-made profile and the brute-force prominence.

#![allow(dead_code)] // each test binary uses a subset

use orogen::io::{open_raster, OpenOptions};
use orogen::oro::stats::SplitMix64;
use orogen::raster::{read_window, GeoRef, Grid, Window};
use orogen::synth::orometric::*;
use std::path::PathBuf;

/// A real DEM: the copy in `tests/data/oro/` (so `cargo test` needs nothing
/// outside the repository). Its absence fails the test instead of skipping
/// the real-data check; the `Option` only lets callers use `?`.
pub fn shared(name: &str) -> Option<PathBuf> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let local = root.join("tests/data/oro").join(name);
    assert!(
        local.exists(),
        "{} is missing: the real-data checks need the repository's copy",
        local.display()
    );
    Some(local)
}

pub fn load(name: &str) -> Option<(Grid<f32>, GeoRef)> {
    let p = shared(name)?;
    let src = open_raster(&p, &OpenOptions::default()).unwrap();
    let (w, h) = (src.info().width, src.info().height);
    let g = read_window::<f32>(&*src, Window::full(w, h)).unwrap();
    Some((g, src.info().georef.clone()))
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
