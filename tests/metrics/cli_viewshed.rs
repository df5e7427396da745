//! `orogen viewshed` end to end on a real DEM: the written window equals the
//! library's viewshed of the same window (single, cumulative from CSV and
//! GeoJSON, fuzzy), is georeferenced at the window's corner; bad input gives
//! clear errors.

use orogen::io::{open_raster, OpenOptions};
use orogen::metrics::visibility::{accumulate_viewshed, viewshed, ViewshedOptions};
use orogen::raster::{read_window, DType, Grid, Window};
use std::path::Path;
use std::process::Command;

const DEM: &str = "tests/data/bigtujunga_crop.tif";

fn orogen(args: &[&str]) -> (bool, String) {
    let o = Command::new(env!("CARGO_BIN_EXE_orogen"))
        .args(args)
        .arg("--quiet")
        .output()
        .unwrap();
    (
        o.status.success(),
        String::from_utf8_lossy(&o.stderr).to_string(),
    )
}

fn read_all(p: &Path) -> (orogen::raster::RasterInfo, Grid<f64>) {
    let r = open_raster(p, &OpenOptions::default()).unwrap();
    let i = r.info().clone();
    let g = read_window::<f64>(r.as_ref(), Window::full(i.width, i.height)).unwrap();
    (i, g)
}

#[test]
fn viewshed_cli_single_cumulative_fuzzy() {
    let dir = tempfile::tempdir().unwrap();
    let src = open_raster(Path::new(DEM), &OpenOptions::default()).unwrap();
    let info = src.info().clone();
    let cell = info.georef.cell_size_m(0);
    assert!(
        (cell.0 - 30.0).abs() < 1.0 && (cell.1 - 30.0).abs() < 1.0,
        "{cell:?}"
    );
    // Observer at the centre of cell (150, 100); radius 1.5 km = 50 cells of 30 m.
    let (ox, oy) = info.georef.pixel_to_map(150.5, 100.5);
    let at = format!("{ox},{oy}");
    let out = dir.path().join("vis.tif");
    let (ok, err) = orogen(&[
        "viewshed",
        DEM,
        "--at",
        &at,
        "--radius",
        "1.5km",
        "--observer-height",
        "2",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{err}");
    let (oi, got) = read_all(&out);
    assert_eq!(oi.dtype, DType::U8);
    let win = Window::new(100, 50, 101, 101);
    assert_eq!((oi.width, oi.height), (win.w, win.h));
    assert_eq!(
        oi.georef.transform[0],
        info.georef.pixel_to_map(100.0, 50.0).0
    );
    assert_eq!(
        oi.georef.transform[3],
        info.georef.pixel_to_map(100.0, 50.0).1
    );
    let dem = read_window::<f32>(src.as_ref(), win).unwrap();
    let o = ViewshedOptions {
        observer_height: 2.0,
        radius_m: 1500.0,
        ..Default::default()
    };
    let want = viewshed(&dem, cell, (50, 50), &o).unwrap();
    let (mut vis, mut hid) = (0, 0);
    for y in 0..win.h {
        for x in 0..win.w {
            let w = want.get(x, y);
            let g = got.get(x, y);
            // 255 is the file's nodata: read back as NaN.
            if w == 255 {
                assert!(g.is_nan(), "({x},{y})");
            } else {
                assert_eq!(g, w as f64, "({x},{y})");
                vis += usize::from(w == 1);
                hid += usize::from(w == 0);
            }
        }
    }
    assert!(vis > 100 && hid > 100, "{vis} visible, {hid} hidden");

    // Cumulative from a CSV and the same points from GeoJSON; fuzzy.
    let p2 = info.georef.pixel_to_map(170.5, 90.5);
    let csv = dir.path().join("pts.csv");
    std::fs::write(
        &csv,
        format!("name,x,y\na,{ox},{oy}\nb,{},{}\n", p2.0, p2.1),
    )
    .unwrap();
    let gj = dir.path().join("pts.geojson");
    std::fs::write(
        &gj,
        format!(
            r#"{{"type":"FeatureCollection","features":[{{"type":"Feature","properties":{{}},"geometry":{{"type":"Point","coordinates":[{ox},{oy}]}}}},{{"type":"Feature","properties":{{}},"geometry":{{"type":"Point","coordinates":[{},{}]}}}}]}}"#,
            p2.0, p2.1
        ),
    )
    .unwrap();
    let win2 = Window::new(100, 40, 121, 111);
    let dem2 = read_window::<f32>(src.as_ref(), win2).unwrap();
    let mut count = Grid::new(win2.w, win2.h, 0f32);
    let mut fuzzy = Grid::new(win2.w, win2.h, 0f32);
    for obs in [(50, 60), (70, 50)] {
        accumulate_viewshed(&dem2, cell, obs, &o, None, &mut count).unwrap();
        accumulate_viewshed(&dem2, cell, obs, &o, Some((300.0, 600.0)), &mut fuzzy).unwrap();
    }
    for (file, fz) in [(&csv, false), (&gj, false), (&csv, true)] {
        let out = dir.path().join(format!("c_{fz}.tif"));
        let mut args = vec![
            "viewshed",
            DEM,
            "--points",
            file.to_str().unwrap(),
            "--radius",
            "1500m",
            "--observer-height",
            "2",
            "-o",
            out.to_str().unwrap(),
        ];
        if fz {
            args.extend(["--fuzzy", "300,600"]);
        }
        let (ok, err) = orogen(&args);
        assert!(ok, "{err}");
        let (oi, got) = read_all(&out);
        assert_eq!(oi.dtype, if fz { DType::F32 } else { DType::U16 });
        assert_eq!((oi.width, oi.height), (win2.w, win2.h));
        let want = if fz { &fuzzy } else { &count };
        assert!(
            want.data().iter().any(|&v| v >= 1.5),
            "both observers see some cells"
        );
        for (i, (&g, &w)) in got.data().iter().zip(want.data()).enumerate() {
            assert!(
                (g - w as f64).abs() < 1e-6,
                "{} cell {i}: {g} vs {w}",
                file.display()
            );
        }
    }
}

#[test]
fn viewshed_cli_errors() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("v.tif");
    let o = out.to_str().unwrap();
    let (ok, err) = orogen(&["viewshed", DEM, "--at", "0,0", "-o", o]);
    assert!(
        !ok && err.contains("outside") && err.contains("inside the DEM"),
        "{err}"
    );
    // One option added to a valid run at pixel (5, 5), and what the error says.
    for (extra, says) in [
        ("--radius=-3km", "positive"),
        ("--observer-height=-1", "observer height"),
    ] {
        let (ok, err) = orogen(&["viewshed", DEM, "--pixel", "--at", "5,5", extra, "-o", o]);
        assert!(!ok && err.contains(says), "{extra}: {err}");
    }
    let (ok, err) = orogen(&["viewshed", DEM, "--pixel", "--at", "5", "-o", o]);
    assert!(!ok && err.contains("two numbers"), "{err}");
    let (ok, err) = orogen(&["viewshed", DEM, "-o", o]);
    assert!(!ok && err.contains("--at"), "{err}");
    let bad = dir.path().join("bad.csv");
    std::fs::write(&bad, "a,b\n1,2\n").unwrap();
    let (ok, err) = orogen(&["viewshed", DEM, "--points", bad.to_str().unwrap(), "-o", o]);
    assert!(!ok && err.contains("x and y"), "{err}");
    let (ok, err) = orogen(&[
        "viewshed", DEM, "--pixel", "--at", "5,5", "--fuzzy", "10,0", "-o", o,
    ]);
    assert!(!ok && err.contains("b2 > 0"), "{err}");
}
