//! `--engine` on commands and `engine` in job files. The MPI runs themselves
//! need `mpirun` and are checked by `tools/mpi_check.sh`, which compares
//! their bytes with the in-process engine's.

use std::path::Path;
use std::process::Command;

fn orogen(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_orogen"))
        .args(args)
        .output()
        .expect("run orogen")
}

const DEM: &str = "tests/data/whitebox_DEM.tif";

#[test]
fn engine_local_writes_the_same_bytes_as_no_flag() {
    let d = tempfile::tempdir().unwrap();
    let a = d.path().join("a.tif");
    let b = d.path().join("b.tif");
    let o1 = orogen(&["fill", DEM, "-o", a.to_str().unwrap(), "--tile", "64", "-q"]);
    assert!(
        o1.status.success(),
        "{}",
        String::from_utf8_lossy(&o1.stderr)
    );
    let o2 = orogen(&[
        "fill",
        DEM,
        "-o",
        b.to_str().unwrap(),
        "--tile",
        "64",
        "-q",
        "--engine",
        "local",
    ]);
    assert!(
        o2.status.success(),
        "{}",
        String::from_utf8_lossy(&o2.stderr)
    );
    let (x, y) = (std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    assert!(x.len() > 1000);
    assert_eq!(x, y);
}

#[test]
fn an_unknown_engine_is_refused_by_name() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("x.tif");
    let o = orogen(&[
        "fill",
        DEM,
        "-o",
        out.to_str().unwrap(),
        "--engine",
        "spark",
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("spark") && err.contains("mpi"), "{err}");
    assert!(!out.exists());
}

#[cfg(not(feature = "mpi"))]
#[test]
fn engine_mpi_without_the_feature_says_how_to_build_it() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("x.tif");
    let o = orogen(&["fill", DEM, "-o", out.to_str().unwrap(), "--engine", "mpi"]);
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("built without MPI") && err.contains("--features mpi"),
        "{err}"
    );
    assert!(!out.exists());
}

fn job(dir: &Path, engine: &str) -> std::path::PathBuf {
    let dem = std::fs::canonicalize(DEM).unwrap();
    let text = format!(
        "engine = \"{engine}\"\nreport = false\n[inputs]\ndem = \"{}\"\n[[step]]\nname = \"filled\"\nrun = \"fill\"\ninput = \"dem\"\noutput = \"filled.tif\"\n",
        dem.display()
    );
    let p = dir.join("job.toml");
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn job_files_pass_their_engine_to_the_steps() {
    let d = tempfile::tempdir().unwrap();
    let p = job(d.path(), "local");
    let o = orogen(&["run", p.to_str().unwrap(), "--dry-run"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let plan = String::from_utf8_lossy(&o.stdout);
    assert!(plan.contains("--engine local"), "{plan}");
    let o = orogen(&["run", p.to_str().unwrap(), "-q"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(d.path().join("filled.tif").exists());

    let bad = tempfile::tempdir().unwrap();
    let p = job(bad.path(), "spark");
    let o = orogen(&["run", p.to_str().unwrap(), "--dry-run"]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("filled") && err.contains("spark"), "{err}");
}

#[cfg(not(feature = "mpi"))]
#[test]
fn a_job_on_mpi_without_the_feature_fails_its_step_clearly() {
    let d = tempfile::tempdir().unwrap();
    let p = job(d.path(), "mpi");
    let o = orogen(&["run", p.to_str().unwrap(), "-q"]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("built without MPI"), "{err}");
    assert!(!d.path().join("filled.tif").exists());
    let o = orogen(&["run", p.to_str().unwrap(), "--engine", "mpi", "--dry-run"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}
