//! Running the built `orogen` binary as a user does: the command, the test
//! data folder, and runs that must succeed or fail cleanly.

use orogen::raster::{read_window, Grid, Window};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

pub fn orogen() -> Command {
    Command::new(env!("CARGO_BIN_EXE_orogen"))
}

/// A file of `tests/data`.
pub fn data(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(p)
}

/// Runs a command that must succeed: returns stdout followed by stderr.
pub fn ok(cmd: &mut Command) -> String {
    let out = cmd.output().unwrap();
    assert!(
        out.status.success(),
        "{:?} failed: {}",
        cmd,
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr)
}

/// Runs a command that must fail: returns stderr, checks exit code 1, one
/// "error:" line first and no panic.
pub fn fails(cmd: &mut Command) -> String {
    let out = cmd.output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success(), "{cmd:?} should fail");
    assert_eq!(out.status.code(), Some(1), "{cmd:?}: {err}");
    assert!(!err.contains("panicked"), "{cmd:?} panicked: {err}");
    assert!(err.starts_with("error: "), "{cmd:?}: {err}");
    err
}

/// `orogen ARGS` with extra environment variables, run to completion.
pub fn run_env(args: &[&str], env: &[(&str, &str)]) -> Output {
    orogen()
        .args(args)
        .envs(env.iter().copied())
        .output()
        .expect("run orogen")
}

/// `orogen ARGS`, run to completion.
pub fn run_args(args: &[&str]) -> Output {
    orogen().args(args).output().expect("run orogen")
}

/// `orogen ARGS` must succeed; returns its stderr.
pub fn ok_args(args: &[&str]) -> String {
    let o = run_args(args);
    assert!(
        o.status.success(),
        "orogen {args:?} failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// `orogen ARGS` must fail; returns its stderr.
pub fn fails_args(args: &[&str]) -> String {
    let o = run_args(args);
    assert!(!o.status.success(), "orogen {args:?} should fail");
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A path as a command-line argument.
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A whole raster as f32.
pub fn read_f32(p: &Path) -> Grid<f32> {
    let src = orogen::io::open_raster(p, &Default::default()).unwrap();
    let i = src.info().clone();
    read_window::<f32>(src.as_ref(), Window::full(i.width, i.height)).unwrap()
}

/// Same width and the same values bit for bit (any NaN equals any NaN).
pub fn same(a: &Grid<f32>, b: &Grid<f32>) -> bool {
    a.width() == b.width()
        && a.data()
            .iter()
            .zip(b.data())
            .all(|(x, y)| x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()))
}
