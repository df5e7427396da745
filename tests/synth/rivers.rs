//! River-network terrain (orogen::synth::rivers): tiles equal the whole
//! raster bit for bit, every land cell drains to the sea (checked with the
//! Priority-Flood fill and by a direct neighbour scan), the river graph is a
//! forest of trees rooted in the sea with heights rising upstream, and the
//! CLI output does not depend on the thread count or work-tile size.

use crate::oro_common::assert_windows_equal_whole;
use orogen::raster::{read_window, Grid, RasterSource, Window};
use orogen::synth::rivers::{LandMask, RiverNetwork, RiverParams, RiverTerrain, NO_PARENT};
use std::path::Path;
use std::process::Command;

fn terrain(w: usize, h: usize, seed: u64, radius: f64, mask: Option<LandMask>) -> RiverTerrain {
    let mut p = RiverParams {
        seed,
        radius,
        ..Default::default()
    };
    if let Some(m) = mask {
        p.mask = m;
    }
    if let LandMask::Noise { fbm, .. } = &mut p.mask {
        fbm.seed = seed;
        fbm.wavelength = w.max(h) as f64 / 2.0;
    }
    let net = RiverNetwork::build(w, h, 30.0, &p).unwrap();
    RiverTerrain::new(net, w, h, 30.0, radius, p.sea_depth, None).unwrap()
}

fn whole(src: &dyn RasterSource) -> Grid<f32> {
    let i = src.info();
    read_window(src, Window::new(0, 0, i.width, i.height)).unwrap()
}

#[test]
fn tiles_equal_whole_bit_for_bit() {
    let t = terrain(203, 171, 5, 5.0, None);
    let g = whole(&t);
    assert_windows_equal_whole(&t, &g, &[17, 64, 100], "rivers");
}

/// Checks that every land cell drains: the fill raises nothing and every
/// land cell has a strictly lower 8-neighbour. Returns (land, sea) counts.
fn check_drainage(t: &RiverTerrain) -> (usize, usize) {
    let g = whole(t);
    let (w, h) = (g.width(), g.height());
    let filled = orogen::hydro::fill(&g).unwrap();
    let mut raised = 0;
    let (mut land, mut sea) = (0, 0);
    for y in 0..h {
        for x in 0..w {
            let v = g.get(x, y);
            assert!(v.is_finite());
            if filled.get(x, y) != v {
                raised += 1;
            }
            if t.is_sea(x, y) {
                sea += 1;
                continue;
            }
            land += 1;
            let mut lower = false;
            for dy in -1i64..=1 {
                for dx in -1i64..=1 {
                    let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                    if (dx, dy) != (0, 0)
                        && nx >= 0
                        && ny >= 0
                        && nx < w as i64
                        && ny < h as i64
                        && g.get(nx as usize, ny as usize) < v
                    {
                        lower = true;
                    }
                }
            }
            assert!(lower, "land cell ({x}, {y}) at {v} has no lower neighbour");
        }
    }
    assert_eq!(raised, 0, "the fill raised {raised} cells");
    (land, sea)
}

#[test]
fn every_land_cell_drains_to_the_sea() {
    for (seed, r, w, h) in [
        (1u64, 4.0, 160usize, 140usize),
        (2, 6.0, 257, 190),
        (9, 2.5, 120, 120),
    ] {
        let t = terrain(w, h, seed, r, None);
        let (land, sea) = check_drainage(&t);
        assert!(
            land > w * h / 5 && sea > 0,
            "seed {seed}: land {land}, sea {sea}"
        );
    }
}

#[test]
fn polygon_mask_drains_and_respects_the_coast() {
    // A concave island (an L shape) in pixel coordinates.
    let ring = vec![
        [20.0, 20.0],
        [180.0, 20.0],
        [180.0, 70.0],
        [90.0, 70.0],
        [90.0, 150.0],
        [20.0, 150.0],
    ];
    let t = terrain(200, 170, 4, 5.0, Some(LandMask::Rings(vec![ring.clone()])));
    let (land, _) = check_drainage(&t);
    // Land ≈ the polygon's area (15 200 cells) to within the node spacing.
    assert!((12_000..18_500).contains(&land), "land {land}");
    // Cells well inside are land, cells well outside are sea.
    assert!(!t.is_sea(50, 100) && !t.is_sea(150, 40));
    assert!(t.is_sea(150, 130) && t.is_sea(5, 5));
}

#[test]
fn river_graph_is_a_forest_draining_to_the_sea() {
    let t = terrain(300, 220, 11, 6.0, None);
    let net = t.network();
    let n = net.nodes.len();
    let mut mouths = 0;
    for v in 0..n {
        if net.sea[v] {
            assert_eq!(net.parent[v], NO_PARENT);
            continue;
        }
        let u = net.parent[v] as usize;
        assert!(u < n);
        // The downstream node is a Delaunay neighbour, lower, and (when land)
        // drains more area: rivers never split downstream.
        assert!(net.neighbours[v].contains(&(u as u32)));
        assert!(net.height[v] > net.height[u]);
        assert!(net.height[v] > 0.0);
        if net.sea[u] {
            mouths += 1;
        } else {
            assert!(net.area[u] > net.area[v]);
        }
        // Following parents reaches the sea without cycles.
        let (mut x, mut steps) = (v, 0);
        while !net.sea[x] {
            x = net.parent[x] as usize;
            steps += 1;
            assert!(steps <= n, "cycle from node {v}");
        }
    }
    assert!(mouths > 0);
    // Drainage area is conserved: the mouths carry all the land.
    let share = net
        .area
        .iter()
        .zip(&net.sea)
        .filter(|(_, &s)| !s)
        .map(|(a, _)| *a)
        .fold(f64::INFINITY, f64::min);
    let land = net.sea.iter().filter(|&&s| !s).count() as f64;
    let at_mouths: f64 = (0..n)
        .filter(|&v| !net.sea[v] && net.sea[net.parent[v] as usize])
        .map(|v| net.area[v])
        .sum();
    assert!(
        (at_mouths / share - land).abs() < 1e-6 * land,
        "{} vs {land}",
        at_mouths / share
    );
}

#[test]
fn bad_parameters_are_errors() {
    let p = RiverParams {
        radius: 1.0,
        ..Default::default()
    };
    assert!(RiverNetwork::build(100, 100, 30.0, &p)
        .unwrap_err()
        .to_string()
        .contains("radius"));
    let p = RiverParams {
        mask: LandMask::Rings(vec![vec![
            [-10.0, -10.0],
            [500.0, -10.0],
            [500.0, 500.0],
            [-10.0, 500.0],
        ]]),
        ..Default::default()
    };
    let e = RiverNetwork::build(100, 100, 30.0, &p)
        .unwrap_err()
        .to_string();
    assert!(e.contains("no sea"), "{e}");
    let p = RiverParams {
        radius: 2.0,
        ..Default::default()
    };
    assert!(RiverNetwork::build(1 << 20, 1 << 20, 30.0, &p)
        .unwrap_err()
        .to_string()
        .contains("too many"));
}

#[test]
fn cli_is_deterministic_across_threads_and_tiles() {
    let dir = tempfile::tempdir().unwrap();
    let exe = env!("CARGO_BIN_EXE_orogen");
    let run = |name: &str, extra: &[&str]| {
        let out = dir.path().join(name);
        let st = Command::new(exe)
            .args([
                "synth", "rivers", "--size", "300x200", "--radius", "6", "--seed", "7", "-q", "-o",
            ])
            .arg(&out)
            .args(extra)
            .status()
            .unwrap();
        assert!(st.success());
        std::fs::read(out).unwrap()
    };
    let a = run("a.tif", &["--threads", "1", "--tile", "64"]);
    let b = run("b.tif", &["--threads", "2", "--tile", "100"]);
    assert_eq!(a, b);
    let net = dir.path().join("net.geojson");
    let pv = dir.path().join("p.png");
    run(
        "c.tif",
        &[
            "--network",
            net.to_str().unwrap(),
            "--preview",
            pv.to_str().unwrap(),
        ],
    );
    check_network_and_preview(&dir.path().join("c.tif"), &net, &pv);
    let o = Command::new(exe)
        .args(["synth", "rivers", "--radius", "0.5", "-o"])
        .arg(dir.path().join("x.tif"))
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("radius"));
}

/// The `--network` GeoJSON of `synth rivers --size 300x200 --radius 6` (30 m
/// cells) against the model's definition (Génevaux et al. 2013 as the module
/// documents it, with the CLI's defaults): one tree edge per land node,
/// linked by end = start of the parent's edge or a mouth into the sea
/// (downstream height −sea_depth = −20 m, rising from sea level); drainage area = the node's share of the raster
/// (54 km² / nodes, the same for every node) plus everything upstream;
/// heights rise upstream by |vp| · clamp(0.05 · A^−0.45, 0.0005, 0.7); the
/// terrain under a node is no higher than the node (its channel cell
/// carries the node's height, the cones only lower it). The `--preview`
/// PNG: one pixel per cell plus a legend, open-sea cells (all 3x3 at the
/// sea floor: flat, unshaded) in one bluish colour, land never in it, low
/// land greener than high land.
fn check_network_and_preview(dem: &Path, net: &Path, pv: &Path) {
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(net).unwrap()).unwrap();
    assert_eq!(v["type"], "FeatureCollection");
    let feats = v["features"].as_array().unwrap();
    assert!(feats.len() > 100, "{} rivers", feats.len());
    struct Edge {
        a: [f64; 2],
        b: [f64; 2],
        node: u64,
        area: f64,
        h: f64,
        hd: f64,
    }
    let edges: Vec<Edge> = feats
        .iter()
        .map(|f| {
            assert_eq!(f["type"], "Feature");
            assert_eq!(f["geometry"]["type"], "LineString");
            let c = f["geometry"]["coordinates"].as_array().unwrap();
            assert_eq!(c.len(), 2, "{f}");
            let pt = |k: usize| [c[k][0].as_f64().unwrap(), c[k][1].as_f64().unwrap()];
            let p = &f["properties"];
            assert_eq!(p["kind"], "river");
            Edge {
                a: pt(0),
                b: pt(1),
                node: p["node"].as_u64().unwrap(),
                area: p["area_km2"].as_f64().unwrap(),
                h: p["height"].as_f64().unwrap(),
                hd: p["downstream_height"].as_f64().unwrap(),
            }
        })
        .collect();
    let mut nodes: Vec<u64> = edges.iter().map(|e| e.node).collect();
    nodes.sort();
    nodes.dedup();
    assert_eq!(nodes.len(), edges.len(), "a node with two edges");
    let by_start: std::collections::HashMap<[u64; 2], usize> = edges
        .iter()
        .enumerate()
        .map(|(i, e)| ([e.a[0].to_bits(), e.a[1].to_bits()], i))
        .collect();
    let share = edges.iter().map(|e| e.area).fold(f64::INFINITY, f64::min);
    let nodes_total = 54.0 / share;
    assert!(
        (nodes_total - nodes_total.round()).abs() < 1e-6,
        "the smallest area {share} km² is not 54 km² / a node count"
    );
    let mut upstream = vec![0.0; edges.len()];
    let mut mouths = 0;
    for e in &edges {
        for p in [e.a, e.b] {
            assert!(
                (0.0..=9000.0).contains(&p[0]) && (0.0..=6000.0).contains(&p[1]),
                "{p:?} outside the raster"
            );
        }
        assert!(e.h > e.hd, "node {} not above its parent", e.node);
        // A mouth rises from sea level (its parent, a sea node, is at 0),
        // though its downstream height is written as the sea floor's.
        let base = match by_start.get(&[e.b[0].to_bits(), e.b[1].to_bits()]) {
            Some(&j) => {
                assert_eq!(e.hd, edges[j].h, "node {}: parent's height", e.node);
                upstream[j] += e.area;
                e.hd
            }
            None => {
                assert_eq!(e.hd, -20.0, "node {}: a mouth flows into the sea", e.node);
                mouths += 1;
                0.0
            }
        };
        let len = (e.a[0] - e.b[0]).hypot(e.a[1] - e.b[1]);
        let s = (0.05 * e.area.powf(-0.45)).clamp(0.0005, 0.7);
        assert!(
            ((e.h - base) - len * s).abs() <= 1e-6 * (1.0 + e.h.abs()),
            "node {}: rise {} over {len} m, Flint's law gives {}",
            e.node,
            e.h - base,
            len * s
        );
    }
    assert!(mouths > 0);
    for (e, up) in edges.iter().zip(&upstream) {
        assert!(
            (e.area - (share + up)).abs() < 1e-9,
            "node {}: area {} ≠ {share} + upstream {up}",
            e.node,
            e.area
        );
    }
    // The terrain under each node.
    let src = orogen::io::open_raster(dem, &Default::default()).unwrap();
    let g: Grid<f32> = read_window(src.as_ref(), Window::new(0, 0, 300, 200)).unwrap();
    let cell = |p: [f64; 2]| ((p[0] / 30.0) as usize, ((6000.0 - p[1]) / 30.0) as usize);
    for e in &edges {
        let (x, y) = cell(e.a);
        let z = g.get(x.min(299), y.min(199)) as f64;
        assert!(
            z <= e.h + 1e-3,
            "node {}: terrain {z} above the node {}",
            e.node,
            e.h
        );
        assert!(z > -20.0, "node {}: a land node on a sea cell", e.node);
    }
    // The preview.
    let d = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(pv).unwrap()));
    let mut r = d.read_info().unwrap();
    let mut buf = vec![0; r.output_buffer_size().unwrap()];
    let info = r.next_frame(&mut buf).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgba);
    assert_eq!(info.width, 300);
    assert!(info.height > 200, "no legend below the 200 rows");
    let px = |x: usize, y: usize| {
        let i = (y * 300 + x) * 4;
        [buf[i], buf[i + 1], buf[i + 2], buf[i + 3]]
    };
    let mut sea = None;
    let (mut nsea, mut land) = (0, std::collections::HashSet::new());
    for y in 0..200 {
        for x in 0..300 {
            let c = px(x, y);
            assert_eq!(c[3], 255, "({x}, {y}) transparent");
            let open_sea = (y.saturating_sub(1)..=(y + 1).min(199)).all(|yy| {
                (x.saturating_sub(1)..=(x + 1).min(299)).all(|xx| g.get(xx, yy) == -20.0)
            });
            if open_sea {
                // Flat, so unshaded: one colour.
                assert_eq!(*sea.get_or_insert(c), c, "sea ({x}, {y}) in another colour");
                nsea += 1;
            } else if g.get(x, y) > -20.0 {
                land.insert(c);
            }
        }
    }
    let sea = sea.expect("no sea cell");
    assert!(
        sea[2] > sea[0] && sea[2] > sea[1],
        "sea colour {sea:?} not blue"
    );
    assert!(!land.contains(&sea), "a land cell in the sea colour");
    assert!(
        nsea > 1000 && land.len() > 100,
        "{nsea} sea cells, {} land colours",
        land.len()
    );
    // The hypsometric tint: the lowest tenth of the land greener than the
    // highest tenth (green lowlands to brown, grey and white heights).
    let mut by_height: Vec<(f32, usize, usize)> = (0..200)
        .flat_map(|y| (0..300).map(move |x| (x, y)))
        .filter(|&(x, y)| g.get(x, y) > 0.0)
        .map(|(x, y)| (g.get(x, y), x, y))
        .collect();
    by_height.sort_by(|a, b| a.0.total_cmp(&b.0));
    let green = |ks: &[(f32, usize, usize)]| {
        ks.iter()
            .map(|&(_, x, y)| {
                let c = px(x, y);
                c[1] as f64 - (c[0] as f64 + c[2] as f64) / 2.0
            })
            .sum::<f64>()
            / ks.len() as f64
    };
    let tenth = by_height.len() / 10;
    let (low, high) = (
        green(&by_height[..tenth]),
        green(&by_height[by_height.len() - tenth..]),
    );
    assert!(
        low > high + 10.0,
        "lowest tenth greenness {low}, highest {high}"
    );
}
