//! `orogen erode --model stream-power` tiled from the command line: the tiled
//! solve (forced with --tiled, or chosen because the DEM does not fit in
//! --memory, with scratch files) writes the same values as the in-memory run
//! for any tile size and thread count; parameters from a TOML file with flags
//! overriding it; clear errors.

use crate::common::cli::{fails_args as fails, ok_args as ok, read_f32 as read, s, same};
use std::path::{Path, PathBuf};

const DEM: &str = "tests/data/bigtujunga_crop.tif";

/// `erode DEM --model stream-power EXTRA -o OUT`.
fn sp<'a>(extra: &[&'a str], out: &'a Path) -> Vec<&'a str> {
    let mut v = vec!["erode", DEM, "--model", "stream-power"];
    v.extend_from_slice(extra);
    v.extend_from_slice(&["-o", s(out)]);
    v
}

fn erode(dir: &Path, name: &str, extra: &[&str]) -> (PathBuf, String) {
    let out = dir.join(name);
    let mut args = vec![
        "erode",
        DEM,
        "--model",
        "stream-power",
        "--steps",
        "4",
        "--uplift",
        "0.002",
        "--k",
        "4e-5",
        "--m",
        "0.5",
        "-o",
        s(&out),
    ];
    args.extend_from_slice(extra);
    let err = ok(&args);
    (out, err)
}

#[test]
fn tiled_equals_in_memory_for_tiles_threads_and_scratch() {
    let dir = tempfile::tempdir().unwrap();
    let (mem, log) = erode(dir.path(), "mem.tif", &["-q"]);
    assert!(!log.contains("tiled"), "{log}");
    let reference = read(&mem);
    let input = read(Path::new(DEM));
    let moved = reference
        .data()
        .iter()
        .zip(input.data())
        .filter(|(a, b)| (**a - **b).abs() > 0.5)
        .count();
    assert!(moved > 1000, "{moved} cells changed by > 0.5 m");
    for (i, extra) in [
        vec!["--tiled", "--tile", "13", "--threads", "1"],
        vec!["--tiled", "--tile", "64", "--threads", "2"],
        vec!["--tiled", "--tile", "100", "--threads", "2"],
    ]
    .iter()
    .enumerate()
    {
        let (out, log) = erode(dir.path(), &format!("t{i}.tif"), extra);
        assert!(log.contains("tiled") && log.contains("in memory"), "{log}");
        assert!(same(&reference, &read(&out)), "{extra:?} differs");
    }
    // Explicit scratch folder and a tile store output.
    let scratch = dir.path().join("sc");
    std::fs::create_dir_all(&scratch).unwrap();
    let (out, _) = erode(
        dir.path(),
        "st.tiles",
        &["--tiled", "--tile", "32", "--scratch", s(&scratch), "-q"],
    );
    assert!(same(&reference, &read(&out)));
}

#[test]
fn params_file_and_flags() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("sp.toml");
    std::fs::write(
        &cfg,
        "steps = 3\n[stream-power]\nk = 4e-5\nm = 0.5\nn = 1.0\ndt = 1000.0\nuplift = 0.002\ndepressions = \"fill\"\n",
    )
    .unwrap();
    // The file alone equals the same parameters as flags.
    let a = dir.path().join("a.tif");
    ok(&sp(&["--params", s(&cfg), "-q"], &a));
    let flags = dir.path().join("f.tif");
    ok(&sp(
        &[
            "--steps", "3", "--k", "4e-5", "--m", "0.5", "--uplift", "0.002", "-q",
        ],
        &flags,
    ));
    assert!(same(&read(&a), &read(&flags)));
    // A flag overrides the file (--k), --set overrides the file (m).
    let b = dir.path().join("b.tif");
    ok(&sp(
        &["--params", s(&cfg), "--k", "1e-4", "--set", "m=0.45", "-q"],
        &b,
    ));
    let c = dir.path().join("c.tif");
    ok(&sp(
        &[
            "--steps", "3", "--k", "1e-4", "--m", "0.45", "--uplift", "0.002", "-q",
        ],
        &c,
    ));
    assert!(same(&read(&b), &read(&c)));
    assert!(!same(&read(&a), &read(&b)));
    // The shipped example file parses.
    let e = dir.path().join("e.tif");
    ok(&sp(
        &[
            "--params",
            "configs/erosion-stream-power.toml",
            "--steps",
            "1",
            "-q",
        ],
        &e,
    ));
    // Unknown keys are listed with the valid ones.
    std::fs::write(&cfg, "[stream-power]\nK = 1e-5\n").unwrap();
    let err = fails(&sp(
        &["--params", s(&cfg), "--steps", "1"],
        &dir.path().join("x.tif"),
    ));
    assert!(
        err.contains("unknown field `K`") && err.contains("uplift_map"),
        "{err}"
    );
    std::fs::write(&cfg, "[stream-power]\ndepressions = \"lakes\"\n").unwrap();
    let err = fails(&sp(
        &["--params", s(&cfg), "--steps", "1"],
        &dir.path().join("x.tif"),
    ));
    assert!(err.contains("basin-graph"), "{err}");
}

#[test]
fn tiled_refuses_what_it_cannot_do() {
    let dir = tempfile::tempdir().unwrap();
    let o = dir.path().join("x.tif");
    let err = fails(&sp(
        &["--steps", "1", "--tiled", "--depressions", "basin-graph"],
        &o,
    ));
    assert!(err.contains("basin-graph") && err.contains("fill"), "{err}");
    let err = fails(&sp(&["--steps", "1", "--tiled", "--levels", "60,30"], &o));
    assert!(err.contains("--levels"), "{err}");
    let err = fails(&sp(&["--steps", "1", "--scratch", s(dir.path())], &o));
    assert!(err.contains("--scratch"), "{err}");
    assert!(!o.exists());
}

#[test]
fn too_large_for_memory_runs_tiled_with_scratch_files() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().join("noise.tif");
    ok(&[
        "synth",
        "noise",
        "--size",
        "600x500",
        "--wavelength",
        "80",
        "--octaves",
        "5",
        "--cell",
        "30",
        "-q",
        "-o",
        s(&d),
    ]);
    let run = |name: &str, mem: &str| {
        let out = dir.path().join(name);
        let log = ok(&[
            "erode",
            s(&d),
            "--model",
            "stream-power",
            "--steps",
            "2",
            "--uplift",
            "0.002",
            "--k",
            "1e-4",
            "--memory",
            mem,
            "--tile",
            "128",
            "-o",
            s(&out),
        ]);
        (out, log)
    };
    let (a, log) = run("a.tif", "1GiB");
    assert!(!log.contains("tiled"), "{log}");
    // 600 x 500 cells need ~29 MB in memory, ~9 MB of tiles: scratch files.
    let (b, log) = run("b.tif", "16MiB");
    assert!(
        log.contains("tiled") && log.contains("scratch files"),
        "{log}"
    );
    assert!(same(&read(&a), &read(&b)));
    let left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains("scratch"))
        .collect();
    assert!(left.is_empty(), "{left:?}");
}
