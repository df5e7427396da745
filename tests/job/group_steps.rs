//! Job steps that run a command of a group (`run = "synth noise"`): the
//! output equals the command run by hand, and group mistakes (no method,
//! unknown method, method after a plain command, unknown option) are one
//! clear error each.

use std::path::Path;
use std::process::Command;

use crate::common::cli::data;
use crate::common::job::job_fixture;

const BIN: &str = env!("CARGO_BIN_EXE_orogen");

fn write_job(dir: &Path, steps: &str) -> std::path::PathBuf {
    let p = dir.join("job.toml");
    std::fs::write(&p, format!("threads = 2\noutput_dir = \"out\"\n{steps}")).unwrap();
    p
}

fn run(args: &[&str]) -> (bool, String, String) {
    let o = Command::new(BIN).args(args).output().unwrap();
    (
        o.status.success(),
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

#[test]
fn synth_noise_step_equals_the_command_by_hand() {
    let dir = tempfile::tempdir().unwrap();
    let job = write_job(
        dir.path(),
        r#"
[[step]]
name = "noise"
run = "synth noise"
output = "noise.tif"
args = { size = "96x80", seed = 7, cell = 30 }

[[step]]
name = "filled"
run = "fill"
input = "noise"
output = "filled.tif"
"#,
    );
    let j = job.display().to_string();
    let (ok, out, err) = run(&["run", &j, "--dry-run"]);
    assert!(ok, "{err}");
    assert!(out.contains("orogen synth noise -o "), "{out}");
    let (ok, _, err) = run(&["run", &j, "--quiet"]);
    assert!(ok, "{err}");
    let by_hand = dir.path().join("hand.tif");
    let (ok, _, err) = run(&[
        "synth",
        "noise",
        "--size",
        "96x80",
        "--seed",
        "7",
        "--cell",
        "30",
        "--threads",
        "2",
        "-o",
        &by_hand.display().to_string(),
    ]);
    assert!(ok, "{err}");
    let a = std::fs::read(dir.path().join("out/noise.tif")).unwrap();
    let b = std::fs::read(&by_hand).unwrap();
    assert!(a == b, "job output differs from the command's");
    assert!(dir.path().join("out/filled.tif").exists());
    // The report names the step's full command.
    let html = std::fs::read_to_string(dir.path().join("out/report.html")).unwrap();
    assert!(html.contains("orogen synth noise"));
}

#[test]
fn group_mistakes_are_clear_errors() {
    let cases = [
        (
            "run = \"synth\"",
            "",
            "name the method, e.g. run = \"synth noise\"",
        ),
        (
            "run = \"synth bogus\"",
            "",
            "unknown method \"bogus\" of `synth`; methods: noise",
        ),
        ("run = \"fill noise\"", "", "`fill` takes no method"),
        (
            "run = \"synth noise\"",
            "args = { bogus = 1 }",
            "`synth noise` has no option --bogus; it accepts: size, cell, kind, seed",
        ),
        (
            "run = \"synth rivers\"",
            "args = { land_treshold = 0.1 }",
            "`synth rivers` has no option --land-treshold (did you mean land_threshold?); it accepts: size, cell, origin",
        ),
        (
            "run = \"synth tectonic\"",
            "args = { noise_shar = 0.5 }",
            "`synth tectonic` has no option --noise-shar (did you mean noise_share?)",
        ),
        ("run = \"nosuch\"", "", "synth noise"),
    ];
    for (runline, args, want) in cases {
        let dir = tempfile::tempdir().unwrap();
        let job = write_job(
            dir.path(),
            &format!("[[step]]\nname = \"s\"\n{runline}\noutput = \"x.tif\"\n{args}\n"),
        );
        let (ok, _, err) = run(&["run", &job.display().to_string(), "--dry-run"]);
        assert!(!ok, "{runline} {args}: accepted");
        assert!(err.contains(want), "{runline} {args}: {err}");
        assert!(err.contains("step \"s\""), "{err}");
    }
}

#[test]
fn report_has_orometry_and_basin_metric_sections() {
    let dir = tempfile::tempdir().unwrap();
    let o = dir.path().join("out");
    let job = write_job(
        dir.path(),
        &job_fixture(
            "orometry_and_basins.toml",
            &[
                ("DEM", &data("bigtujunga_crop.tif").display().to_string()),
                ("OUT", &o.display().to_string()),
            ],
        ),
    );
    let (ok, _, err) = run(&["run", &job.display().to_string(), "--quiet"]);
    assert!(ok, "{err}");
    let html = std::fs::read_to_string(o.join("report.html")).unwrap();
    // Orometric statistics: one chart per Table 1 feature and the scalars.
    let oro = &html[html.find("— orometric statistics").expect("oro section")..];
    for f in [
        "prominence_m",
        "isolation_km",
        "saddle_dir",
        "relevance",
        "density_per_100km2",
        "nni",
    ] {
        assert!(oro.contains(f), "{f}");
    }
    // Basin metrics: summary table with the mean of a column recomputed here.
    let csv = std::fs::read_to_string(o.join("basins.csv")).unwrap();
    let mut lines = csv.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let j = head.iter().position(|c| *c == "relief").unwrap();
    let v: Vec<f64> = lines
        .map(|l| l.split(',').nth(j).unwrap().parse().unwrap())
        .collect();
    assert!(!v.is_empty());
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    let bas = &html[html.find("— basin metrics").expect("basin section")..];
    let row = format!("<tr><td>relief</td><td>{}</td>", v.len());
    let at = bas.find(&row).expect("relief row");
    let cells: Vec<&str> = bas[at..].split("</td><td>").take(5).collect();
    let shown: f64 = cells[4].parse().unwrap();
    assert!((shown - mean).abs() <= 0.006, "{shown} vs {mean}");
    assert!(bas.contains("mean hypsometric curve"));
    assert!(bas.matches("data:image/png;base64,").count() >= 4);
}
