//! Job steps that run a command of a group (`run = "synth noise"`): the
//! output equals the command run by hand, and group mistakes (no method,
//! unknown method, method after a plain command, unknown option) are one
//! clear error each.

use std::path::Path;
use std::process::Command;

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
        ("run = \"synth\"", "", "name the method, e.g. run = \"synth noise\""),
        ("run = \"synth bogus\"", "", "unknown method \"bogus\" of `synth`; methods: noise"),
        ("run = \"fill noise\"", "", "`fill` takes no method"),
        (
            "run = \"synth noise\"",
            "args = { bogus = 1 }",
            "`synth noise` has no option --bogus; see `orogen synth noise --help`",
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
