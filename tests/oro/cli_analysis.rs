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
    // The rasters mark exactly the cells of the GeoJSON paths, each with
    // the smallest level and an order among those of the paths through it.
    let (w, h) = (info.width, info.height);
    let orders = raster(&out.join("ridge_orders.tif"));
    let mut level = vec![0u64; w * h];
    let mut ords = vec![Vec::new(); w * h];
    for f in feats {
        let p = &f["properties"];
        for c in f["geometry"]["coordinates"].as_array().unwrap() {
            let (col, row) = info
                .georef
                .map_to_pixel(c[0].as_f64().unwrap(), c[1].as_f64().unwrap())
                .unwrap();
            let k = row.floor() as usize * w + col.floor() as usize;
            let l = p["level"].as_u64().unwrap();
            level[k] = if level[k] == 0 { l } else { level[k].min(l) };
            ords[k].push(p["order"].as_u64().unwrap());
        }
    }
    for k in 0..w * h {
        let (x, y) = (k % w, k / w);
        // Consecutive path cells may be apart across flats: only the cells
        // the GeoJSON names are checked for their values.
        if level[k] > 0 {
            assert_eq!(g.get(x, y) as u64, level[k], "level at ({x}, {y})");
            assert!(
                ords[k].contains(&(orders.get(x, y) as u64)),
                "order at ({x}, {y})"
            );
        }
    }
    // PPA marks only Chang et al.'s candidates.
    let dem = raster(&data("whitebox_DEM.tif"));
    let z: Vec<f64> = dem.data().iter().map(|&v| v as f64).collect();
    let ppa = raster(&out.join("ppa_ridges.tif"));
    let mut n = 0;
    for y in 0..h {
        for x in 0..w {
            if ppa.get(x, y) == 1.0 {
                n += 1;
                assert!(
                    ppa_candidate(&z, w, h, x, y, 3),
                    "PPA ridge ({x}, {y}) is no candidate"
                );
            }
        }
    }
    assert!(n > 100, "{n} PPA ridge cells");
}

/// A raster written by `orogen ridges`, as f32.
fn raster(p: &Path) -> orogen::raster::Grid<f32> {
    let src = orogen::io::open_raster(p, &Default::default()).unwrap();
    let i = src.info().clone();
    orogen::raster::read_window::<f32>(
        src.as_ref(),
        orogen::raster::Window::full(i.width, i.height),
    )
    .unwrap()
}

/// Chang et al.'s candidate test, by hand: along one of the four profiles
/// through (x, y), a lower cell within `hw` cells on both sides.
fn ppa_candidate(z: &[f64], w: usize, h: usize, x: usize, y: usize, hw: i64) -> bool {
    let at = |x: i64, y: i64| {
        (x >= 0 && y >= 0 && x < w as i64 && y < h as i64).then(|| z[y as usize * w + x as usize])
    };
    let c = z[y * w + x];
    [(1, 0), (0, 1), (1, 1), (1, -1)].iter().any(|&(dx, dy)| {
        let lower = |s: i64| {
            (1..=hw)
                .any(|k| at(x as i64 + s * k * dx, y as i64 + s * k * dy).is_some_and(|v| v < c))
        };
        lower(1) && lower(-1)
    })
}

/// One straight ridge along row 20 of a 61 x 41 DEM (100 m cells) with two
/// summits, P1 (15, 20) at 1000 m and P2 (45, 20) at 900 m, and their key
/// saddle at (35, 20), 800 m: z = max(1000 − 10|x − 15|, 900 − 10|x − 45|)
/// − 20|y − 20|. The divide-tree ridges are the two steepest ascents from
/// the saddle along the crest, one tree whose longest path is the whole
/// crest (level 1) with Strahler order 1; PPA keeps only candidate cells,
/// the crest among them.
#[test]
fn ridges_of_a_two_summit_crest() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (61, 41);
    let f = |x: usize, y: usize| {
        let (x, y) = (x as f64, y as f64);
        (1000.0 - 10.0 * (x - 15.0).abs()).max(900.0 - 10.0 * (x - 45.0).abs())
            - 20.0 * (y - 20.0).abs()
    };
    let dem = dir.path().join("crest.asc");
    asc(&dem, w, h, f);
    let z: Vec<f64> = (0..w * h).map(|k| f(k % w, k / w)).collect();
    let out = dir.path().join("r");
    ok(orogen()
        .args(["ridges", "--min-prominence", "20", "-o"])
        .arg(&out)
        .arg(&dem));
    let levels = raster(&out.join("ridge_levels.tif"));
    let orders = raster(&out.join("ridge_orders.tif"));
    let ppa = raster(&out.join("ppa_ridges.tif"));
    for y in 0..h {
        for x in 0..w {
            let on = y == 20 && (15..=45).contains(&x);
            let want = if on { 1.0 } else { 0.0 };
            assert_eq!(levels.get(x, y), want, "level at ({x}, {y})");
            assert_eq!(orders.get(x, y), want, "order at ({x}, {y})");
            if ppa.get(x, y) == 1.0 {
                assert!(
                    ppa_candidate(&z, w, h, x, y, 3),
                    "PPA ridge ({x}, {y}) is no candidate"
                );
            } else {
                assert_eq!(ppa.get(x, y), 0.0);
            }
        }
    }
    for x in 3..w - 3 {
        assert_eq!(ppa.get(x, 20), 1.0, "PPA misses the crest at ({x}, 20)");
    }
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("ridges.geojson")).unwrap())
            .unwrap();
    let mut feats: Vec<(f64, f64, f64, u64, u64)> = v["features"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| {
            let p = &f["properties"];
            (
                p["saddle_elevation"].as_f64().unwrap(),
                p["peak_elevation"].as_f64().unwrap(),
                p["length_m"].as_f64().unwrap(),
                p["level"].as_u64().unwrap(),
                p["order"].as_u64().unwrap(),
            )
        })
        .collect();
    feats.sort_by(|a, b| a.1.total_cmp(&b.1));
    // Saddle to P2: 10 cells east; to P1: 20 cells west.
    assert_eq!(
        feats,
        [(800.0, 900.0, 1000.0, 1, 1), (800.0, 1000.0, 2000.0, 1, 1)]
    );
}
