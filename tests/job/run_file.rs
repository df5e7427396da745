//! `orogen run job.toml`: outputs equal to running the commands by hand,
//! resume after kill -9 at random points with identical final bytes, and one
//! clear error for each kind of mistake in a job file.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

use crate::common::job::job_fixture;

const BIN: &str = env!("CARGO_BIN_EXE_orogen");

fn dem() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/bigtujunga_crop.tif")
}

fn job_text(out: &str) -> String {
    job_fixture(
        "unordered_pipeline.toml",
        &[("OUT", out), ("DEM", &dem().display().to_string())],
    )
}

fn run(args: &[&str]) -> (bool, String) {
    let o = Command::new(BIN).args(args).output().unwrap();
    (
        o.status.success(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

fn outputs(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut v = vec![];
    for f in [
        "acc.tif",
        "filled.tif",
        "d8.tif",
        "metrics/slope.tif",
        "metrics/tpi_r4c.tif",
    ] {
        v.push((f.to_string(), std::fs::read(dir.join(f)).unwrap()));
    }
    v
}

#[test]
fn a_job_equals_the_commands_run_by_hand() {
    let tmp = tempfile::tempdir().unwrap();
    let job = tmp.path().join("job.toml");
    std::fs::write(&job, job_text("out")).unwrap();
    let (ok, err) = run(&["run", job.to_str().unwrap(), "-q"]);
    assert!(ok, "{err}");
    // Steps ran in dependency order although `acc` comes first in the file.
    let order: Vec<&str> = err
        .lines()
        .filter_map(|l| l.split(": ").next())
        .filter_map(|l| l.split("] ").nth(1))
        .collect();
    assert_eq!(order, ["store", "filled", "d8", "acc", "metrics"], "{err}");
    let out = tmp.path().join("out");
    assert!(out.join("report.html").exists());
    // By hand.
    let hand = tmp.path().join("hand");
    std::fs::create_dir_all(hand.join("metrics")).unwrap();
    let h = |p: &str| hand.join(p).display().to_string();
    let d = dem().display().to_string();
    let m = ["--memory", "128MiB", "--threads", "2", "-q"];
    for args in [
        vec!["ingest", &d, "-o", &h("dem.tiles"), "--store-tile", "64"],
        vec![
            "fill",
            &h("dem.tiles"),
            "-o",
            &h("filled.tif"),
            "--tile",
            "100",
        ],
        vec!["flow", &h("filled.tif"), "-o", &h("d8.tif")],
        vec!["accumulate", &h("d8.tif"), "-o", &h("acc.tif")],
        vec![
            "metric",
            &d,
            "-o",
            &h("metrics"),
            "--metric",
            "slope,tpi:radius=4c",
            "--compress",
            "zstd",
        ],
    ] {
        let mut a = args.clone();
        a.extend(m);
        let (ok, err) = run(&a);
        assert!(ok, "{a:?}: {err}");
    }
    assert!(outputs(&out) == outputs(&hand));
    // A rerun does nothing and changes nothing.
    let (ok, err) = run(&["run", job.to_str().unwrap(), "-q"]);
    assert!(ok);
    assert_eq!(err.matches("skipped").count(), 5, "{err}");
    assert!(outputs(&out) == outputs(&hand));
}

#[test]
fn killed_at_random_points_a_rerun_gives_identical_bytes() {
    let tmp = tempfile::tempdir().unwrap();
    let clean = tmp.path().join("clean.toml");
    std::fs::write(&clean, job_text("clean")).unwrap();
    let t0 = std::time::Instant::now();
    assert!(run(&["run", clean.to_str().unwrap(), "-q", "--no-report"]).0);
    let total = t0.elapsed().as_millis() as u64;
    let want = outputs(&tmp.path().join("clean"));

    let job = tmp.path().join("job.toml");
    std::fs::write(&job, job_text("out")).unwrap();
    // Deterministic "random" kill points spread over the clean run's duration;
    // each trial starts afresh, is killed once (SIGKILL), then rerun to the end.
    let mut s: u64 = 0x9E3779B97F4A7C15;
    for trial in 0..5 {
        let _ = std::fs::remove_dir_all(tmp.path().join("out"));
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        let ms = 5 + s % total.max(10);
        let mut child = Command::new(BIN)
            .args(["run", job.to_str().unwrap(), "-q", "--no-report"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        std::thread::sleep(Duration::from_millis(ms));
        let _ = child.kill();
        let _ = child.wait();
        let (ok, err) = run(&["run", job.to_str().unwrap(), "-q", "--no-report"]);
        assert!(ok, "trial {trial} (killed at {ms} ms): {err}");
        assert!(
            outputs(&tmp.path().join("out")) == want,
            "trial {trial} (killed at {ms} ms of {total})"
        );
        // No temporary files left that could pass for outputs.
        for e in walk(&tmp.path().join("out")) {
            let n = e.file_name().unwrap().to_string_lossy().into_owned();
            assert!(
                !n.contains("orogen-tmp") && !n.contains("orogen-cog"),
                "leftover {n}"
            );
        }
    }
}

fn walk(d: &Path) -> Vec<PathBuf> {
    let mut v = vec![];
    for e in std::fs::read_dir(d).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            v.extend(walk(&p));
        } else {
            v.push(p);
        }
    }
    v
}

#[test]
fn each_mistake_in_a_job_file_is_one_clear_error() {
    let tmp = tempfile::tempdir().unwrap();
    let d = dem().display().to_string();
    let cases: Vec<(&str, String, &str)> = vec![
        ("unknown key", "memroy = \"1GiB\"\n[[step]]\nname=\"a\"\nrun=\"fill\"\n".into(), "unknown field `memroy`, expected one of `memory`"),
        ("line number", "threads = 2\n\n[[step]]\nname=\"a\"\nrun=\"fill\"\nouptut=\"x.tif\"\n".into(), "line 6"),
        ("unknown command", "[[step]]\nname=\"a\"\nrun=\"fil\"\n".into(), "unknown command \"fil\"; a step may run: "),
        ("missing input", "[[step]]\nname=\"a\"\nrun=\"fill\"\ninput=\"nope\"\noutput=\"a.tif\"\n".into(), "\"nope\" is neither an input nor a step"),
        ("cycle", "[[step]]\nname=\"a\"\nrun=\"fill\"\ninput=\"b\"\noutput=\"a.tif\"\n[[step]]\nname=\"b\"\nrun=\"flow\"\ninput=\"a\"\noutput=\"b.tif\"\n".into(), "cycle: a -> b -> a"),
        ("wrong type", format!("[inputs]\ndem=\"{d}\"\n[[step]]\nname=\"a\"\nrun=\"slope\"\ninput=\"dem\"\noutput=\"a.tif\"\nargs={{z_factor=\"big\"}}\n"), "step \"a\": `slope` option z_factor = \"big\": invalid type: string \"big\", expected f64"),
        ("unknown option", format!("[inputs]\ndem=\"{d}\"\n[[step]]\nname=\"a\"\nrun=\"slope\"\ninput=\"dem\"\noutput=\"a.tif\"\nargs={{zfactor=2}}\n"), "`slope` has no option --zfactor"),
        ("duplicate", "[inputs]\na=\"x.tif\"\n[[step]]\nname=\"a\"\nrun=\"fill\"\n".into(), "\"a\" is used twice"),
        ("no steps", "threads = 1\n".into(), "no [[step]]"),
        ("table value", format!("[inputs]\ndem=\"{d}\"\n[[step]]\nname=\"a\"\nrun=\"slope\"\ninput=\"dem\"\noutput=\"a.tif\"\nargs={{z_factor={{a=1}}}}\n"), "a table is not a valid value"),
    ];
    for (what, text, want) in cases {
        let p = tmp.path().join("bad.toml");
        std::fs::write(&p, &text).unwrap();
        let (ok, err) = run(&["run", p.to_str().unwrap()]);
        assert!(!ok, "{what}: accepted");
        assert!(err.contains(want), "{what}: {err}");
        assert!(
            err.contains("bad.toml"),
            "{what}: error does not name the file: {err}"
        );
        assert!(!err.contains("panicked"), "{what}: {err}");
        // Nothing was run: no output folder content.
        assert!(!tmp.path().join("a.tif").exists());
    }
    // A failing step names itself, keeps the finished steps and the report.
    let p = tmp.path().join("fail.toml");
    std::fs::write(
        &p,
        format!("[inputs]\ndem=\"{d}\"\n[[step]]\nname=\"ok\"\nrun=\"slope\"\ninput=\"dem\"\noutput=\"s.tif\"\n[[step]]\nname=\"bad\"\nrun=\"slope\"\ninput=\"dem\"\noutput=\"nofolder/s.tif\"\n"),
    )
    .unwrap();
    let (ok, err) = run(&["run", p.to_str().unwrap(), "-q"]);
    assert!(!ok);
    assert!(err.contains("step \"bad\""), "{err}");
    assert!(tmp.path().join("s.tif").exists());
    let html = std::fs::read_to_string(tmp.path().join("report.html")).unwrap();
    assert!(html.contains("FAILED") && html.contains("data:image/png;base64,"));
}
