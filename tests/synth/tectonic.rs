//! Tectonic folds (orogen::synth::tectonic): plate merging on a hand-made
//! peak set (velocities computed by hand), tiles equal the whole raster for
//! every layer, peaks of the sample map lie near generated crests, bad maps
//! give clear errors, and the CLI writes the intermediates deterministically.

use crate::oro_common::assert_windows_equal_whole;
use orogen::raster::{read_window, GeoRef, Grid, Window};
use orogen::synth::tectonic::{
    map_to_pixels, TectonicLayer, TectonicModel, TectonicParams, TectonicSource,
};
use orogen::synth::vector::{MapPeak, VectorMap};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Arc;

fn peaks_map(pts: &[[f64; 2]]) -> VectorMap {
    VectorMap {
        peaks: pts
            .iter()
            .map(|&pos| MapPeak {
                pos,
                elevation: None,
            })
            .collect(),
        path: PathBuf::from("hand.geojson"),
        ..Default::default()
    }
}

fn params(t1: f64, t2: f64, coarse: usize) -> TectonicParams {
    TectonicParams {
        t1,
        t2,
        coarse,
        ..Default::default()
    }
}

#[test]
fn plate_merging_follows_the_rules_on_a_hand_made_peak_set() {
    // 400 x 200 raster, coarse grid = the raster (k = 1). Two peaks on the
    // middle row at x = 50 and 250: the Voronoi boundary is x = 150, plate A
    // covers columns 0..150 (centre of mass x = 75), B 150..400 (x = 275):
    // both velocities are (50 - 75, 0) = (250 - 275, 0) = (-25, 0).
    let map = peaks_map(&[[50.0, 100.0], [250.0, 100.0]]);
    // Area ratio 150/250 = 0.6: merged when T2 <= 0.6.
    let m = TectonicModel::new(&map, 400, 200, 30.0, params(0.8, 0.5, 400)).unwrap();
    assert_eq!(m.plate_of_peaks(), &[0, 0]);
    let v = m.plate_velocities()[0];
    assert!((v[0] + 25.0).abs() < 1e-9 && v[1].abs() < 1e-9, "{v:?}");
    let m = TectonicModel::new(&map, 400, 200, 30.0, params(0.8, 0.7, 400)).unwrap();
    assert_eq!(m.plate_of_peaks(), &[0, 1]);
    for v in m.plate_velocities() {
        assert!((v[0] + 25.0).abs() < 1e-9 && v[1].abs() < 1e-9, "{v:?}");
    }
    // Plate labels on the raster: the boundary falls between columns 149 and 150.
    let src = TectonicSource::new(Arc::new(m), TectonicLayer::Plates, GeoRef::pixel());
    let g: Grid<i32> = read_window(&src, Window::new(140, 0, 20, 200)).unwrap();
    for y in 0..200 {
        for x in 0..20 {
            assert_eq!(g.get(x, y), if x + 140 < 150 { 0 } else { 1 });
        }
    }

    // Three peaks at x = 50, 250, 380: A = [0, 150) moves west (-25), B =
    // [150, 315) east (250 - 232.5 = 17.5), C = [315, 400) east (380 - 357.5
    // = 22.5). A and B are opposed (dot -1): never merged. B and C agree
    // (dot 1), area ratio 85/165 = 0.515.
    let map = peaks_map(&[[50.0, 100.0], [250.0, 100.0], [380.0, 100.0]]);
    let m = TectonicModel::new(&map, 400, 200, 30.0, params(0.8, 0.5, 400)).unwrap();
    assert_eq!(m.plate_of_peaks(), &[0, 1, 1]);
    let v = m.plate_velocities();
    assert!((v[0][0] + 25.0).abs() < 1e-9);
    // Area-weighted: (165 * 17.5 + 85 * 22.5) / 250 = 19.2.
    assert!((v[1][0] - 19.2).abs() < 1e-9, "{v:?}");
    let m = TectonicModel::new(&map, 400, 200, 30.0, params(0.8, 0.6, 400)).unwrap();
    assert_eq!(m.plate_of_peaks(), &[0, 1, 2]);
    // T1 = -1 accepts opposed plates too: everything merges when T2 allows.
    let m = TectonicModel::new(&map, 400, 200, 30.0, params(-1.0, 0.0, 400)).unwrap();
    assert_eq!(m.plate_of_peaks(), &[0, 0, 0]);
}

/// The sample map on a grid of `cell` metres, as the CLI derives it (5 % margin).
fn sample(cell: f64) -> (VectorMap, usize, usize, GeoRef) {
    let map = VectorMap::read(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/configs/tectonic-map.geojson"
    )))
    .unwrap();
    let b = map.bbox().unwrap();
    let m = 0.05 * (b[2] - b[0]).max(b[3] - b[1]);
    let (x0, y0) = (b[0] - m, b[3] + m);
    let w = ((b[2] + m - x0) / cell).ceil() as usize;
    let h = ((y0 - (b[1] - m)) / cell).ceil() as usize;
    let g = GeoRef::north_up(x0, y0, cell, Default::default());
    let px = map_to_pixels(&map, &g).unwrap();
    (px, w, h, g)
}

fn sample_params(cell: f64) -> TectonicParams {
    // The CLI's defaults are in 30 m cells; keep the same ground lengths.
    let s = 30.0 / cell;
    let mut p = TectonicParams::default();
    p.blur *= s;
    p.peak_radius *= s;
    p.river_width *= s;
    p.fbm.wavelength *= s;
    p
}

#[test]
fn every_layer_is_tileable() {
    let (map, w, h, g) = sample(150.0);
    let model = Arc::new(TectonicModel::new(&map, w, h, 150.0, sample_params(150.0)).unwrap());
    for layer in [
        TectonicLayer::Terrain,
        TectonicLayer::Plates,
        TectonicLayer::VelocityMagnitude,
        TectonicLayer::VelocityDirection,
        TectonicLayer::Folds,
        TectonicLayer::Watershed,
    ] {
        let src = TectonicSource::new(model.clone(), layer, g.clone());
        let all: Grid<f64> = read_window(&src, Window::new(0, 0, w, h)).unwrap();
        assert_windows_equal_whole(&src, &all, &[13, 50, 77], &format!("{layer:?}"));
    }
}

#[test]
fn peaks_lie_near_generated_crests() {
    let cell = 60.0;
    let (map, w, h, g) = sample(cell);
    let model = Arc::new(TectonicModel::new(&map, w, h, cell, sample_params(cell)).unwrap());
    let src = TectonicSource::new(model, TectonicLayer::Terrain, g);
    let z: Grid<f32> = read_window(&src, Window::new(0, 0, w, h)).unwrap();
    // Crest cells: strictly higher than both neighbours along at least two
    // of the four axes.
    let mut crest = Vec::new();
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let c = z.get(x, y);
            let axes = [(1i64, 0i64), (0, 1), (1, 1), (1, -1)];
            let n = axes
                .iter()
                .filter(|(dx, dy)| {
                    let a = z.get((x as i64 + dx) as usize, (y as i64 + dy) as usize);
                    let b = z.get((x as i64 - dx) as usize, (y as i64 - dy) as usize);
                    c > a && c > b
                })
                .count();
            if n >= 2 && c > 0.0 {
                crest.push([x as f64 + 0.5, y as f64 + 0.5]);
            }
        }
    }
    let nearest = |q: [f64; 2]| {
        crest
            .iter()
            .map(|p| ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt())
            .fold(f64::INFINITY, f64::min)
    };
    let mut d: Vec<f64> = map.peaks.iter().map(|p| nearest(p.pos) * cell).collect();
    // Baseline: land points on a regular lattice.
    let mut base = Vec::new();
    for y in (5..h).step_by(9) {
        for x in (5..w).step_by(9) {
            if z.get(x, y) > 0.0 {
                base.push(nearest([x as f64 + 0.5, y as f64 + 0.5]) * cell);
            }
        }
    }
    d.sort_by(f64::total_cmp);
    base.sort_by(f64::total_cmp);
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let (dm, bm) = (mean(&d), mean(&base));
    eprintln!(
        "peak to crest distance (m): min {:.0}, median {:.0}, mean {dm:.0}, max {:.0}; land lattice points: median {:.0}, mean {bm:.0} ({} peaks, {} points, {} crest cells)",
        d[0],
        d[d.len() / 2],
        d[d.len() - 1],
        base[base.len() / 2],
        d.len(),
        base.len(),
        crest.len()
    );
    // Peaks sit on or next to crests: median within two cells, every peak
    // within 500 m, and much closer than arbitrary land points.
    assert!(d[d.len() / 2] <= 2.0 * cell, "median {}", d[d.len() / 2]);
    assert!(d[d.len() - 1] <= 500.0, "max {}", d[d.len() - 1]);
    assert!(dm < 0.5 * bm, "peaks {dm} vs land {bm}");
}

#[test]
fn bad_maps_give_clear_errors() {
    let p = Path::new("bad.geojson");
    let e = VectorMap::parse("{\"type\": \"FeatureCollection\", \"features\": [", p)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("bad.geojson") && e.contains("not valid JSON"),
        "{e}"
    );
    let e = VectorMap::parse("[1, 2]", p).unwrap_err().to_string();
    assert!(e.contains("FeatureCollection"), "{e}");
    // No peaks.
    let m = VectorMap::parse(
        r#"{"type":"FeatureCollection","features":[{"type":"Feature","properties":{},"geometry":{"type":"LineString","coordinates":[[1,1],[50,50]]}}]}"#,
        p,
    )
    .unwrap();
    let e = TectonicModel::new(&m, 100, 100, 30.0, TectonicParams::default())
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("no peaks"), "{e}");
    // A peak outside the raster.
    let m = peaks_map(&[[10.0, 10.0], [120.0, 50.0]]);
    let e = TectonicModel::new(&m, 100, 100, 30.0, TectonicParams::default())
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("peak 1") && e.contains("outside"), "{e}");
    // A self-intersecting coastline (a figure of eight).
    let e = VectorMap::parse(
        r#"{"type":"FeatureCollection","features":[{"type":"Feature","properties":{"kind":"coast"},"geometry":{"type":"Polygon","coordinates":[[[0,0],[40,40],[80,0],[80,40],[40,0],[0,40],[0,0]]]}}]}"#,
        p,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("coastline 0 crosses itself"), "{e}");
    // Coastlines that enclose no land inside the raster.
    let mut m = peaks_map(&[[10.0, 10.0]]);
    m.coasts = vec![vec![[500.0, 500.0], [600.0, 500.0], [600.0, 600.0]]];
    let e = TectonicModel::new(&m, 100, 100, 30.0, TectonicParams::default())
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("no land"), "{e}");
    // Absurd sizes: refused beyond 2^31 cells a side; at 2^31 the global
    // part stays coarse (built without allocating per output cell).
    let mut m = peaks_map(&[[10.0, 10.0]]);
    assert!(TectonicModel::new(&m, (1 << 31) + 1, 10, 30.0, TectonicParams::default()).is_err());
    m.rivers = vec![vec![[0.0, 0.0], [1e9, 1e9]]];
    let big = TectonicModel::new(&m, 1 << 31, 1 << 31, 30.0, TectonicParams::default()).unwrap();
    assert_eq!(big.size(), (1 << 31, 1 << 31));
    // Bad parameters.
    let m = peaks_map(&[[10.0, 10.0]]);
    assert!(TectonicModel::new(&m, 100, 100, 30.0, params(2.0, 0.1, 512)).is_err());
    assert!(TectonicModel::new(&m, 100, 100, 30.0, params(0.5, f64::NAN, 512)).is_err());
}

#[test]
fn cli_writes_intermediates_deterministically() {
    let dir = tempfile::tempdir().unwrap();
    let exe = env!("CARGO_BIN_EXE_orogen");
    let map = concat!(env!("CARGO_MANIFEST_DIR"), "/configs/tectonic-map.geojson");
    let run = |name: &str, extra: &[&str]| {
        let out = dir.path().join(name);
        let o = Command::new(exe)
            .args([
                "synth", "tectonic", "--map", map, "--cell", "150", "-q", "-o",
            ])
            .arg(&out)
            .args(extra)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        std::fs::read(out).unwrap()
    };
    let inter = dir.path().join("inter");
    let pv = dir.path().join("t.png");
    let a = run(
        "a.tif",
        &[
            "--threads",
            "1",
            "--tile",
            "64",
            "--intermediates",
            inter.to_str().unwrap(),
            "--preview",
            pv.to_str().unwrap(),
        ],
    );
    let b = run("b.tif", &["--threads", "2", "--tile", "100"]);
    assert_eq!(a, b);
    // The terrain preview: one pixel per cell (plus a legend), the open sea
    // (3x3 at the deepest level: flat, unshaded) in one bluish colour, low
    // land greener than high land (hypsometric tint).
    {
        let t = orogen::io::open_raster(&dir.path().join("a.tif"), &Default::default()).unwrap();
        let (w, h) = (t.info().width, t.info().height);
        let z: Grid<f32> = read_window(t.as_ref(), Window::new(0, 0, w, h)).unwrap();
        let d = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&pv).unwrap()));
        let mut r = d.read_info().unwrap();
        let mut px = vec![0; r.output_buffer_size().unwrap()];
        let info = r.next_frame(&mut px).unwrap();
        assert_eq!(info.color_type, png::ColorType::Rgba);
        assert_eq!(info.width as usize, w);
        assert!(info.height as usize > h, "no legend");
        let c = |x: usize, y: usize| {
            let i = (y * w + x) * 4;
            [px[i], px[i + 1], px[i + 2]]
        };
        let deep = z.data().iter().copied().fold(f32::INFINITY, f32::min);
        assert!(deep < 0.0, "no sea");
        let mut sea = None;
        let mut land = Vec::new();
        for y in 1..h - 1 {
            for x in 1..w - 1 {
                if (y - 1..=y + 1).all(|yy| (x - 1..=x + 1).all(|xx| z.get(xx, yy) == deep)) {
                    assert_eq!(*sea.get_or_insert(c(x, y)), c(x, y), "open sea ({x}, {y})");
                } else if z.get(x, y) > 0.0 {
                    land.push((z.get(x, y), x, y));
                }
            }
        }
        let sea = sea.expect("no open sea");
        assert!(sea[2] > sea[0] && sea[2] > sea[1], "sea {sea:?} not blue");
        land.sort_by(|a, b| a.0.total_cmp(&b.0));
        let green = |ks: &[(f32, usize, usize)]| {
            ks.iter()
                .map(|&(_, x, y)| {
                    let p = c(x, y);
                    p[1] as f64 - (p[0] as f64 + p[2] as f64) / 2.0
                })
                .sum::<f64>()
                / ks.len() as f64
        };
        let tenth = land.len() / 10;
        assert!(tenth > 100, "{} land cells", land.len());
        let (low, high) = (green(&land[..tenth]), green(&land[land.len() - tenth..]));
        assert!(
            low > high + 10.0,
            "lowest tenth greenness {low}, highest {high}"
        );
    }
    for n in [
        "plates",
        "velocity_magnitude",
        "velocity_direction",
        "folds",
        "watershed",
    ] {
        assert!(
            inter.join(format!("{n}.tif")).exists() && inter.join(format!("{n}.png")).exists(),
            "{n}"
        );
    }
    // The plates file holds the model's merged plates: labels 0..n, each
    // present, n + 1 the model's plate count, and each cell the label of
    // the plate of its nearest peak (the Voronoi cells of the peaks, found
    // here by brute force; cells within 0.01 cell of a tie left out).
    let plates = orogen::io::open_raster(&inter.join("plates.tif"), &Default::default()).unwrap();
    let i = plates.info().clone();
    let g: Grid<i32> = read_window(plates.as_ref(), Window::new(0, 0, i.width, i.height)).unwrap();
    let (map, w, h, _) = sample(150.0);
    assert_eq!((i.width, i.height), (w, h));
    let model = TectonicModel::new(&map, w, h, 150.0, TectonicParams::default()).unwrap();
    let n = model.plate_velocities().len();
    assert!(
        n >= 2 && n < map.peaks.len(),
        "{n} plates from {} peaks",
        map.peaks.len()
    );
    let mut seen = vec![0usize; n];
    let mut checked = 0;
    for y in 0..h {
        for x in 0..w {
            let v = g.get(x, y);
            assert!(
                v >= 0 && (v as usize) < n,
                "label {v} at ({x}, {y}), {n} plates"
            );
            seen[v as usize] += 1;
            let mut d: Vec<(f64, usize)> = map
                .peaks
                .iter()
                .enumerate()
                .map(|(k, p)| {
                    (
                        (p.pos[0] - x as f64 - 0.5).hypot(p.pos[1] - y as f64 - 0.5),
                        k,
                    )
                })
                .collect();
            d.sort_by(|a, b| a.0.total_cmp(&b.0));
            if d[1].0 - d[0].0 > 0.01 {
                checked += 1;
                assert_eq!(
                    v as u32,
                    model.plate_of_peaks()[d[0].1],
                    "({x}, {y}): nearest peak {}",
                    d[0].1
                );
            }
        }
    }
    assert!(
        seen.iter().all(|&c| c > 0),
        "a plate without cells: {seen:?}"
    );
    assert!(checked > w * h * 9 / 10);
    // Its preview (viridis, no shading): one colour per plate, different
    // plates in different colours, lighter for higher labels (viridis runs
    // from dark purple to yellow).
    let png_px = |name: &str| {
        let d = png::Decoder::new(std::io::BufReader::new(
            std::fs::File::open(inter.join(name)).unwrap(),
        ));
        let mut r = d.read_info().unwrap();
        let mut buf = vec![0; r.output_buffer_size().unwrap()];
        let info = r.next_frame(&mut buf).unwrap();
        assert_eq!(info.color_type, png::ColorType::Rgba);
        assert_eq!(info.width as usize, w, "{name}");
        assert!(info.height as usize >= h, "{name}");
        buf
    };
    let px = png_px("plates.png");
    let mut colour = vec![None; n];
    for k in 0..w * h {
        let c = [px[4 * k], px[4 * k + 1], px[4 * k + 2], px[4 * k + 3]];
        assert_eq!(c[3], 255);
        let l = g.data()[k] as usize;
        assert_eq!(*colour[l].get_or_insert(c), c, "plate {l} in two colours");
    }
    let lum = |c: [u8; 4]| 0.2126 * c[0] as f64 + 0.7152 * c[1] as f64 + 0.0722 * c[2] as f64;
    for l in 1..n {
        let (a, b) = (colour[l - 1].unwrap(), colour[l].unwrap());
        assert!(
            lum(a) < lum(b),
            "plate {} {a:?} not darker than plate {l} {b:?}",
            l - 1
        );
    }
    // The velocity magnitude in grey: R = G = B, never darker for a faster
    // cell, black at the slowest and white at the fastest.
    let vm = orogen::io::open_raster(&inter.join("velocity_magnitude.tif"), &Default::default())
        .unwrap();
    let v: Grid<f32> = read_window(vm.as_ref(), Window::new(0, 0, w, h)).unwrap();
    let px = png_px("velocity_magnitude.png");
    let mut cells: Vec<(f32, u8)> = (0..w * h)
        .map(|k| {
            assert!(
                px[4 * k] == px[4 * k + 1] && px[4 * k] == px[4 * k + 2],
                "not grey"
            );
            (v.data()[k], px[4 * k])
        })
        .collect();
    cells.sort_by(|a, b| a.0.total_cmp(&b.0));
    assert!(
        cells.windows(2).all(|p| p[0].1 <= p[1].1),
        "grey not monotone in the speed"
    );
    assert!(
        cells[0].1 <= 1 && cells[w * h - 1].1 >= 254,
        "{:?} {:?}",
        cells[0],
        cells[w * h - 1]
    );

    // A map with a peak outside the given domain: non-zero exit, one clear line.
    let bad = dir.path().join("bad.geojson");
    std::fs::write(&bad, r#"{"type":"FeatureCollection","features":[{"type":"Feature","properties":{},"geometry":{"type":"Point","coordinates":[5000,5000]}}]}"#).unwrap();
    let o = Command::new(exe)
        .args(["synth", "tectonic", "--map"])
        .arg(&bad)
        .args(["--origin", "0,3000", "--size", "100x100", "-o"])
        .arg(dir.path().join("x.tif"))
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("bad.geojson") && err.contains("outside"),
        "{err}"
    );
    assert!(!dir.path().join("x.tif").exists());
}
