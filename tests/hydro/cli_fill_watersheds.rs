//! `orogen fill-epsilon` and `orogen watersheds` through the built binary,
//! checked against the in-memory library functions on a real DEM.

use orogen::hydro::{d8_directions, fill, fill_epsilon, flow::outlet_labels};
use orogen::io::{open_raster, OpenOptions};
use orogen::raster::{read_window, Grid, Window};
use std::path::Path;
use std::process::Command;

fn orogen(args: &[&str]) {
    let out = Command::new(env!("CARGO_BIN_EXE_orogen"))
        .args(args)
        .output()
        .expect("runs");
    assert!(
        out.status.success(),
        "orogen {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

fn read<T: orogen::raster::Cell>(p: &Path) -> Grid<T> {
    let src = open_raster(p, &OpenOptions::default()).unwrap();
    let i = src.info();
    read_window::<T>(src.as_ref(), Window::new(0, 0, i.width, i.height)).unwrap()
}

#[test]
fn fill_epsilon_and_watersheds_equal_the_library() {
    let dem = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/bigtujunga_crop.tif");
    let d = tempfile::tempdir().unwrap();
    let eps = d.path().join("eps.tif");
    let filled = d.path().join("f.tiles");
    let d8 = d.path().join("d8.tif");
    let ws = d.path().join("ws.tif");
    let s = |p: &Path| p.to_str().unwrap().to_string();
    orogen(&[
        "fill-epsilon",
        &s(&dem),
        "-o",
        &s(&eps),
        "--tile",
        "64",
        "-q",
    ]);
    orogen(&["fill", &s(&dem), "-o", &s(&filled), "--tile", "64", "-q"]);
    orogen(&["flow", &s(&filled), "-o", &s(&d8), "--tile", "64", "-q"]);
    orogen(&["watersheds", &s(&d8), "-o", &s(&ws), "--tile", "37", "-q"]);
    // no temporary store left behind
    let left: Vec<_> = std::fs::read_dir(d.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .filter(|n| n.contains("fill-tmp"))
        .collect();
    assert!(left.is_empty(), "{left:?}");
    let g = read::<f32>(&dem);
    let want = fill_epsilon(&g).unwrap();
    let got = read::<f32>(&eps);
    let bits = |g: &Grid<f32>| -> Vec<u32> {
        g.data()
            .iter()
            .map(|v| if v.is_nan() { 0 } else { v.to_bits() })
            .collect()
    };
    assert_eq!(bits(&got), bits(&want));
    let labels = outlet_labels(&d8_directions(&fill(&g).unwrap())).unwrap();
    assert_eq!(read::<u32>(&ws).data(), labels.data());
}
