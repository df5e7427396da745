//! The coordinates of GeoJSON outputs (RFC 7946: WGS 84 lon/lat;
//! `--geojson-crs native`: the raster's CRS with a named-CRS member) and the
//! `crs` member of GeoJSON inputs, as a user runs them.
//!
//! The oracle is GDAL/PROJ, not orogen's projection: the constants below are
//! cell centres (and one corner) of tests/data/bigtujunga_crop.tif (WGS 84 /
//! UTM 11N, origin 388313.655454263498541, 3801917.827628375496715, 30 m
//! cells) recorded once with GDAL 3.6.2:
//!
//! ```text
//! printf "392348.6554542635 3801302.8276283755\n..." |
//!   gdaltransform -s_srs EPSG:32611 -t_srs EPSG:4326 -output_xy
//! ```
//!
//! `tools/geojson_crs_check.sh` checks the files with `ogrinfo` as well.

use crate::common::cli::{data, fails, ok, orogen};
use serde_json::Value;
use std::path::Path;

/// A point as (x, y) or (lon, lat).
type Xy = (f64, f64);

/// (col, row) of a cell of bigtujunga_crop.tif, its centre in UTM 11N, and
/// that centre's lon/lat by gdaltransform (see the module doc).
const CENTRES: [((u64, u64), Xy, Xy); 7] = [
    // peak 0 (1647 m)
    (
        (134, 20),
        (392348.6554542635, 3801302.8276283755),
        (-118.170473435345, 34.3474567057365),
    ),
    // peak 1
    (
        (51, 0),
        (389858.6554542635, 3801902.8276283755),
        (-118.197618537457, 34.3526047630522),
    ),
    // peak 3
    (
        (3, 107),
        (388418.6554542635, 3798692.8276283755),
        (-118.212856511662, 34.3235079704381),
    ),
    // key saddle of peak 1 (1417 m)
    (
        (132, 0),
        (392288.6554542635, 3801902.8276283755),
        (-118.171200925279, 34.3528603766086),
    ),
    // key saddle of peak 3 (1321 m)
    (
        (0, 83),
        (388328.6554542635, 3799412.8276283755),
        (-118.213928091957, 34.3299900937593),
    ),
    // stream nodes at threshold 50 cells: a head and an outlet on the top edge
    (
        (242, 0),
        (395588.6554542635, 3801902.8276283755),
        (-118.135324630145, 34.3531983812961),
    ),
    (
        (253, 0),
        (395918.6554542635, 3801902.8276283755),
        (-118.131736967965, 34.3532316036799),
    ),
];

/// The top-left corner of the DEM (a vertex of the basin outlines).
const TOP_LEFT_LONLAT: (f64, f64) = (-118.214416696635, 34.3525745253674);

/// RFC 7946 output agrees with PROJ to 1e-7 degrees (about 1 cm).
const TOL_DEG: f64 = 1e-7;

fn read(p: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

fn xy(v: &Value) -> (f64, f64) {
    (v[0].as_f64().unwrap(), v[1].as_f64().unwrap())
}

fn oracle(col: u64, row: u64) -> Option<((f64, f64), (f64, f64))> {
    CENTRES
        .iter()
        .find(|c| c.0 == (col, row))
        .map(|c| (c.1, c.2))
}

fn near(a: (f64, f64), b: (f64, f64), tol: f64) -> bool {
    (a.0 - b.0).abs() <= tol && (a.1 - b.1).abs() <= tol
}

/// Features of `v` whose col/row properties are in [`CENTRES`], with their
/// coordinates and the oracle's projected and lon/lat values.
fn checked_points(v: &Value) -> Vec<(Xy, Xy, Xy)> {
    v["features"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|f| {
            let p = &f["properties"];
            let (c, r) = (p["col"].as_u64()?, p["row"].as_u64()?);
            let (m, ll) = oracle(c, r)?;
            Some((xy(&f["geometry"]["coordinates"]), m, ll))
        })
        .collect()
}

fn peaks(dir: &Path, extra: &[&str]) {
    ok(orogen()
        .args(["peaks", "--min-prominence", "20", "-q", "-o"])
        .arg(dir)
        .args(extra)
        .arg(data("bigtujunga_crop.tif")));
}

#[test]
fn peaks_and_saddles_of_a_utm_dem_are_lonlat_as_gdal_projects_them() {
    let d = tempfile::tempdir().unwrap();
    peaks(d.path(), &[]);
    let pv = read(&d.path().join("peaks.geojson"));
    assert!(pv.get("crs").is_none(), "RFC 7946 output has no crs member");
    let got = checked_points(&pv);
    assert_eq!(got.len(), 3, "peaks 0, 1 and 3 are at the oracle's cells");
    for (c, _, ll) in &got {
        assert!(near(*c, *ll, TOL_DEG), "{c:?} vs GDAL {ll:?}");
    }
    let sv = read(&d.path().join("saddles.geojson"));
    let got = checked_points(&sv);
    assert_eq!(got.len(), 2, "the key saddles of peaks 1 and 3");
    for (c, _, ll) in &got {
        assert!(near(*c, *ll, TOL_DEG), "{c:?} vs GDAL {ll:?}");
    }
    // The divide tree's edge of peak 3: peak, key saddle, parent (peak 0).
    let tv = read(&d.path().join("divide_tree.geojson"));
    let e = tv["features"]
        .as_array()
        .unwrap()
        .iter()
        .find(|f| f["properties"]["peak"] == 3)
        .unwrap();
    let line: Vec<(f64, f64)> = e["geometry"]["coordinates"]
        .as_array()
        .unwrap()
        .iter()
        .map(xy)
        .collect();
    let want = [CENTRES[2].2, CENTRES[4].2, CENTRES[0].2];
    for (g, w) in line.iter().zip(want) {
        assert!(near(*g, w, TOL_DEG), "{g:?} vs GDAL {w:?}");
    }
    // Properties are measures in metres, unchanged: isolation in km from the CSV.
    let csv = std::fs::read_to_string(d.path().join("peaks.csv")).unwrap();
    let row3: Vec<&str> = csv.lines().nth(4).unwrap().split(',').collect();
    let iso: f64 = row3[7].parse().unwrap();
    assert_eq!(
        pv["features"][3]["properties"]["isolation_km"].as_f64(),
        Some(iso)
    );
    // peaks.csv keeps the DEM's projected coordinates.
    assert_eq!(&row3[..2], &["3798692.8276283755", "388418.6554542635"]);
}

#[test]
fn geojson_crs_native_keeps_projected_coordinates_and_names_the_crs() {
    let (a, b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    peaks(a.path(), &["--geojson-crs", "native"]);
    peaks(b.path(), &[]);
    for f in ["peaks.geojson", "saddles.geojson", "divide_tree.geojson"] {
        let v = read(&a.path().join(f));
        assert_eq!(
            v["crs"],
            serde_json::json!({"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::32611"}}),
            "{f}"
        );
        // Same features and properties as the lon/lat file.
        let w = read(&b.path().join(f));
        let props = |v: &Value| -> Vec<Value> {
            v["features"]
                .as_array()
                .unwrap()
                .iter()
                .map(|f| f["properties"].clone())
                .collect()
        };
        assert_eq!(props(&v), props(&w), "{f}");
    }
    let got = checked_points(&read(&a.path().join("peaks.geojson")));
    assert_eq!(got.len(), 3);
    for (c, m, _) in &got {
        assert_eq!(c, m, "the projected cell centre, as written before");
    }
}

#[test]
fn geojson_crs_values_other_than_wgs84_and_native_are_refused() {
    let d = tempfile::tempdir().unwrap();
    let out = orogen()
        .args(["peaks", "--geojson-crs", "utm", "-o"])
        .arg(d.path())
        .arg(data("bigtujunga_crop.tif"))
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && !e.contains("panicked"), "{e}");
    assert!(
        e.contains("\"utm\"") && e.contains("wgs84") && e.contains("native"),
        "{e}"
    );
    assert!(!d.path().join("peaks.geojson").exists());
}

#[test]
fn geographic_dem_geojson_is_the_same_in_both_modes() {
    let (a, b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let dem = data("oro/srtm3_N46E008_crop.tif");
    for (d, mode) in [(a.path(), "wgs84"), (b.path(), "native")] {
        ok(orogen()
            .args([
                "peaks",
                "--min-prominence",
                "30",
                "-q",
                "--geojson-crs",
                mode,
                "-o",
            ])
            .arg(d)
            .arg(&dem));
    }
    for f in ["peaks.geojson", "saddles.geojson", "divide_tree.geojson"] {
        let x = std::fs::read(a.path().join(f)).unwrap();
        assert_eq!(x, std::fs::read(b.path().join(f)).unwrap(), "{f}");
        assert!(read(&a.path().join(f)).get("crs").is_none(), "{f}");
    }
    // The coordinates are the lat/lon of peaks.csv, as they are.
    let csv = std::fs::read_to_string(a.path().join("peaks.csv")).unwrap();
    let first: Vec<f64> = csv
        .lines()
        .nth(1)
        .unwrap()
        .split(',')
        .take(2)
        .map(|s| s.parse().unwrap())
        .collect();
    let v = read(&a.path().join("peaks.geojson"));
    assert_eq!(
        xy(&v["features"][0]["geometry"]["coordinates"]),
        (first[1], first[0])
    );
}

/// A copy of bigtujunga_crop.tif claiming EPSG:2056 (Swiss LV95), a CRS
/// orogen does not project.
fn lv95_dem(dir: &Path) -> std::path::PathBuf {
    use orogen::raster::{read_window, Crs, GeoRef, MemRaster, Window};
    let src = orogen::io::open_raster(&data("bigtujunga_crop.tif"), &Default::default()).unwrap();
    let info = src.info();
    let g = read_window::<f32>(src.as_ref(), Window::full(info.width, info.height)).unwrap();
    let geo = GeoRef::north_up(2_600_000.0, 1_200_000.0, 30.0, Crs::projected(2056));
    let p = dir.join("lv95.tif");
    let mem = MemRaster::from_grid(g, geo);
    orogen::ops::convert(&mem, &p, &Default::default(), None, &Default::default()).unwrap();
    p
}

#[test]
fn a_crs_orogen_cannot_project_fails_naming_the_fix_and_writes_nothing() {
    let d = tempfile::tempdir().unwrap();
    let dem = lv95_dem(d.path());
    let out = d.path().join("p");
    let e = fails(orogen().args(["peaks", "-q", "-o"]).arg(&out).arg(&dem));
    assert!(e.contains("lv95.tif") && e.contains("EPSG:2056"), "{e}");
    assert!(e.contains("--geojson-crs native"), "{e}");
    assert!(!out.exists(), "nothing written");
    // The other commands refuse before writing too.
    let r = d.path().join("r");
    let e = fails(
        orogen()
            .args(["ridges", "-q", "--no-ppa", "-o"])
            .arg(&r)
            .arg(&dem),
    );
    assert!(e.contains("--geojson-crs native"), "{e}");
    assert!(!r.join("ridges.geojson").exists() && !r.join("ridge_levels.tif").exists());
    // With native: the LV95 coordinates and a crs member naming them.
    ok(orogen()
        .args(["peaks", "-q", "--geojson-crs", "native", "-o"])
        .arg(&out)
        .arg(&dem));
    let v = read(&out.join("peaks.geojson"));
    assert_eq!(v["crs"]["properties"]["name"], "urn:ogc:def:crs:EPSG::2056");
    let f = &v["features"][0];
    let (c, r) = (
        f["properties"]["col"].as_f64().unwrap(),
        f["properties"]["row"].as_f64().unwrap(),
    );
    assert_eq!(
        xy(&f["geometry"]["coordinates"]),
        (
            2_600_000.0 + 30.0 * (c + 0.5),
            1_200_000.0 - 30.0 * (r + 0.5)
        )
    );
}

#[test]
fn a_raster_without_crs_writes_its_own_coordinates_with_a_warning() {
    let d = tempfile::tempdir().unwrap();
    let dem = d.path().join("local.asc");
    // One cone on a 100 m grid whose lower-left corner is (1000, 2000), no .prj.
    crate::common::write_esri_ascii(&dem, (21, 21), (1000.0, 2000.0, 100.0), |x, y| {
        Some((100.0 - 10.0 * (x.abs_diff(10).max(y.abs_diff(10)) as f64)).max(0.0))
    });
    let out = d.path().join("p");
    let log = ok(orogen().args(["peaks", "-o"]).arg(&out).arg(&dem));
    assert!(
        log.contains("warning:")
            && log.contains("local.asc")
            && log.contains("no known coordinate reference system"),
        "{log}"
    );
    let v = read(&out.join("peaks.geojson"));
    assert!(v.get("crs").is_none());
    // The centre of cell (10, 10): x = 1000 + 1050, y = 2000 + 2100 - 1050.
    assert_eq!(
        xy(&v["features"][0]["geometry"]["coordinates"]),
        (2050.0, 3050.0)
    );
}

#[test]
fn ridges_streams_nodes_and_basin_outlines_of_a_utm_dem_are_lonlat() {
    let d = tempfile::tempdir().unwrap();
    let p = |n: &str| d.path().join(n);
    ok(orogen()
        .args(["ridges", "--min-prominence", "20", "--no-ppa", "-q", "-o"])
        .arg(p("ridges"))
        .arg(data("bigtujunga_crop.tif")));
    let rv = read(&p("ridges/ridges.geojson"));
    assert!(rv.get("crs").is_none());
    // Ridges climb from saddles to peaks: those of peak 1 end on it, and
    // one starts at its key saddle.
    let feats = rv["features"].as_array().unwrap();
    let line = |f: &Value| -> Vec<(f64, f64)> {
        f["geometry"]["coordinates"]
            .as_array()
            .unwrap()
            .iter()
            .map(xy)
            .collect()
    };
    let of_peak_1: Vec<&Value> = feats
        .iter()
        .filter(|f| f["properties"]["peak"] == 1)
        .collect();
    assert!(!of_peak_1.is_empty());
    for f in &of_peak_1 {
        let l = line(f);
        assert!(near(*l.last().unwrap(), CENTRES[1].2, TOL_DEG), "{l:?}");
        assert!(
            f["properties"]["length_m"].as_f64().unwrap() > 30.0,
            "metres"
        );
    }
    assert!(feats
        .iter()
        .any(|f| near(line(f)[0], CENTRES[3].2, TOL_DEG)));

    ok(orogen()
        .args(["fill", "-q", "-o"])
        .arg(p("filled.tif"))
        .arg(data("bigtujunga_crop.tif")));
    ok(orogen()
        .args(["flow", "-q", "-o"])
        .arg(p("d8.tif"))
        .arg(p("filled.tif")));
    for mode in ["wgs84", "native"] {
        ok(orogen()
            .args([
                "streams",
                "--threshold",
                "50",
                "-q",
                "--geojson-crs",
                mode,
                "-o",
            ])
            .arg(p(&format!("s_{mode}.geojson")))
            .arg("--nodes")
            .arg(p(&format!("n_{mode}.geojson")))
            .arg(p("d8.tif")));
    }
    let nodes = read(&p("n_wgs84.geojson"));
    assert!(nodes.get("crs").is_none());
    let got = checked_points(&nodes);
    assert_eq!(
        got.len(),
        2,
        "the head at (242, 0) and the outlet at (253, 0)"
    );
    for (c, _, ll) in &got {
        assert!(near(*c, *ll, TOL_DEG), "{c:?} vs GDAL {ll:?}");
    }
    let native = read(&p("n_native.geojson"));
    assert_eq!(
        native["crs"]["properties"]["name"],
        "urn:ogc:def:crs:EPSG::32611"
    );
    for (c, m, _) in checked_points(&native) {
        assert_eq!(c, m);
    }
    // Links: the same vertices' lon/lat, lengths in metres in both modes.
    let (sw, sn) = (read(&p("s_wgs84.geojson")), read(&p("s_native.geojson")));
    assert!(sw.get("crs").is_none() && sn.get("crs").is_some());
    let (fw, fnat) = (
        sw["features"].as_array().unwrap(),
        sn["features"].as_array().unwrap(),
    );
    assert_eq!(fw.len(), fnat.len());
    for (a, b) in fw.iter().zip(fnat) {
        assert_eq!(a["properties"], b["properties"]);
        let (la, lb) = (
            a["geometry"]["coordinates"].as_array().unwrap(),
            b["geometry"]["coordinates"].as_array().unwrap(),
        );
        assert_eq!(la.len(), lb.len());
        for (v, w) in la.iter().zip(lb) {
            if let Some((_, ll)) = CENTRES.iter().find(|c| c.1 == xy(w)).map(|c| (c.1, c.2)) {
                assert!(near(xy(v), ll, TOL_DEG));
            }
            let (lon, lat) = xy(v);
            // Inside the DEM's lon/lat bounds (gdalinfo -json: wgs84Extent).
            assert!(
                (-118.2145..-118.1155).contains(&lon) && (34.2976..34.3536).contains(&lat),
                "{lon},{lat}"
            );
        }
    }

    ok(orogen()
        .args(["basins", "-q", "--min-cells", "500", "-o"])
        .arg(p("b.tif"))
        .arg("--metrics")
        .arg(p("bm.csv"))
        .arg("--dem")
        .arg(p("filled.tif"))
        .arg(p("d8.tif")));
    let bv = read(&p("bm.geojson"));
    assert!(bv.get("crs").is_none());
    let vertices: Vec<(f64, f64)> = bv["features"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|f| f["geometry"]["coordinates"].as_array().unwrap().clone())
        .flat_map(|part| part.as_array().unwrap().clone())
        .flat_map(|ring| ring.as_array().unwrap().clone())
        .map(|v| xy(&v))
        .collect();
    assert!(
        vertices.iter().any(|&v| near(v, TOP_LEFT_LONLAT, TOL_DEG)),
        "the DEM's top-left corner is a vertex of an outline"
    );
    // outlet_x/outlet_y stay the projected coordinates of the CSV.
    let csv = std::fs::read_to_string(p("bm.csv")).unwrap();
    let row: Vec<&str> = csv.lines().nth(1).unwrap().split(',').collect();
    let ox: f64 = row[3].parse().unwrap();
    assert_eq!(
        bv["features"][0]["properties"]["outlet_x"].as_f64(),
        Some(ox)
    );
}

#[test]
fn point_inputs_honour_a_crs_member() {
    let d = tempfile::tempdir().unwrap();
    let p = |n: &str| d.path().join(n);
    ok(orogen()
        .args(["fill", "-q", "-o"])
        .arg(p("filled.tif"))
        .arg(data("bigtujunga_crop.tif")));
    ok(orogen()
        .args(["flow", "-q", "-o"])
        .arg(p("d8.tif"))
        .arg(p("filled.tif")));
    // The same pour point (the outlet node at (253, 0)) three ways: UTM
    // without a crs member (as before), lon/lat by GDAL with a CRS84
    // member, UTM with the member --geojson-crs native writes.
    let (m, ll) = (CENTRES[6].1, CENTRES[6].2);
    let point = |crs: &str, (x, y): (f64, f64)| {
        format!(
            r#"{{"type":"FeatureCollection",{crs}"features":[{{"type":"Feature","geometry":{{"type":"Point","coordinates":[{x},{y}]}},"properties":{{}}}}]}}"#
        )
    };
    let files = [
        ("plain.geojson", point("", m)),
        (
            "crs84.geojson",
            point(
                r#""crs":{"type":"name","properties":{"name":"urn:ogc:def:crs:OGC:1.3:CRS84"}},"#,
                ll,
            ),
        ),
        (
            "native.geojson",
            point(
                r#""crs":{"type":"name","properties":{"name":"urn:ogc:def:crs:EPSG::32611"}},"#,
                m,
            ),
        ),
    ];
    let mut labels = Vec::new();
    for (name, text) in &files {
        std::fs::write(p(name), text).unwrap();
        let out = p(&format!("{name}.tif"));
        ok(orogen()
            .args(["basins", "-q", "--points"])
            .arg(p(name))
            .arg("-o")
            .arg(&out)
            .arg(p("d8.tif")));
        let g = crate::common::cli::read_f32(&out);
        labels.push(g.data().iter().map(|v| v.to_bits()).collect::<Vec<u32>>());
    }
    let cells = labels[0].iter().filter(|&&b| b == 1f32.to_bits()).count();
    assert!(cells > 1, "the point's watershed is labelled");
    assert!(labels[0] == labels[1], "CRS84 member: lon/lat read back");
    assert!(labels[0] == labels[2], "the native member: as is");
    // A member naming another CRS is refused, naming the file.
    std::fs::write(
        p("other.geojson"),
        point(
            r#""crs":{"type":"name","properties":{"name":"urn:ogc:def:crs:EPSG::32632"}},"#,
            m,
        ),
    )
    .unwrap();
    let e = fails(
        orogen()
            .args(["basins", "-q", "--points"])
            .arg(p("other.geojson"))
            .arg("-o")
            .arg(p("o.tif"))
            .arg(p("d8.tif")),
    );
    assert!(
        e.contains("other.geojson") && e.contains("EPSG:32632"),
        "{e}"
    );
}

#[test]
fn job_steps_take_geojson_crs() {
    let d = tempfile::tempdir().unwrap();
    let job = d.path().join("job.toml");
    std::fs::write(
        &job,
        format!(
            "output_dir = \"out\"\ninputs = {{ dem = {:?} }}\nstep = [\n    {{ name = \"p\", run = \"peaks\", input = \"dem\", output = \"peaks\", args = {{ min_prominence = 20, geojson_crs = \"native\" }} }},\n]\n",
            data("bigtujunga_crop.tif").to_str().unwrap(),
        ),
    )
    .unwrap();
    ok(orogen().args(["run", "-q"]).arg(&job));
    let v = read(&d.path().join("out/peaks/peaks.geojson"));
    assert_eq!(
        v["crs"]["properties"]["name"],
        "urn:ogc:def:crs:EPSG::32611"
    );
    let got = checked_points(&v);
    assert_eq!(got.len(), 3);
    for (c, m, _) in got {
        assert_eq!(c, m);
    }
}
