//! Orometric synthesis (issue 10): profiles, divide-tree synthesis, terrain.
//! Oracles: a brute-force prominence definition on the tree, `orogen peaks`
//! (the `oro` module, which shares no code with the synthesis) run on the
//! synthesised terrain, and the profiles of real DEMs.

use crate::oro_common::*;
use orogen::io::{open_raster, OpenOptions};
use orogen::raster::{read_window, GeoRef, Grid, Window};
use orogen::synth::orometric::*;
use std::path::PathBuf;
use std::process::Command;

#[test]
fn tree_prominences_match_the_definition() {
    let prof = toy_profile();
    for seed in [1, 2, 3] {
        let mut o = TreeOptions::new(200, 150, 50.0, seed);
        o.n_peaks = Some(60);
        let t = synthesize_tree(&prof, &o).unwrap();
        assert_eq!(t.saddles.len() + 1, t.peaks.len());
        let a = t.prominences();
        let b = brute_prominence(&t);
        for (x, y) in a.iter().zip(&b) {
            assert!((x - y).abs() < 1e-9, "{x} vs {y}");
        }
        // Saddles respect 0 ≤ h(K) < min(h(ends)).
        for s in &t.saddles {
            let lo = t.peaks[s.peaks[0]]
                .elevation
                .min(t.peaks[s.peaks[1]].elevation);
            assert!(s.elevation >= 0.0 && s.elevation < lo);
        }
    }
}

#[test]
fn ridges_are_a_spanning_tree_of_the_delaunay_graph() {
    // Four peaks on a square plus the centre: the MST of the Delaunay graph
    // with ρ = 0 is the four spokes (each 70.7 m) and no side (100 m).
    let p = |x: f64, y: f64| SynthPeak {
        x,
        y,
        elevation: 1000.0,
        fixed: false,
    };
    let peaks = vec![
        p(100.0, 100.0),
        p(200.0, 100.0),
        p(100.0, 200.0),
        p(200.0, 200.0),
        p(150.0, 150.0),
    ];
    let e = ridge_tree(&peaks, 0).unwrap();
    assert_eq!(e.len(), 4);
    assert!(e.iter().all(|&(a, b)| a == 4 || b == 4));
}

/// Synthesise on the toy profile and check `orogen peaks` on the terrain.
fn check_preserved(noise: f64) -> (usize, usize) {
    let prof = toy_profile();
    let mut o = TreeOptions::new(320, 280, 50.0, 5);
    o.n_peaks = Some(80);
    let tree = synthesize_tree(&prof, &o).unwrap();
    let topt = TerrainOptions {
        noise_amplitude: Some(noise),
        ..TerrainOptions::default()
    };
    let ter = OroTerrain::new(&tree, &topt).unwrap();
    let dem = ter.render();
    let found = found_peaks(&dem, ter.georef(), tree.min_prominence);
    let own = saddle_owners(&tree);
    let sbound = key_saddle_bounds(&tree, &own, 0.0);
    let (want, ok) = recovered_peaks(&tree, &found, noise, &sbound, |_, _| {});
    (want, ok)
}

#[test]
fn orometry_is_preserved_without_noise() {
    let (want, ok) = check_preserved(0.0);
    println!("recovered {ok} of {want}");
    assert!(want >= 50);
    // Measured: 60 of 64 (seed 5); the rest are buried where two ridges of
    // different sub-trees pass closer than the flank slope cap allows.
    assert!(ok as f64 >= 0.9 * want as f64, "recovered {ok} of {want}");
}

#[test]
fn orometry_is_preserved_with_noise() {
    let (want, ok) = check_preserved(8.0);
    println!("recovered {ok} of {want}");
    assert!(want >= 40);
    assert!(ok as f64 >= 0.9 * want as f64, "recovered {ok} of {want}");
}

#[test]
fn windows_equal_the_whole_render_and_seeds_are_deterministic() {
    let prof = toy_profile();
    let mut o = TreeOptions::new(150, 110, 50.0, 9);
    o.n_peaks = Some(30);
    let t1 = synthesize_tree(&prof, &o).unwrap();
    let t2 = synthesize_tree(&prof, &o).unwrap();
    assert_eq!(t1.to_json(), t2.to_json());
    o.seed = 10;
    assert_ne!(synthesize_tree(&prof, &o).unwrap().to_json(), t1.to_json());
    let ter = OroTerrain::new(&t1, &TerrainOptions::default()).unwrap();
    let all = ter.render();
    for (x, y, w, h) in [
        (0, 0, 150, 110),
        (37, 11, 53, 61),
        (149, 109, 1, 1),
        (5, 90, 140, 20),
    ] {
        let g = read_window::<f32>(&ter, Window::new(x, y, w, h)).unwrap();
        for yy in 0..h {
            for xx in 0..w {
                assert_eq!(
                    g.get(xx, yy).to_bits(),
                    all.get(x as usize + xx, y as usize + yy).to_bits()
                );
            }
        }
    }
    // Round trip of the tree through JSON.
    let back: SynthTree = serde_json::from_str(&t1.to_json()).unwrap();
    assert_eq!(back, t1);
}

#[test]
fn edits_and_bad_inputs_give_clear_errors() {
    let prof = toy_profile();
    let mut o = TreeOptions::new(150, 110, 50.0, 9);
    o.n_peaks = Some(30);
    let t = synthesize_tree(&prof, &o).unwrap();
    // Deleting a peak reconnects its neighbours: still a valid tree.
    let mut d = t.clone();
    d.delete_peak(3).unwrap();
    assert_eq!(d.peaks.len(), t.peaks.len() - 1);
    d.validate().unwrap();
    // Deleting a ridge disconnects the tree.
    let mut cut = t.clone();
    cut.saddles.remove(0);
    let e = cut.validate().unwrap_err().to_string();
    assert!(e.contains("disconnected"), "{e}");
    // A saddle above its lower peak.
    let mut hi = t.clone();
    hi.saddles[0].elevation = 1e6;
    assert!(hi.validate().is_err());
    // Empty profile histogram.
    let mut empty = prof.clone();
    empty.prominence.p.iter_mut().for_each(|v| *v = 0.0);
    let e = synthesize_tree(&empty, &o).unwrap_err().to_string();
    assert!(e.contains("empty"), "{e}");
    // Density map of zeros.
    let mut z = o.clone();
    z.density_map = Some(Grid::new(10, 10, 0.0));
    let e = synthesize_tree(&prof, &z).unwrap_err().to_string();
    assert!(e.contains("zero"), "{e}");
    // Fixed peak outside the domain.
    let mut f = o.clone();
    f.fixed_peaks = vec![SynthPeak {
        x: 1e7,
        y: 10.0,
        elevation: 900.0,
        fixed: false,
    }];
    let e = synthesize_tree(&prof, &f).unwrap_err().to_string();
    assert!(e.contains("outside"), "{e}");
    // Absurd sizes.
    let mut big = o.clone();
    big.width = usize::MAX;
    assert!(synthesize_tree(&prof, &big).is_err());
    // Noise at or above half the threshold.
    let bad = TerrainOptions {
        noise_amplitude: Some(20.0),
        ..TerrainOptions::default()
    };
    assert!(OroTerrain::new(&t, &bad).is_err());
}

#[test]
fn fixed_peaks_stay_where_the_user_put_them() {
    let prof = toy_profile();
    let mut o = TreeOptions::new(200, 200, 50.0, 4);
    o.n_peaks = Some(40);
    o.fixed_peaks = vec![SynthPeak {
        x: 5025.0,
        y: 5025.0,
        elevation: 2500.0,
        fixed: false,
    }];
    let t = synthesize_tree(&prof, &o).unwrap();
    let p = &t.peaks[0];
    assert!(p.fixed && p.x == 5025.0 && p.y == 5025.0 && p.elevation == 2500.0);
    // The highest peak: its prominence is its elevation.
    assert_eq!(t.prominences()[0], 2500.0);
}

#[test]
fn profile_edits_and_round_trip() {
    let prof = toy_profile();
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("p.json");
    prof.save(&p).unwrap();
    assert_eq!(SynthProfile::load(&p).unwrap(), prof);
    let mut x2 = prof.clone();
    x2.scale_prominence(2.0).unwrap();
    for u in [0.1, 0.5, 0.9] {
        let (a, b) = (prof.prominence.quantile(u), x2.prominence.quantile(u));
        assert!((b - 2.0 * a).abs() < 1e-9 * b);
    }
    std::fs::write(&p, "{\"format\": 1}").unwrap();
    assert!(SynthProfile::load(&p).is_err());
}

#[test]
fn cli_profile_divide_tree_from_tree() {
    let exe = env!("CARGO_BIN_EXE_orogen");
    let dir = tempfile::tempdir().unwrap();
    let prof = dir.path().join("toy.json");
    toy_profile().save(&prof).unwrap();
    let tree = dir.path().join("tree.json");
    let gj = dir.path().join("tree.geojson");
    succeeds(
        Command::new(exe)
            .args(["synth", "divide-tree", "--profile"])
            .arg(&prof)
            .args(["--size", "200x160", "--cell", "50", "--peaks", "40", "-o"])
            .arg(&tree)
            .arg("--geojson")
            .arg(&gj),
    );
    let t = SynthTree::load(&tree).unwrap();
    assert_eq!(t.peaks.len(), 40);
    assert!(std::fs::read_to_string(&gj).unwrap().contains("\"ridge\""));
    let tif = dir.path().join("t.tif");
    succeeds(
        Command::new(exe)
            .args(["synth", "from-tree"])
            .arg(&tree)
            .arg("-o")
            .arg(&tif)
            .args(["--tile", "64", "-q", "--terrain", "tents"]),
    );
    // The file holds the terrain, cell for cell.
    let src = open_raster(&tif, &OpenOptions::default()).unwrap();
    let got = read_window::<f32>(&*src, Window::full(200, 160)).unwrap();
    let want = OroTerrain::new(&t, &TerrainOptions::default())
        .unwrap()
        .render();
    assert_eq!(got.data(), want.data());
    // An edit that disconnects the tree is refused with a sentence.
    let mut cut = t.clone();
    cut.saddles.pop();
    std::fs::write(&tree, serde_json::to_string(&cut).unwrap()).unwrap();
    let st = Command::new(exe)
        .args(["synth", "from-tree"])
        .arg(&tree)
        .arg("-o")
        .arg(&tif)
        .output()
        .unwrap();
    assert!(!st.status.success());
    assert!(String::from_utf8_lossy(&st.stderr).contains("disconnected"));
    // The one-step form and a profile from a DEM.
    succeeds(
        Command::new(exe)
            .args(["synth", "orometric", "--profile"])
            .arg(&prof)
            .args(["--size", "120", "--cell", "50", "-q", "-o"])
            .arg(dir.path().join("o.tif")),
    );
    let dem = dir.path().join("o.tif");
    succeeds(
        Command::new(exe)
            .args(["synth", "profile"])
            .arg(&dem)
            .args(["--min-prominence", "20", "-o"])
            .arg(dir.path().join("again.json")),
    );
    SynthProfile::load(&dir.path().join("again.json")).unwrap();
}

/// Isolation of the tree's own peaks: distance to the nearest strictly
/// higher peak (brute force; the highest: none).
fn tree_isolation_km(t: &SynthTree) -> Vec<f64> {
    let mut out = Vec::new();
    for p in &t.peaks {
        let d = t
            .peaks
            .iter()
            .filter(|q| q.elevation > p.elevation)
            .map(|q| (q.x - p.x).hypot(q.y - p.y))
            .fold(f64::INFINITY, f64::min);
        if d.is_finite() {
            out.push(d / 1000.0);
        }
    }
    out
}

/// Tree and rendered-terrain errors of one profile and seed: [isolation,
/// prominence, dominance] total-variation distances to the profile. The
/// tree's isolation is its nearest-higher-peak distance (no stretch, so it is
/// only printed); the terrain is the default model (TIN), measured by
/// `oro::peaks` through `PeakSamples::of_dem`. `render` false: tree only.
/// The domain is `scale` times the DEM's side (same cell).
fn split_errors(
    g: &Grid<f32>,
    geo: &GeoRef,
    prof: &SynthProfile,
    seed: u64,
    refine: bool,
    render: bool,
    scale: usize,
) -> ([f64; 3], Option<[f64; 3]>) {
    let (w, h) = (g.width() * scale, g.height() * scale);
    let (sx, sy) = geo.cell_size_m(g.height() as i64 / 2);
    let cell = (sx * sy).sqrt();
    let mut o = TreeOptions::new(w, h, cell, seed);
    o.refine = refine;
    let t = synthesize_tree(prof, &o).unwrap();
    let pr = t.prominences();
    // Every non-root peak keeps the threshold.
    let n_below = pr
        .iter()
        .filter(|&&p| p < prof.min_prominence * (1.0 - 1e-9))
        .count();
    assert_eq!(n_below, 0, "seed {seed}: peaks below the threshold");
    let dom: Vec<f64> = pr
        .iter()
        .zip(&t.peaks)
        .map(|(p, q)| p / q.elevation)
        .collect();
    let tree = [
        prof.isolation_km.error_against(&tree_isolation_km(&t)),
        prof.prominence.error_against(&pr),
        prof.dominance.error_against(&dom),
    ];
    if !render {
        return (tree, None);
    }
    let ter = build_terrain(&t, &TerrainOptions::default()).unwrap();
    let dem = read_window::<f32>(&*ter, Window::full(w, h)).unwrap();
    let s = PeakSamples::of_dem(&dem, &ter.info().georef, prof.min_prominence).unwrap();
    let e = prof.errors(&s);
    println!(
        "  seed {seed}: {} tree peaks, {} found on the terrain",
        t.peaks.len(),
        s.elevation.len()
    );
    (
        tree,
        Some([e["isolation_km"], e["prominence"], e["dominance"]]),
    )
}

/// The profile of a real DEM of `tests/data/oro`.
fn real_profile(name: &str, thr: f64) -> (Grid<f32>, GeoRef, SynthProfile) {
    let (g, geo) = load(name);
    let prof = SynthProfile::from_dem(&g, &geo, thr, name, name).unwrap();
    (g, geo, prof)
}

const ALPS: (&str, f64) = ("terraindescriptors_alps_montblanc.tif", 30.0);
const DALLAS: (&str, f64) = ("pysheds_dem.tif", 5.0);
/// Seeds of the distribution tests (all of those measured, none left out).
const SEEDS: [u64; 6] = [1, 2, 3, 4, 5, 6];

/// Terrain errors over [`SEEDS`]: (worst, mean) per [isolation,
/// prominence, dominance].
fn terrain_errors(name: &str, thr: f64) -> ([f64; 3], [f64; 3]) {
    terrain_errors_scaled(name, thr, 1)
}

fn terrain_errors_scaled(name: &str, thr: f64, scale: usize) -> ([f64; 3], [f64; 3]) {
    let (g, geo, prof) = real_profile(name, thr);
    let (mut worst, mut mean) = ([0.0f64; 3], [0.0f64; 3]);
    for seed in SEEDS {
        let (tree, ter) = split_errors(&g, &geo, &prof, seed, true, true, scale);
        let ter = ter.unwrap();
        println!("{name} seed {seed}: tree {tree:.4?} terrain {ter:.4?}");
        for k in 0..3 {
            worst[k] = worst[k].max(ter[k]);
            mean[k] += ter[k] / SEEDS.len() as f64;
        }
    }
    println!("{name}: worst {worst:.4?} mean {mean:.4?}");
    (worst, mean)
}

#[test]
fn distributions_match_the_alps_profile() {
    // The paper's figures (isolation ≤ 8 %, prominence and dominance
    // ≤ 3 %): prominence and dominance on every seed (worst = the largest
    // of seeds 1-6), isolation on the mean and within 8.5 % on every seed.
    // Measured (session 8: the tree keeps peaks and saddles clear of ridges,
    // `clearance`, and the raster blocks steps across rivers beside crests):
    // isolation 4.4-8.1 %, 7.1 % mean; prominence 0.8-1.4 %; dominance
    // 0.1-0.6 % (session 7: isolation 5.1-8.3 %; session 6, before the
    // render was exact: isolation 5.2-7.9 %, prominence 1.4-2.6 %, dominance
    // 0.6-1.5 %; docs/design/orometric-synthesis.md#ridge-clearance-clearancers). The Alps' isolation floor for ~578
    // peaks is 3.7 % (the measure's sampling noise); the rest is the
    // isolation model's bias.
    distributions_within(ALPS, [0.085, 0.03, 0.03], [0.075, 0.025, 0.02]);
}

#[test]
fn distributions_match_the_low_relief_profile() {
    // Measured with the ridge contrast 5 (session 5, seeds 1-6,
    // docs/design/orometric-synthesis.md#ridges): isolation 3.4-7.7 %, 5.3 % mean; prominence
    // 0.1-0.5 %; dominance 0.9-3.0 %, 1.8 % mean (the paper: isolation ≤ 8 %,
    // prominence and dominance ≤ 3 %). Session 8 (the tree keeps peaks and
    // saddles clear of ridges, `clearance`): isolation 5.1-8.9 %, 7.3 %
    // mean; prominence ≤ 0.6 %; dominance ≤ 1.2 %.
    //
    // Isolation on ~168 peaks is at the noise floor of the measure: 168
    // values drawn from the profile's own histogram are 6.3 % off it on
    // average, over 8 % in about 20 % of draws and over 10.1 % in 5 %
    // (docs/design/orometric-synthesis.md#ridge-clearance-clearancers, 2000 draws). So at the DEM's size the paper's
    // 8 % holds on the mean, and each seed is held to 10.5 %; the per-seed
    // 8 % is checked on a domain twice the side
    // (`low_relief_isolation_holds_per_seed_on_a_larger_domain`).
    distributions_within(DALLAS, [0.105, 0.01, 0.03], [0.08, 0.006, 0.021]);
}

/// Each of the isolation, prominence and dominance errors of the terrains
/// of profile `(name, thr)` ([`terrain_errors`]) at most `worst_max` on
/// every seed and `mean_max` on the mean .
fn distributions_within((name, thr): (&str, f64), worst_max: [f64; 3], mean_max: [f64; 3]) {
    let (worst, mean) = terrain_errors(name, thr);
    for (k, what) in ["isolation", "prominence", "dominance"].iter().enumerate() {
        assert!(
            worst[k] <= worst_max[k] && mean[k] <= mean_max[k],
            "{name}: {what} {mean:?} {worst:?}"
        );
    }
}

/// The low-relief profile on a domain twice the DEM's side (~670 peaks,
/// where drawing from the profile itself is 3 % off on average and over 8 %
/// in none of 2000 draws): the paper's figures on every seed. Measured
/// (session 8): isolation 3.4-7.5 %, 5.2 % mean; prominence ≤ 0.3 %;
/// dominance ≤ 0.4 %.
#[test]
fn low_relief_isolation_holds_per_seed_on_a_larger_domain() {
    per_seed_on_a_larger_domain(DALLAS, 0.065, 0.01);
}

/// On a domain twice the DEM's side: isolation ≤ 8 % on every seed and
/// ≤ `mean_iso` on the mean; prominence and dominance ≤ `prom_dom` on
/// every seed.
fn per_seed_on_a_larger_domain((name, thr): (&str, f64), mean_iso: f64, prom_dom: f64) {
    let (worst, mean) = terrain_errors_scaled(name, thr, 2);
    assert!(
        worst[0] <= 0.08 && mean[0] <= mean_iso,
        "{name}: isolation {mean:?} {worst:?}"
    );
    assert!(
        worst[1] <= prom_dom && worst[2] <= prom_dom,
        "{name}: {worst:?}"
    );
}

/// The Alps profile on a domain twice the DEM's side (~2300 peaks, where
/// drawing from the profile itself is 1.8 % off on average): the paper's
/// figures on every seed. At the DEM's size the measure's sampling noise
/// (3.7 % mean, 6.0 % p95 for 578 peaks) on top of the isolation model's
/// bias puts one seed of six at 8.1 %. Measured (session 8): isolation
/// 5.9-6.8 %, 6.2 % mean; prominence ≤ 1.3 %; dominance ≤ 0.5 %.
#[test]
fn alps_isolation_holds_per_seed_on_a_larger_domain() {
    per_seed_on_a_larger_domain(ALPS, 0.075, 0.03);
}

/// The local search on the saddle heights never leaves the tree's
/// prominence + dominance distance worse than the assignment alone, and
/// brings the Alps tree near the paper's figures before rendering
/// (measured prominence 1.6–3.2 %, dominance 0.4–2.4 %, seeds 1–3).
#[test]
fn saddle_refinement_lowers_the_tree_errors() {
    for (name, thr) in [ALPS, DALLAS] {
        let (g, geo, prof) = real_profile(name, thr);
        for seed in [1, 2, 3] {
            let (a, _) = split_errors(&g, &geo, &prof, seed, false, false, 1);
            let (b, _) = split_errors(&g, &geo, &prof, seed, true, false, 1);
            println!("{name} seed {seed}: assignment {a:.3?} refined {b:.3?}");
            assert!(b[1] + b[2] <= a[1] + a[2] + 1e-12, "{a:?} {b:?}");
            if name == ALPS.0 {
                assert!(b[1] <= 0.04 && b[2] <= 0.03, "{b:?}");
            }
        }
    }
}

/// The two bases of the ridge weights: the contrast rule (default 5)
/// changes the ridges of the low-relief profile (Dallas, 165-298 m) and not
/// Mont Blanc's (876-4810 m, contrast 5.5); the base fraction (default 0.72
/// of the lowest peak) changes Mont Blanc's and not Dallas's (its contrast
/// base is higher). Each lowers the tree error it was made for, at seed 3:
/// Dallas dominance (measured 0.6 % vs 3.0 % with the paper's weights),
/// Mont Blanc prominence (measured 1.8 % vs 3.2 %). Bad values are refused.
#[test]
fn ridge_bases_change_the_trees_they_were_made_for() {
    for (name, thr) in [ALPS, DALLAS] {
        let (g, geo, prof) = real_profile(name, thr);
        let (w, h) = (g.width(), g.height());
        let (sx, sy) = geo.cell_size_m(g.height() as i64 / 2);
        let mut o = TreeOptions::new(w, h, (sx * sy).sqrt(), 3);
        let def = synthesize_tree(&prof, &o).unwrap();
        o.ridge_base = 0.0;
        let contrast_only = synthesize_tree(&prof, &o).unwrap();
        o.ridge_contrast = 1.0;
        let paper = synthesize_tree(&prof, &o).unwrap();
        let errs = |t: &SynthTree| {
            let p = t.prominences();
            let d: Vec<f64> = p
                .iter()
                .zip(&t.peaks)
                .map(|(p, q)| p / q.elevation)
                .collect();
            (
                prof.prominence.error_against(&p),
                prof.dominance.error_against(&d),
            )
        };
        if name == ALPS.0 {
            assert_eq!(contrast_only.to_json(), paper.to_json());
            assert_ne!(def.edges(), paper.edges());
            let (a, b) = (errs(&def).0, errs(&paper).0);
            assert!(a <= 0.02 && b >= 1.5 * a, "prominence {a} vs {b}");
        } else {
            assert_eq!(def.to_json(), contrast_only.to_json());
            assert_ne!(def.edges(), paper.edges());
            let (a, b) = (errs(&def).1, errs(&paper).1);
            assert!(a <= 0.01 && b >= 0.02, "dominance {a} vs {b}");
        }
        let mut bad = TreeOptions::new(w, h, (sx * sy).sqrt(), 3);
        bad.ridge_contrast = 0.5;
        let e = synthesize_tree(&prof, &bad).unwrap_err().to_string();
        assert!(e.contains("ridge_contrast"), "{e}");
        bad.ridge_contrast = 5.0;
        bad.ridge_base = 1.0;
        let e = synthesize_tree(&prof, &bad).unwrap_err().to_string();
        assert!(e.contains("ridge_base"), "{e}");
    }
}

/// The tree the CLI wrote equals the library's: peak positions and
/// elevations, saddle elevations.
fn assert_same_tree(got: &SynthTree, want: &SynthTree, what: &str) {
    assert_eq!(got.peaks.len(), want.peaks.len(), "{what}");
    for (a, b) in got.peaks.iter().zip(&want.peaks) {
        assert_eq!((a.x, a.y, a.elevation), (b.x, b.y, b.elevation), "{what}");
    }
    for (a, b) in got.saddles.iter().zip(&want.saddles) {
        assert_eq!(a.elevation, b.elevation, "{what}");
    }
}

/// `--ridge-contrast` and `--no-refine` reach the library: the CLI trees equal
/// `synthesize_tree` with the same options, and a contrast below 1 is refused.
#[test]
fn cli_ridge_contrast_and_no_refine_reach_the_library() {
    let exe = env!("CARGO_BIN_EXE_orogen");
    let dir = tempfile::tempdir().unwrap();
    let prof_path =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("configs/profiles/lowrelief_dallas.json");
    let prof = SynthProfile::load(&prof_path).unwrap();
    let run = |extra: &[&str], name: &str| {
        let out = dir.path().join(name);
        let st = Command::new(exe)
            .args(["synth", "divide-tree", "--profile"])
            .arg(&prof_path)
            .args(["--size", "300x300", "--cell", "90", "--seed", "2", "-o"])
            .arg(&out)
            .args(extra)
            .output()
            .unwrap();
        (st, out)
    };
    let mut seen = Vec::new();
    for (extra, contrast, refine) in [
        (vec![], tree_synth::DEFAULT_RIDGE_CONTRAST, true),
        (vec!["--ridge-contrast", "1"], 1.0, true),
        (
            vec!["--no-refine"],
            tree_synth::DEFAULT_RIDGE_CONTRAST,
            false,
        ),
    ] {
        let (st, out) = run(&extra, "t.json");
        assert!(
            st.status.success(),
            "{}",
            String::from_utf8_lossy(&st.stderr)
        );
        let mut o = TreeOptions::new(300, 300, 90.0, 2);
        o.ridge_contrast = contrast;
        o.refine = refine;
        let want = synthesize_tree(&prof, &o).unwrap();
        assert_same_tree(
            &SynthTree::load(&out).unwrap(),
            &want,
            &format!("{extra:?}"),
        );
        seen.push(std::fs::read(&out).unwrap());
    }
    // Each option changes the tree (else this test could not fail).
    assert_ne!(seen[0], seen[1], "--ridge-contrast 1 gave the default tree");
    assert_ne!(seen[0], seen[2], "--no-refine gave the default tree");
    let (st, _) = run(&["--ridge-contrast", "0.5"], "bad.json");
    assert!(!st.status.success());
    assert!(String::from_utf8_lossy(&st.stderr).contains("contrast"));
}

/// `--ridge-base` and `--type-blend` reach the library: the CLI trees equal
/// `synthesize_tree` with the same options, each differs from the default
/// (Mont Blanc: the base changes its trees, not Dallas's), and out-of-range
/// values are refused with the option's name.
#[test]
fn cli_ridge_base_and_type_blend_reach_the_library() {
    let exe = env!("CARGO_BIN_EXE_orogen");
    let dir = tempfile::tempdir().unwrap();
    let cfg = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("configs/profiles");
    let alps_path = cfg.join("alps_montblanc.json");
    let dallas_path = cfg.join("lowrelief_dallas.json");
    let alps = SynthProfile::load(&alps_path).unwrap();
    let dallas = SynthProfile::load(&dallas_path).unwrap();
    let ct = dir.path().join("ct.asc");
    std::fs::write(
        &ct,
        "ncols 2\nnrows 1\nxllcorner 0\nyllcorner 0\ncellsize 1\nNODATA_value -9999\n1 2\n",
    )
    .unwrap();
    let run = |extra: &[&str], typed: bool, name: &str| {
        let out = dir.path().join(name);
        let mut c = Command::new(exe);
        c.args(["synth", "divide-tree", "--profile"])
            .arg(&alps_path)
            .args(["--size", "300x150", "--cell", "90", "--seed", "2", "-o"])
            .arg(&out)
            .args(extra);
        if typed {
            c.arg("--type-map")
                .arg(&ct)
                .arg("--type-profile")
                .arg(format!("2={}", dallas_path.display()));
        }
        (c.output().unwrap(), out)
    };
    let mut seen = Vec::new();
    for (extra, typed, base, blend) in [
        (vec![], false, tree_synth::DEFAULT_RIDGE_BASE, 0.0),
        (vec!["--ridge-base", "0"], false, 0.0, 0.0),
        (vec![], true, tree_synth::DEFAULT_RIDGE_BASE, 0.0),
        (
            vec!["--type-blend", "6000"],
            true,
            tree_synth::DEFAULT_RIDGE_BASE,
            6000.0,
        ),
    ] {
        let (st, out) = run(&extra, typed, "t.json");
        assert!(
            st.status.success(),
            "{}",
            String::from_utf8_lossy(&st.stderr)
        );
        let mut o = TreeOptions::new(300, 150, 90.0, 2);
        o.ridge_base = base;
        o.type_blend_m = blend;
        if typed {
            let labels = Grid::from_vec(2, 1, vec![1.0, 2.0]).unwrap();
            o.type_map = Some(TypeMap::new(labels, vec![(2, dallas.clone())]).unwrap());
        }
        let want = synthesize_tree(&alps, &o).unwrap();
        assert_same_tree(
            &SynthTree::load(&out).unwrap(),
            &want,
            &format!("{extra:?}"),
        );
        seen.push(std::fs::read(&out).unwrap());
    }
    assert_ne!(seen[0], seen[1], "--ridge-base 0 gave the default tree");
    assert_ne!(seen[2], seen[3], "--type-blend 6000 gave the sharp tree");
    let (st, _) = run(&["--ridge-base", "1"], false, "bad.json");
    assert!(!st.status.success());
    assert!(String::from_utf8_lossy(&st.stderr).contains("ridge_base"));
    let (st, _) = run(&["--type-blend=-5"], true, "bad.json");
    assert!(!st.status.success());
    assert!(String::from_utf8_lossy(&st.stderr).contains("type_blend_m"));
}
