//! `orogen metric table` and the new metrics through the built binary:
//! files written, markdown/CSV shapes, the heat map is a PNG of the right
//! size, errors name what is accepted.

use crate::common::cli::{ok, orogen};
use std::path::Path;
use std::process::Output;

const DEM: &str = "tests/data/whitebox_DEM.tif";

/// `orogen metric table DEM -o DIR EXTRA`.
fn table(dir: &Path, extra: &[&str]) -> Output {
    orogen()
        .args(["metric", "table", DEM, "-o"])
        .arg(dir)
        .args(extra)
        .output()
        .unwrap()
}

#[test]
fn metric_table_writes_cost_and_correlation() {
    let dir = tempfile::tempdir().unwrap();
    let out = table(
        dir.path(),
        &[
            "--radii",
            "200m,3c",
            "--only",
            "slope,tpi,ors",
            "--corr-radius",
            "2c",
            "-q",
        ],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let cost = std::fs::read_to_string(dir.path().join("cost.csv")).unwrap();
    // header + slope + tpi x2 + ors x2
    assert_eq!(cost.lines().count(), 6, "{cost}");
    assert!(cost.lines().nth(1).unwrap().starts_with("slope,,0,"));
    let md = std::fs::read_to_string(dir.path().join("cost.md")).unwrap();
    assert!(md.contains("| ors |") && md.contains("r = 200 m"), "{md}");
    let legend = std::fs::read_to_string(dir.path().join("correlation_legend.csv")).unwrap();
    let n = legend.lines().count() - 1;
    assert!(n > 30, "{legend}");
    let corr = std::fs::read_to_string(dir.path().join("correlation.csv")).unwrap();
    assert_eq!(corr.lines().count(), n + 1);
    assert!(corr.lines().all(|l| l.split(',').count() == n + 1));
    let png = std::fs::read(dir.path().join("correlation.png")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    // IHDR width and height (big-endian) equal: a square heat map.
    let wh = |o: usize| u32::from_be_bytes([png[o], png[o + 1], png[o + 2], png[o + 3]]);
    assert_eq!(wh(16), wh(20));
    assert!(wh(16) as usize >= n * 20);
}

#[test]
fn metric_table_errors_name_the_fix() {
    let dir = tempfile::tempdir().unwrap();
    let out = table(dir.path(), &["--only", "slope,bogus"]);
    assert!(!out.status.success());
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(
        e.contains("unknown metric 'bogus'") && e.contains("jut"),
        "{e}"
    );
    let out = table(dir.path(), &["--max-cells", "100"]);
    assert!(!out.status.success());
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(
        e.contains("whitebox_DEM.tif") && e.contains("--max-cells"),
        "{e}"
    );
    let out = table(dir.path(), &["--radii", "-5m"]);
    assert!(!out.status.success());
}

#[test]
fn new_metrics_through_the_cli() {
    let dir = tempfile::tempdir().unwrap();
    ok(orogen()
        .args(["metric", DEM, "-q", "--tile", "50", "-m"])
        .arg("directional_slope:azimuth=45,average_slope:radius=300m,fractional_laplacian:radius=3c:s=0.25,hillslope_asymmetry:radius=5c,shary_landform,ors:radius=3c,jut:radius=3c,rut:radius=3c")
        .arg("-o")
        .arg(dir.path()));
    for f in [
        "directional_slope_a45.tif",
        "average_slope_r300m.tif",
        "fractional_laplacian_r3c_s0.25.tif",
        "hillslope_asymmetry_r5c.tif",
        "shary_landform.tif",
        "ors_r3c.tif",
        "jut_r3c.tif",
        "rut_r3c.tif",
    ] {
        assert!(dir.path().join(f).exists(), "{f} missing");
    }
    let out = orogen()
        .args(["metric", DEM, "-m", "fractional_laplacian:s=2", "-o"])
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("0 < s < 1"));
}
