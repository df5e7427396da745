//! `orogen orostats`, `orogen classify` and `orogen ridges` as a user runs them.

use crate::common::cli::{data, fails, ok, orogen};
use crate::common::write_esri_ascii;
use std::path::Path;

fn asc(path: &Path, w: usize, h: usize, f: impl Fn(usize, usize) -> f64) {
    write_esri_ascii(path, (w, h), (500000.0, 4000000.0, 100.0), |x, y| {
        Some(f(x, y))
    });
}

#[test]
fn orostats_then_classify_evaluate_train_predict() {
    let dir = tempfile::tempdir().unwrap();
    let a = dir.path().join("a.csv");
    let b = dir.path().join("b.csv");
    let prof = dir.path().join("a.json");
    let out = ok(orogen()
        .args([
            "orostats", "-R", "1km", "--label", "tujunga", "--seed", "3", "-o",
        ])
        .arg(&a)
        .arg("--profile")
        .arg(&prof)
        .arg(data("bigtujunga_crop.tif")));
    assert!(out.contains("disks of radius 1000 m"), "{out}");
    let p = orogen::oro::stats::OroProfile::load(&prof).unwrap();
    assert_eq!(p.label, "tujunga");
    assert!(p.n_peaks > 0 && p.n_disks > 0);
    ok(orogen()
        .args(["orostats", "-q", "-R", "3km", "--label", "whitebox", "-o"])
        .arg(&b)
        .arg(data("whitebox_DEM.tif")));
    let text = std::fs::read_to_string(&a).unwrap();
    let header = text.lines().next().unwrap();
    assert!(header.starts_with("label,source,col,row,n_peaks,elevation_norm:0-0.1,"));
    let n_cols = header.split(',').count();
    assert!(text
        .lines()
        .skip(1)
        .all(|l| l.split(',').count() == n_cols && l.starts_with("tujunga,bigtujunga_crop.tif,")));
    // Same seed, same bytes.
    let a2 = dir.path().join("a2.csv");
    ok(orogen()
        .args([
            "orostats", "-q", "-R", "1km", "--label", "tujunga", "--seed", "3", "-o",
        ])
        .arg(&a2)
        .arg(data("bigtujunga_crop.tif")));
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&a2).unwrap());
    // JSON form.
    let j = dir.path().join("a.json.features.json");
    ok(orogen()
        .args(["orostats", "-q", "-R", "1km", "-o"])
        .arg(&j)
        .arg(data("bigtujunga_crop.tif")));
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&j).unwrap()).unwrap();
    assert_eq!(v["names"].as_array().unwrap().len(), n_cols - 5);

    let conf = dir.path().join("confusion.csv");
    let out = ok(orogen()
        .args([
            "classify",
            "evaluate",
            "--repeats",
            "3",
            "--trees",
            "15",
            "-o",
        ])
        .arg(&conf)
        .arg(&a)
        .arg(&b));
    assert!(out.contains("accuracy") && out.contains("± "), "{out}");
    let c = std::fs::read_to_string(&conf).unwrap();
    assert!(c.starts_with("true\\predicted,tujunga,whitebox\n"), "{c}");
    let model = dir.path().join("model.json");
    ok(orogen()
        .args(["classify", "train", "--trees", "15", "-o"])
        .arg(&model)
        .arg(&a)
        .arg(&b));
    let pred = dir.path().join("pred.csv");
    ok(orogen()
        .args(["classify", "predict"])
        .arg(&model)
        .arg(&b)
        .arg("-o")
        .arg(&pred));
    let pt = std::fs::read_to_string(&pred).unwrap();
    assert!(pt.starts_with("label,predicted\n"));
    assert_eq!(
        pt.lines().count(),
        std::fs::read_to_string(&b).unwrap().lines().count()
    );

    // One label only: the classifier says it needs two.
    let e = fails(
        orogen()
            .args(["classify", "train", "-o"])
            .arg(&model)
            .arg(&a),
    );
    assert!(e.contains("two"), "{e}");
    let e = fails(
        orogen()
            .args(["classify", "predict", "/no/such/model.json"])
            .arg(&b),
    );
    assert!(e.contains("/no/such/model.json"), "{e}");
}

#[test]
fn orostats_bad_input_is_explained() {
    let dir = tempfile::tempdir().unwrap();
    let o = dir.path().join("f.csv");
    let e = fails(
        orogen()
            .args(["orostats", "-R", "100km", "-o"])
            .arg(&o)
            .arg(data("bigtujunga_crop.tif")),
    );
    assert!(e.contains("does not fit"), "{e}");
    let e = fails(
        orogen()
            .args(["orostats", "-R", "ten", "-o"])
            .arg(&o)
            .arg(data("bigtujunga_crop.tif")),
    );
    assert!(e.contains("distance"), "{e}");
    let e = fails(
        orogen()
            .args(["orostats", "-o", "x.txt"])
            .arg(data("bigtujunga_crop.tif")),
    );
    assert!(e.contains(".csv or .json"), "{e}");
    // All nodata.
    let none = dir.path().join("none.asc");
    asc(&none, 40, 40, |_, _| -9999.0);
    let e = fails(
        orogen()
            .args(["orostats", "-R", "1km", "-o"])
            .arg(&o)
            .arg(&none),
    );
    assert!(e.contains("no valid cells"), "{e}");
    // Flat: no peaks with the unknown edge, a warning, zero histograms.
    let flat = dir.path().join("flat.asc");
    asc(&flat, 40, 40, |_, _| 120.0);
    let out = ok(orogen()
        .args(["orostats", "-R", "1km", "--edge", "unknown", "-o"])
        .arg(&o)
        .arg(&flat));
    assert!(out.contains("no peaks"), "{out}");
    // A single peak.
    let one = dir.path().join("one.asc");
    asc(&one, 40, 40, |x, y| {
        900.0 - 10.0 * ((x as f64 - 20.0).powi(2) + (y as f64 - 20.0).powi(2)).sqrt()
    });
    let out = ok(orogen()
        .args(["orostats", "-R", "1km", "-o"])
        .arg(&o)
        .arg(&one));
    assert!(out.contains(", 1 peaks"), "{out}");
}

#[test]
fn ridges_writes_networks() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r");
    let msg = ok(orogen()
        .args(["ridges", "--min-prominence", "20", "-o"])
        .arg(&out)
        .arg(data("whitebox_DEM.tif")));
    assert!(msg.contains("ridge segments"), "{msg}");
    for f in [
        "ridges.geojson",
        "ridge_levels.tif",
        "ridge_orders.tif",
        "ppa_ridges.tif",
    ] {
        assert!(out.join(f).exists(), "{f}");
    }
    let src = orogen::io::open_raster(&out.join("ridge_levels.tif"), &Default::default()).unwrap();
    let info = src.info().clone();
    let g = orogen::raster::read_window::<f32>(
        src.as_ref(),
        orogen::raster::Window::full(info.width, info.height),
    )
    .unwrap();
    let n1 = g.data().iter().filter(|&&v| v == 1.0).count();
    assert!(n1 > 0, "a main ridge");
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("ridges.geojson")).unwrap())
            .unwrap();
    let feats = v["features"].as_array().unwrap();
    assert!(!feats.is_empty());
    assert!(feats
        .iter()
        .all(|f| f["properties"]["level"].as_u64().unwrap() >= 1));
}
