//! `orogen compare`: distances of a terrain with itself, with shifted and
//! scaled copies (closed-form expectations), the CLI's three outputs, and
//! bad input.

use orogen::compare::{self, CompareOptions, Terrain, SLOPE_BINS};
use orogen::io::{open_raster, OpenOptions};
use std::path::{Path, PathBuf};
use std::process::Command;

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

fn load(name: &str) -> Terrain {
    let src = open_raster(&data(name), &OpenOptions::default()).unwrap();
    compare::load_terrain(src.as_ref(), name, 1 << 30).unwrap()
}

fn opts() -> CompareOptions {
    CompareOptions {
        channel_area_m2: 0.2e6,
        ..Default::default()
    }
}

fn transformed(t: &Terrain, f: impl Fn(f32) -> f32) -> Terrain {
    Terrain {
        name: format!("{} transformed", t.name),
        dem: t.dem.map(f),
        georef: t.georef.clone(),
    }
}

#[test]
fn a_terrain_compared_with_itself_is_at_distance_zero() {
    let a = load("bigtujunga_crop.tif");
    let c = compare::compare(&a, &a.clone(), &opts()).unwrap();
    assert!(c.a.oro.is_some(), "{:?}", c.a.oro_note);
    assert!(c.a.pits.count > 0 && c.a.drainage.links > 0);
    for (k, v) in &c.distances {
        assert_eq!(*v, 0.0, "{k} = {v}");
    }
    assert_eq!(c.distances.len(), 22);
}

#[test]
fn vertical_offset_keeps_hypsometry_slopes_pits_and_prominence() {
    let a = load("bigtujunga_crop.tif");
    // Integer heights + 1000 are exact in f32.
    let b = transformed(&a, |z| z + 1000.0);
    let c = compare::compare(&a, &b, &opts()).unwrap();
    let d = &c.distances;
    for k in [
        "hypsometric_curve_l1",
        "hypsometric_integral_abs",
        "slope_emd_deg",
        "profile_curvature_emd_per_m",
        "geomorphon_total_variation",
        "pits_per_km2_rel",
        "pit_volume_per_km2_rel",
        "drainage_density_rel",
        "oro_prominence_m_emd",
        "oro_elevation_norm_emd",
        "oro_isolation_km_emd",
        "peak_density_rel",
    ] {
        assert_eq!(d[k], 0.0, "{k}");
    }
    assert_eq!(c.b.z_min, c.a.z_min + 1000.0);
    // Dominance (prominence / elevation) does change.
    assert!(d["oro_dominance_emd"] > 0.0);
}

#[test]
fn doubled_heights_follow_the_tan_law() {
    let a = load("bigtujunga_crop.tif");
    let b = transformed(&a, |z| 2.0 * z);
    let c = compare::compare(&a, &b, &opts()).unwrap();
    // Horn's gradient is linear in z: tan(slope_b) = 2 tan(slope_a), cell by cell.
    assert_eq!(c.a.slope_deg.len(), c.b.slope_deg.len());
    let mapped: Vec<f32> =
        c.a.slope_deg
            .iter()
            .map(|&s| (2.0 * (s as f64).to_radians().tan()).atan().to_degrees() as f32)
            .collect();
    for (m, s) in mapped.iter().zip(&c.b.slope_deg) {
        assert!((m - s).abs() < 1e-3, "{m} vs {s}");
    }
    // The histogram of B is A's slopes mapped through the law (brute-force
    // binning here; cells within 1e-3° of a bin edge may differ by one bin).
    let mut want = vec![0.0; SLOPE_BINS];
    for &m in &mapped {
        want[(m.floor() as usize).min(SLOPE_BINS - 1)] += 1.0 / mapped.len() as f64;
    }
    let l1: f64 = want
        .iter()
        .zip(&c.slope.b)
        .map(|(x, y)| (x - y).abs())
        .sum();
    assert!(l1 < 0.01, "L1 {l1}");
    // Slopes got steeper, so the EMD is at least the mean increase's lower
    // bound |mean_b − mean_a| (Kantorovich–Rubinstein with f(x) = x), less
    // half a bin for the binning.
    let mean = |v: &[f32]| v.iter().map(|&x| x as f64).sum::<f64>() / v.len() as f64;
    let shift = mean(&c.b.slope_deg) - mean(&c.a.slope_deg);
    assert!(shift > 5.0);
    assert!(c.distances["slope_emd_deg"] >= shift - 0.5);
    // Relative heights, pits' count and the drainage pattern do not change.
    assert_eq!(c.distances["hypsometric_curve_l1"], 0.0);
    assert_eq!(c.distances["pits_per_km2_rel"], 0.0);
    assert_eq!(c.b.pits.volume_m3, 2.0 * c.a.pits.volume_m3);
    assert_eq!(c.distances["drainage_density_rel"], 0.0);
}

#[test]
fn emd_and_total_variation_of_hand_made_histograms() {
    // ∫ |F − G|: all the mass moved from 0 to 3 costs 3; halves moved from
    // {0, 1} to {2, 3} cost 2 each way (F − G = 0.5, 1, 0.5 on the three
    // unit gaps); unequal gaps count their width.
    let x = [0.0, 1.0, 2.0, 3.0];
    assert_eq!(
        compare::emd::emd_1d(&x, &[1.0, 0.0, 0.0, 0.0], &[0.0, 0.0, 0.0, 1.0]),
        3.0
    );
    assert_eq!(
        compare::emd::emd_1d(&x, &[1.0, 1.0, 0.0, 0.0], &[0.0, 0.0, 3.0, 3.0]),
        2.0
    );
    assert_eq!(
        compare::emd::emd_1d(&[0.0, 1.0, 10.0], &[1.0, 0.0, 0.0], &[0.0, 0.0, 2.0]),
        10.0
    );
    // p = (0.2, 0.3, 0.5), q = (0.5, 0.3, 0.2) on 0, 2, 3:
    // |F − G| = 0.3 over [0, 2], 0.3 over [2, 3]: 0.9.
    let d = compare::emd::emd_1d(&[0.0, 2.0, 3.0], &[0.2, 0.3, 0.5], &[0.5, 0.3, 0.2]);
    assert!((d - 0.9).abs() < 1e-12, "{d}");
    assert_eq!(compare::emd::total_variation(&[1.0, 0.0], &[0.0, 1.0]), 1.0);
    let tv = compare::emd::total_variation(&[0.5, 0.25, 0.25], &[0.25, 0.25, 0.5]);
    assert!((tv - 0.25).abs() < 1e-12, "{tv}");
}

/// Hypsometry and slope distances of a terrain and a reshaped copy against
/// the definitions computed here: the curve (fraction of cells with
/// relative height ≥ k/100, k = 0..=100), its integral (the mean relative
/// height), and the slope EMD as ∫ |CDF_a − CDF_b| over 1° bins.
#[test]
fn distances_match_their_definitions_computed_independently() {
    let a = load("bigtujunga_crop.tif");
    // Heights squared (scaled): relative heights and slopes both change.
    let b = transformed(&a, |z| z * z / 1000.0);
    let c = compare::compare(&a, &b, &opts()).unwrap();
    let rel = |t: &Terrain| -> Vec<f64> {
        let v: Vec<f64> = t
            .dem
            .data()
            .iter()
            .filter(|v| v.is_finite())
            .map(|&v| v as f64)
            .collect();
        let (lo, hi) = v
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
                (a.min(x), b.max(x))
            });
        v.iter().map(|x| (x - lo) / (hi - lo)).collect()
    };
    let (ra, rb) = (rel(&a), rel(&b));
    let curve = |r: &[f64]| -> Vec<f64> {
        (0..=100)
            .map(|k| {
                r.iter().filter(|&&x| x >= k as f64 / 100.0 - 1e-12).count() as f64 / r.len() as f64
            })
            .collect()
    };
    let (ca, cb) = (curve(&ra), curve(&rb));
    let l1 = ca.iter().zip(&cb).map(|(x, y)| (x - y).abs()).sum::<f64>() / 101.0;
    let d = &c.distances;
    assert!(l1 > 0.05, "the reshaping changes the curve ({l1})");
    assert!(
        (d["hypsometric_curve_l1"] - l1).abs() < 1e-9,
        "{} vs {l1}",
        d["hypsometric_curve_l1"]
    );
    let mean = |r: &[f64]| r.iter().sum::<f64>() / r.len() as f64;
    let hi = (mean(&ra) - mean(&rb)).abs();
    assert!(
        (d["hypsometric_integral_abs"] - hi).abs() < 1e-9,
        "{} vs {hi}",
        d["hypsometric_integral_abs"]
    );
    // Slope EMD from the slopes themselves.
    let hist = |s: &[f32]| {
        let mut h = vec![0.0; 90];
        for &v in s {
            h[(v.floor() as usize).min(89)] += 1.0 / s.len() as f64;
        }
        h
    };
    let (ha, hb) = (hist(&c.a.slope_deg), hist(&c.b.slope_deg));
    let (mut fa, mut fb, mut emd) = (0.0, 0.0, 0.0);
    for i in 0..89 {
        fa += ha[i];
        fb += hb[i];
        emd += (fa - fb).abs();
    }
    assert!(emd > 1.0, "the reshaping changes the slopes ({emd})");
    assert!(
        (d["slope_emd_deg"] - emd).abs() < 1e-9,
        "{} vs {emd}",
        d["slope_emd_deg"]
    );
}

fn orogen() -> Command {
    Command::new(env!("CARGO_BIN_EXE_orogen"))
}

#[test]
fn cli_writes_json_html_and_charts() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cmp");
    let r = orogen()
        .arg("compare")
        .arg(data("bigtujunga_crop.tif"))
        .arg(data("whitebox_DEM.tif"))
        .arg("-o")
        .arg(&out)
        .args(["--channel-area", "0.5", "--quiet", "--radius", "1500m"])
        .output()
        .unwrap();
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("compare.json")).unwrap()).unwrap();
    assert_eq!(j["format"], "orogen-compare-1");
    assert_eq!(j["radius_m"], 1500.0);
    assert_eq!(j["a"]["drainage"]["channel_area_m2"], 0.5e6);
    let d = j["distances"].as_object().unwrap();
    assert!(d["slope_emd_deg"].as_f64().unwrap() > 1.0);
    let html = std::fs::read_to_string(out.join("compare.html")).unwrap();
    assert!(html.contains("whitebox_DEM.tif") && html.contains("slope_emd_deg"));
    // Two thumbnails + 15 charts, each inlined too.
    assert!(html.matches("data:image/png;base64,").count() >= 17);
    for f in [
        "a.png",
        "b.png",
        "slope.png",
        "hypsometry.png",
        "oro_prominence_m.png",
    ] {
        let bytes = std::fs::read(out.join(f)).unwrap();
        assert_eq!(&bytes[1..4], b"PNG", "{f}");
    }
}

#[test]
fn bad_input_is_an_error_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let junk = dir.path().join("junk.tif");
    std::fs::write(&junk, b"II*\0garbage that is no TIFF").unwrap();
    let nodata = dir.path().join("empty.asc");
    std::fs::write(
        &nodata,
        "ncols 3\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 10\nNODATA_value -9999\n-9999 -9999 -9999\n-9999 -9999 -9999\n",
    )
    .unwrap();
    let good = data("whitebox_DEM.tif");
    let cases: Vec<(Vec<String>, &str)> = vec![
        (
            vec![junk.display().to_string(), good.display().to_string()],
            "junk.tif",
        ),
        (
            vec![
                dir.path().join("missing.tif").display().to_string(),
                good.display().to_string(),
            ],
            "missing.tif",
        ),
        (
            vec![good.display().to_string(), nodata.display().to_string()],
            "no valid cells",
        ),
        (
            vec![
                good.display().to_string(),
                good.display().to_string(),
                "--channel-area".into(),
                "0".into(),
            ],
            "--channel-area",
        ),
        (
            vec![
                good.display().to_string(),
                good.display().to_string(),
                "--radius".into(),
                "0km".into(),
            ],
            "--radius",
        ),
    ];
    for (args, want) in cases {
        let r = orogen()
            .arg("compare")
            .args(&args)
            .arg("-o")
            .arg(dir.path().join("out"))
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&r.stderr);
        assert!(!r.status.success(), "{args:?} succeeded");
        assert!(err.contains(want), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
    assert!(!dir.path().join("out/compare.json").exists());
    // A raster whose analysis would not fit the budget is refused before reading.
    let src = open_raster(&good, &OpenOptions::default()).unwrap();
    let e = compare::load_terrain(src.as_ref(), "w", 1 << 20).unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.contains("whitebox_DEM.tif") && msg.contains("over the budget"),
        "{msg}"
    );
}
