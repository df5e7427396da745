//! Hand-checked cases for `orogen::oro`: flats, nodata, single and twin
//! summits, sea level with negative heights, pits and saddles, writers and
//! the JSON round trip, pruning of an edited tree, hostile input.

use orogen::oro::{self, DivideTree, EdgeConvention, Peak, PeakOptions, Saddle};
use orogen::raster::{Crs, GeoRef, Grid};

const SEA: EdgeConvention = EdgeConvention::SeaLevel;
const UNK: EdgeConvention = EdgeConvention::Unknown;

fn grid(w: usize, rows: &[&[f32]]) -> Grid<f32> {
    let v: Vec<f32> = rows.iter().flat_map(|r| r.iter().copied()).collect();
    Grid::from_vec(w, rows.len(), v).unwrap()
}

/// (col, row, elevation, prominence, key saddle elevation, parent).
type Row = (u32, u32, f32, f64, Option<f32>, Option<usize>);

/// `oro::peaks` with no prominence threshold, in pixel coordinates.
fn every_peak(g: &Grid<f32>) -> oro::PeakList {
    oro::peaks(
        g,
        &GeoRef::pixel(),
        &PeakOptions {
            min_prominence: 0.0,
            ..Default::default()
        },
    )
    .unwrap()
}

fn summary(t: &DivideTree) -> Vec<Row> {
    t.peaks
        .iter()
        .map(|p| {
            (
                p.col,
                p.row,
                p.elevation,
                p.prominence,
                p.key_saddle.map(|s| t.saddles[s].elevation),
                p.parent,
            )
        })
        .collect()
}

#[test]
fn flat_dem() {
    let g = Grid::new(5, 4, 100.0f32);
    assert!(oro::divide_tree(&g, UNK).unwrap().peaks.is_empty());
    let c = oro::critical_points(&g, UNK).unwrap();
    assert!(c.peaks.is_empty() && c.saddles.is_empty() && c.pits.is_empty());
    // Under SeaLevel the flat is an island 100 m above the sea: one peak at its
    // first cell.
    let t = oro::divide_tree(&g, SEA).unwrap();
    assert_eq!(summary(&t), vec![(0, 0, 100.0, 100.0, None, None)]);
    // A flat at sea level is no island.
    assert!(oro::divide_tree(&Grid::new(3, 3, 0.0f32), SEA)
        .unwrap()
        .peaks
        .is_empty());
}

#[test]
fn all_nodata_and_empty() {
    let g = Grid::new(4, 4, f32::NAN);
    for conv in [SEA, UNK] {
        assert!(oro::divide_tree(&g, conv).unwrap().peaks.is_empty());
        let l = oro::peaks(
            &g,
            &GeoRef::pixel(),
            &PeakOptions {
                convention: conv,
                ..Default::default()
            },
        )
        .unwrap();
        assert!(l.tree.peaks.is_empty() && l.tree.saddles.is_empty());
    }
    let e: Grid<f32> = Grid::new(0, 0, 0.0);
    assert!(oro::divide_tree(&e, SEA).unwrap().peaks.is_empty());
}

#[test]
fn single_peak_cone() {
    let g = Grid::from_fn(7, 7, |x, y| {
        10.0 - (x as f32 - 3.0).abs().max((y as f32 - 3.0).abs())
    });
    assert_eq!(
        summary(&oro::divide_tree(&g, SEA).unwrap()),
        vec![(3, 3, 10.0, 10.0, None, None)]
    );
    // Unknown: down to the lowest cell (7).
    assert_eq!(
        summary(&oro::divide_tree(&g, UNK).unwrap()),
        vec![(3, 3, 10.0, 3.0, None, None)]
    );
    let l = every_peak(&g);
    assert_eq!(l.tree.peaks[0].isolation, None);
    assert_eq!(l.tree.peaks[0].dominance(), Some(1.0));
}

#[test]
fn twin_summits_tie_rule() {
    let g = grid(5, &[&[1.0, 5.0, 2.0, 5.0, 1.0]]);
    // The twin later in row-major order (x = 3) counts as higher.
    let t = oro::divide_tree(&g, SEA).unwrap();
    assert_eq!(
        summary(&t),
        vec![
            (3, 0, 5.0, 5.0, None, None),
            (1, 0, 5.0, 3.0, Some(2.0), Some(0))
        ]
    );
    assert_eq!((t.saddles[0].col, t.saddles[0].row), (2, 0));
    let t = oro::divide_tree(&g, UNK).unwrap();
    assert_eq!(
        summary(&t),
        vec![
            (3, 0, 5.0, 4.0, None, None),
            (1, 0, 5.0, 3.0, Some(2.0), Some(0))
        ]
    );
    let c = oro::critical_points(&g, UNK).unwrap();
    assert_eq!(c.saddles, vec![(2, 0)]);
    // Isolation of twins: no strictly higher ground.
    let l = every_peak(&g);
    assert!(l.tree.peaks.iter().all(|p| p.isolation.is_none()));
}

#[test]
fn plateau_summit_representative_and_pit() {
    let g = grid(
        5,
        &[
            &[1.0, 1.0, 1.0, 1.0, 1.0],
            &[1.0, 7.0, 7.0, 3.0, 1.0],
            &[1.0, 7.0, 3.0, 0.5, 1.0],
            &[1.0, 2.0, 3.0, 3.0, 1.0],
            &[1.0, 1.0, 1.0, 1.0, 1.0],
        ],
    );
    let t = oro::divide_tree(&g, SEA).unwrap();
    // The L-shaped 7 m plateau is one peak, represented by its first cell.
    assert_eq!(summary(&t), vec![(1, 1, 7.0, 7.0, None, None)]);
    let c = oro::critical_points(&g, SEA).unwrap();
    assert_eq!(c.pits, vec![(3, 2)]);
}

#[test]
fn sea_level_with_negative_heights() {
    // Interior cells do not touch the edge; the sea enters through the -3 ring:
    // the island top at 4 meets it at -3 (its land first touches the edge
    // there), so its prominence is 4 - (-3) = 7, not 4; the peak at 2 keeps
    // its real col at -1.
    let g = grid(
        5,
        &[
            &[-3.0, -3.0, -3.0, -3.0, -3.0],
            &[-3.0, 4.0, -1.0, 2.0, -3.0],
            &[-3.0, -3.0, -3.0, -3.0, -3.0],
        ],
    );
    let t = oro::divide_tree(&g, SEA).unwrap();
    assert_eq!(
        summary(&t),
        vec![
            (1, 1, 4.0, 7.0, None, None),
            (3, 1, 2.0, 3.0, Some(-1.0), Some(0))
        ]
    );
    // Nodata cuts the ridge: two islands.
    let g = grid(5, &[&[1.0, 4.0, f32::NAN, 2.0, 1.0]]);
    let t = oro::divide_tree(&g, SEA).unwrap();
    assert_eq!(
        summary(&t),
        vec![(1, 0, 4.0, 4.0, None, None), (3, 0, 2.0, 2.0, None, None)]
    );
    let t = oro::divide_tree(&g, UNK).unwrap();
    assert_eq!(
        summary(&t),
        vec![(1, 0, 4.0, 3.0, None, None), (3, 0, 2.0, 1.0, None, None)]
    );
}

#[test]
fn infinite_elevation_is_an_error() {
    let g = grid(3, &[&[1.0, f32::INFINITY, 1.0]]);
    let e = oro::divide_tree(&g, SEA).unwrap_err().to_string();
    assert!(e.contains("(1, 0)") && e.contains("finite"), "{e}");
    let p = oro::peaks(
        &Grid::new(2, 2, 1.0f32),
        &GeoRef::pixel(),
        &PeakOptions {
            min_prominence: f64::NAN,
            ..Default::default()
        },
    );
    assert!(p.is_err());
}

fn hand_tree() -> DivideTree {
    let pk = |col, elevation, prominence, key_saddle, parent| Peak {
        col,
        row: 0,
        elevation,
        prominence,
        key_saddle,
        parent,
        on_edge: false,
        isolation: None,
    };
    let sd = |col, elevation| Saddle {
        col,
        row: 0,
        elevation,
    };
    DivideTree {
        width: 10,
        height: 1,
        convention: SEA,
        peaks: vec![
            pk(0, 100.0, 100.0, None, None),
            pk(5, 60.0, 10.0, Some(0), Some(0)),
            pk(8, 55.0, 50.0, Some(1), Some(1)),
        ],
        saddles: vec![sd(3, 50.0), sd(7, 5.0)],
    }
}

#[test]
fn pruning_relinks_an_edited_tree() {
    let t = hand_tree();
    t.validate().unwrap();
    let p = t.pruned(30.0);
    assert_eq!(p.peaks.len(), 2);
    assert_eq!(
        (p.peaks[1].col, p.peaks[1].parent, p.peaks[1].key_saddle),
        (8, Some(0), Some(0))
    );
    assert_eq!(
        p.saddles,
        vec![Saddle {
            col: 7,
            row: 0,
            elevation: 5.0
        }]
    );
    p.validate().unwrap();
    // Cycles and dangling indices are rejected.
    let mut c = t.clone();
    c.peaks[0].parent = Some(2);
    assert!(c.validate().is_err());
    let mut d = t.clone();
    d.peaks[2].key_saddle = Some(9);
    assert!(d.validate().is_err());
}

#[test]
fn writers_and_json_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    // 0.5-degree cells from (10 E, 50 N): cell (c, r) centre = (10.25 + c/2, 49.75 - r/2).
    let geo = GeoRef::north_up(10.0, 50.0, 0.5, Crs::wgs84());
    let g = grid(5, &[&[1.0, 5.0, 2.0, 6.0, 1.0]]);
    let l = oro::peaks(
        &g,
        &geo,
        &PeakOptions {
            min_prominence: 1.0,
            ..Default::default()
        },
    )
    .unwrap();
    let csv = dir.path().join("peaks.csv");
    oro::write_peaks_csv(&csv, &l.tree, &geo).unwrap();
    let text = std::fs::read_to_string(&csv).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert!(lines[0].starts_with("lat,lon,elevation,prominence,saddle_lat,saddle_lon,saddle_elevation,isolation_km,dominance"));
    assert_eq!(lines.len(), 3);
    assert!(
        lines[1].starts_with("49.75,11.75,6,6,,,,,1,3,0,"),
        "{}",
        lines[1]
    );
    let f: Vec<&str> = lines[2].split(',').collect();
    assert_eq!(
        &f[..7],
        &["49.75", "10.75", "5", "3", "49.75", "11.25", "2"]
    );
    // Isolation of the 5 m peak: the 6 m cell one degree of longitude east at 49.75 N.
    let want = 2.0
        * 6_371_008.8
        * (49.75f64.to_radians().cos() * (1.0f64.to_radians() / 2.0).sin()).asin();
    assert!((f[7].parse::<f64>().unwrap() - want / 1000.0).abs() < 1e-9);
    assert!((f[8].parse::<f64>().unwrap() - 0.6).abs() < 1e-12);
    assert_eq!(f[11], "0");

    let pj = dir.path().join("peaks.geojson");
    let sj = dir.path().join("saddles.geojson");
    let tj = dir.path().join("divide_tree.geojson");
    // Geographic: lon/lat as they are in either mode (RFC 7946).
    let gj = orogen::io::geojson::GeoJsonCrs::Wgs84
        .coords(&geo, std::path::Path::new("geo.tif"))
        .unwrap();
    oro::write_peaks_geojson(&pj, &l.tree, &geo, &gj).unwrap();
    oro::write_saddles_geojson(&sj, &l.tree, &gj).unwrap();
    oro::write_divide_tree_geojson(&tj, &l.tree, &gj).unwrap();
    let read = |p: &std::path::Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
    };
    let pv = read(&pj);
    assert_eq!(pv["features"].as_array().unwrap().len(), 2);
    assert_eq!(
        pv["features"][0]["geometry"]["coordinates"],
        serde_json::json!([11.75, 49.75])
    );
    assert_eq!(
        pv["features"][1]["properties"]["prominence"],
        serde_json::json!(3.0)
    );
    let sv = read(&sj);
    assert_eq!(sv["features"].as_array().unwrap().len(), 1);
    assert_eq!(
        sv["features"][0]["geometry"]["coordinates"],
        serde_json::json!([11.25, 49.75])
    );
    let tv = read(&tj);
    assert_eq!(
        tv["features"][0]["geometry"]["coordinates"],
        serde_json::json!([[10.75, 49.75], [11.25, 49.75], [11.75, 49.75]])
    );

    let js = dir.path().join("tree.json");
    l.tree.save_json(&js).unwrap();
    assert_eq!(DivideTree::load_json(&js).unwrap(), l.tree);
    // Garbage and inconsistent trees are typed errors naming the file.
    std::fs::write(&js, b"{\"width\": 3, \"peaks\": [").unwrap();
    let e = DivideTree::load_json(&js).unwrap_err().to_string();
    assert!(e.contains("tree.json"), "{e}");
    let mut bad = hand_tree();
    bad.peaks[1].parent = Some(7);
    std::fs::write(&js, bad.to_json()).unwrap();
    assert!(DivideTree::load_json(&js)
        .unwrap_err()
        .to_string()
        .contains("tree.json"));
    // Everything at once, into a new directory.
    let out = dir.path().join("out");
    let files = l.write_all(&out, &gj).unwrap();
    assert_eq!(files.len(), 5);
    assert_eq!(std::fs::read_to_string(&files[0]).unwrap(), text);
    assert_eq!(DivideTree::load_json(&files[4]).unwrap(), l.tree);
    // Projected CRS: x/y columns.
    let utm = GeoRef::north_up(500000.0, 4000000.0, 30.0, Crs::projected(32611));
    oro::write_peaks_csv(&csv, &l.tree, &utm).unwrap();
    assert!(std::fs::read_to_string(&csv).unwrap().starts_with("y,x,"));
}
