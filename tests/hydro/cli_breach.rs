//! `orogen breach` and `orogen flow --method rho8` as a user runs them:
//! outputs equal the library's in-memory results for any tile size, bad
//! options are clear errors, no temporary files are left behind.

use orogen::hydro::{breach, rho8_directions, BreachMethod, BreachOptions};
use orogen::io::{open_raster, OpenOptions};
use orogen::raster::{read_window, Grid, Window};
use std::path::{Path, PathBuf};
use std::process::Command;

fn orogen() -> Command {
    Command::new(env!("CARGO_BIN_EXE_orogen"))
}

fn data(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(p)
}

fn run(cmd: &mut Command, want_ok: bool) -> String {
    let o = cmd.output().expect("runs");
    let err = String::from_utf8_lossy(&o.stderr).to_string();
    assert_eq!(o.status.success(), want_ok, "{err}");
    err
}

fn read<T: orogen::raster::Cell>(p: &Path) -> Grid<T> {
    let src = open_raster(p, &OpenOptions::default()).unwrap();
    let (w, h) = (src.info().width, src.info().height);
    read_window::<T>(src.as_ref(), Window::full(w, h)).unwrap()
}

fn same(a: &Grid<f32>, b: &Grid<f32>) -> bool {
    a.width() == b.width()
        && a.data()
            .iter()
            .zip(b.data())
            .all(|(x, y)| x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()))
}

#[test]
fn breach_outputs_equal_the_library_for_any_tile_size() {
    let dir = tempfile::tempdir().unwrap();
    let dem_path = data("bigtujunga_crop.tif");
    let dem = read::<f32>(&dem_path);
    let cases: Vec<(Vec<&str>, BreachOptions)> = vec![
        (
            vec![],
            BreachOptions {
                method: BreachMethod::Breach,
                ..Default::default()
            },
        ),
        (
            vec![
                "--method",
                "hybrid",
                "--max-depth",
                "3",
                "--max-length",
                "10",
            ],
            BreachOptions {
                method: BreachMethod::Hybrid {
                    max_depth: 3.0,
                    max_length: 10,
                },
                ..Default::default()
            },
        ),
        (
            vec!["--method", "least-cost", "--dist", "8"],
            BreachOptions {
                method: BreachMethod::LeastCost { dist: 8 },
                ..Default::default()
            },
        ),
        (
            vec!["--method", "least-cost", "--dist", "4", "--fill-remaining"],
            BreachOptions {
                method: BreachMethod::LeastCost { dist: 4 },
                fill_remaining: true,
                ..Default::default()
            },
        ),
    ];
    for (k, (args, opts)) in cases.iter().enumerate() {
        let want = breach(&dem, opts).unwrap();
        for tile in ["37", "100", "4096"] {
            for ext in ["tif", "tiles"] {
                let out = dir.path().join(format!("b{k}_{tile}.{ext}"));
                run(
                    orogen()
                        .arg("breach")
                        .arg(&dem_path)
                        .args(args)
                        .args(["-q", "--tile", tile, "--store-tile", tile, "-o"])
                        .arg(&out),
                    true,
                );
                let got = read::<f32>(&out);
                assert!(same(&got, &want), "case {k} tile {tile} {ext}");
            }
        }
    }
    // no temporary folders left beside the outputs
    for e in std::fs::read_dir(dir.path()).unwrap() {
        let n = e.unwrap().file_name().to_string_lossy().to_string();
        assert!(!n.contains("breach-tmp"), "{n} left behind");
    }
}

#[test]
fn rho8_flow_equals_the_library_for_any_tile_size() {
    let dir = tempfile::tempdir().unwrap();
    let dem_path = data("bigtujunga_crop.tif");
    let filled = dir.path().join("filled.tif");
    run(
        orogen()
            .arg("fill")
            .arg(&dem_path)
            .args(["-q", "-o"])
            .arg(&filled),
        true,
    );
    let want = rho8_directions(&read::<f32>(&filled), 9);
    for tile in ["37", "4096"] {
        let out = dir.path().join(format!("rho8_{tile}.tif"));
        run(
            orogen()
                .arg("flow")
                .arg(&filled)
                .args([
                    "-q", "--method", "rho8", "--seed", "9", "--tile", tile, "-o",
                ])
                .arg(&out),
            true,
        );
        let got = read::<u8>(&out);
        assert_eq!(got.data(), want.data(), "tile {tile}");
    }
}

#[test]
fn bad_breach_options_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let dem_path = data("bigtujunga_crop.tif");
    let out = dir.path().join("x.tif");
    for (args, says) in [
        (vec!["--method", "hybrid"], "--max-depth"),
        (vec!["--method", "least-cost", "--dist", "0"], "distance"),
        (vec!["--max-depth", "2"], "hybrid only"),
        (vec!["--fill-remaining"], "least-cost only"),
        (vec!["--method", "hybrid", "--max-depth=-1"], "max depth"),
        (
            vec!["--method", "hybrid", "--max-depth", "NaN"],
            "max depth",
        ),
    ] {
        let e = run(
            orogen()
                .arg("breach")
                .arg(&dem_path)
                .args(&args)
                .arg("-o")
                .arg(&out),
            false,
        );
        assert!(e.contains(says), "{args:?}: {e}");
    }
    let e = run(
        orogen()
            .arg("breach")
            .arg(&dem_path)
            .args([
                "--method",
                "least-cost",
                "--dist",
                "5000",
                "--memory",
                "64MiB",
                "-o",
            ])
            .arg(&out),
        false,
    );
    assert!(e.contains("lower --dist"), "{e}");
    let e = run(
        orogen()
            .arg("flow")
            .arg(&dem_path)
            .args(["--method", "rho9", "-o"])
            .arg(&out),
        false,
    );
    assert!(e.contains("rho8"), "{e}");
    let e = run(
        orogen()
            .arg("breach")
            .arg(&dem_path)
            .args(["--memory", "16MiB", "-o"])
            .arg(&out),
        true,
    );
    assert!(e.is_empty() || !e.contains("error"), "{e}");
    assert!(!out.with_extension("tif.breach-tmp").exists());
}
