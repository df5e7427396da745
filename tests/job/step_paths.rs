//! Paths in a step's `args`: files a step writes beside its output (a
//! stream raster, statistics, previews) go under the job's `output_dir`;
//! files it reads (sinks, weights, masks) are taken from the job file's
//! folder, like `[inputs]`, whatever the current directory; a missing one
//! is refused before the first step runs.

use std::path::Path;
use std::process::Command;

use crate::common::cli::data;

const BIN: &str = env!("CARGO_BIN_EXE_orogen");

fn job(dir: &Path, steps: &str) -> std::path::PathBuf {
    std::fs::copy(data("bigtujunga_crop.tif"), dir.join("dem.tif")).unwrap();
    let p = dir.join("job.toml");
    std::fs::write(
        &p,
        format!("output_dir = \"out\"\n[inputs]\ndem = \"dem.tif\"\n{steps}"),
    )
    .unwrap();
    p
}

/// Run `orogen ARGS` from `cwd`.
fn run_in(cwd: &Path, args: &[&str]) -> (bool, String) {
    let o = Command::new(BIN)
        .current_dir(cwd)
        .args(args)
        .output()
        .unwrap();
    (
        o.status.success(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

#[test]
fn side_outputs_go_under_output_dir_and_inputs_come_from_the_job_folder() {
    let dir = tempfile::tempdir().unwrap();
    let elsewhere = tempfile::tempdir().unwrap();
    // The sink: the bottom of the DEM's deepest depression.
    std::fs::copy(data("bigtujunga_crop.tif"), dir.path().join("dem.tif")).unwrap();
    let (ok, err) = run_in(dir.path(), &["fill", "dem.tif", "-o", "plain.tif", "-q"]);
    assert!(ok, "{err}");
    let plain = crate::common::cli::read_f32(&dir.path().join("plain.tif"));
    let z = crate::common::cli::read_f32(&dir.path().join("dem.tif"));
    let deepest = (0..z.data().len())
        .max_by(|&a, &b| {
            (plain.data()[a] - z.data()[a]).total_cmp(&(plain.data()[b] - z.data()[b]))
        })
        .unwrap();
    let (x, y) = (deepest % z.width(), deepest / z.width());
    let (mx, my) = (
        388313.6554542635 + 30.0 * (x as f64 + 0.5),
        3801917.8276283755 - 30.0 * (y as f64 + 0.5),
    );
    std::fs::write(dir.path().join("sinks.csv"), format!("x,y\n{mx},{my}\n")).unwrap();
    let j = job(
        dir.path(),
        r#"
[[step]]
name = "f"
run = "fill"
input = "dem"
output = "f.tif"
args = { sinks = "sinks.csv" }
[[step]]
name = "d8"
run = "flow"
input = "f"
output = "d8.tif"
args = { sinks = "sinks.csv" }
[[step]]
name = "st"
run = "streams"
input = "d8"
output = "streams.geojson"
args = { raster = "streams.tif", stats = "stats.json", threshold = 100 }
"#,
    );
    let (ok, err) = run_in(elsewhere.path(), &["run", j.to_str().unwrap()]);
    assert!(ok, "{err}");
    let out = dir.path().join("out");
    for f in [
        "f.tif",
        "d8.tif",
        "streams.geojson",
        "streams.tif",
        "stats.json",
    ] {
        assert!(out.join(f).exists(), "{f} not under output_dir");
    }
    assert_eq!(
        std::fs::read_dir(elsewhere.path()).unwrap().count(),
        0,
        "nothing in the current directory"
    );
    // The sink took effect: the job's fill equals the command by hand.
    let hand = dir.path().join("hand.tif");
    let (ok, err) = run_in(
        dir.path(),
        &[
            "fill",
            "dem.tif",
            "--sinks",
            "sinks.csv",
            "-o",
            hand.to_str().unwrap(),
            "-q",
        ],
    );
    assert!(ok, "{err}");
    let a = crate::common::cli::read_f32(&hand);
    let b = crate::common::cli::read_f32(&out.join("f.tif"));
    assert!(a
        .data()
        .iter()
        .zip(b.data())
        .all(|(x, y)| x.to_bits() == y.to_bits()));
    assert!(
        plain.data().iter().zip(b.data()).any(|(x, y)| x != y),
        "the sink changes the fill"
    );
}

#[test]
fn a_missing_input_path_in_args_is_refused_before_any_step() {
    let dir = tempfile::tempdir().unwrap();
    let j = job(
        dir.path(),
        r#"
[[step]]
name = "f"
run = "fill"
input = "dem"
output = "f.tif"
[[step]]
name = "acc"
run = "accumulate"
input = "f"
output = "a.tif"
args = { weights = "rain.tif" }
"#,
    );
    let (ok, err) = run_in(dir.path(), &["run", j.to_str().unwrap()]);
    assert!(!ok);
    assert!(
        err.starts_with("error: ")
            && err.contains("step \"acc\"")
            && err.contains("rain.tif does not exist"),
        "{err}"
    );
    assert!(
        !dir.path().join("out").join("f.tif").exists(),
        "no step ran"
    );
}
