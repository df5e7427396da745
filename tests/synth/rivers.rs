//! River-network terrain (orogen::synth::rivers): tiles equal the whole
//! raster bit for bit, every land cell drains to the sea (checked with the
//! Priority-Flood fill and by a direct neighbour scan), the river graph is a
//! forest of trees rooted in the sea with heights rising upstream, and the
//! CLI output does not depend on the thread count or work-tile size.

use crate::oro_common::assert_windows_equal_whole;
use orogen::raster::{read_window, Grid, RasterSource, Window};
use orogen::synth::rivers::{LandMask, RiverNetwork, RiverParams, RiverTerrain, NO_PARENT};
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
    let _ = run(
        "c.tif",
        &[
            "--network",
            net.to_str().unwrap(),
            "--preview",
            pv.to_str().unwrap(),
        ],
    );
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&net).unwrap()).unwrap();
    assert!(!v["features"].as_array().unwrap().is_empty());
    assert!(pv.exists());
    let o = Command::new(exe)
        .args(["synth", "rivers", "--radius", "0.5", "-o"])
        .arg(dir.path().join("x.tif"))
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("radius"));
}
