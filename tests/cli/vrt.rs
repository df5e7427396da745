//! GDAL VRT mosaics and sparse mosaics from the command line: slope and
//! fill of a VRT of four tiles equal those of the uncut DEM, a VRT with a
//! missing tile equals it away from the gap, unsupported VRTs and sparse
//! mosaics fail with one error and leave no output, `--allow-sparse` builds
//! them.

use crate::common::cli::{data, fails, ok, orogen, read_f32, same};

#[test]
fn slope_and_fill_of_a_vrt_equal_those_of_the_uncut_dem() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (input, tag) in [("vrt/mosaic.vrt", "v"), ("bigtujunga_crop.tif", "o")] {
        ok(orogen()
            .arg("slope")
            .arg(data(input))
            .arg("-o")
            .arg(d.join(format!("slope_{tag}.tif"))));
        ok(orogen()
            .arg("fill")
            .arg(data(input))
            .args(["--tile", "37", "-o"])
            .arg(d.join(format!("fill_{tag}.tif"))));
    }
    for f in ["slope", "fill"] {
        let (v, o) = (
            read_f32(&d.join(format!("{f}_v.tif"))),
            read_f32(&d.join(format!("{f}_o.tif"))),
        );
        assert!(same(&v, &o), "{f} of the VRT differs from {f} of the DEM");
    }
}

#[test]
fn slope_of_a_vrt_with_a_gap_equals_the_dem_away_from_it() {
    let dir = tempfile::tempdir().unwrap();
    let (v, o) = (dir.path().join("v.tif"), dir.path().join("o.tif"));
    ok(orogen()
        .arg("slope")
        .arg(data("vrt/gap.vrt"))
        .arg("-o")
        .arg(&v));
    ok(orogen()
        .arg("slope")
        .arg(data("bigtujunga_crop.tif"))
        .arg("-o")
        .arg(&o));
    let (v, o) = (read_f32(&v), read_f32(&o));
    let (mut inside, mut gap) = (0, 0);
    for y in 0..203 {
        for x in 0..301 {
            // The missing tile: x >= 140, y >= 90; its neighbours see it.
            if x >= 139 && y >= 89 {
                if x >= 140 && y >= 90 {
                    assert!(v.get(x, y).is_nan(), "({x}, {y}) in the gap");
                    gap += 1;
                }
                continue;
            }
            assert_eq!(v.get(x, y).to_bits(), o.get(x, y).to_bits(), "({x}, {y})");
            inside += 1;
        }
    }
    assert!(inside > 40_000 && gap == 161 * 113);
}

#[test]
fn unsupported_vrts_fail_with_one_error_naming_the_fix() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("s.tif");
    for name in ["resample.vrt", "warped.vrt", "scaled.vrt"] {
        let err = fails(
            orogen()
                .arg("slope")
                .arg(data(&format!("vrt/{name}")))
                .arg("-o")
                .arg(&out),
        );
        assert!(
            err.contains(name) && err.contains("gdal_translate"),
            "{err}"
        );
        assert_eq!(err.lines().count(), 1, "one error: {err}");
        assert!(!out.exists());
    }
}

#[test]
fn sparse_mosaics_need_allow_sparse() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("s.tif");
    let err = fails(
        orogen()
            .arg("slope")
            .arg(data("vrt/sparse.vrt"))
            .arg("-o")
            .arg(&out),
    );
    assert!(
        err.contains("--allow-sparse") && err.contains("sparse.vrt"),
        "{err}"
    );
    assert!(!out.exists(), "no output after a refusal");
    ok(orogen()
        .arg("slope")
        .arg(data("vrt/sparse.vrt"))
        .arg("--allow-sparse")
        .arg("-o")
        .arg(&out));
    assert!(out.exists());
    // Several inputs given to ingest: the same rule.
    let store = dir.path().join("m.tiles");
    let err = fails(
        orogen()
            .arg("ingest")
            .arg(data("vrt/t_a.tif"))
            .arg(data("vrt/t_far.tif"))
            .arg("-o")
            .arg(&store),
    );
    assert!(
        err.contains("--allow-sparse") && err.contains("2 files"),
        "{err}"
    );
    assert!(!store.exists(), "no store after a refusal");
    ok(orogen()
        .arg("ingest")
        .arg(data("vrt/t_a.tif"))
        .arg(data("vrt/t_far.tif"))
        .arg("--allow-sparse")
        .arg("-o")
        .arg(&store));
    let help = ok(orogen().args(["slope", "--help"]));
    assert!(
        help.contains("--allow-sparse") && help.contains("half"),
        "{help}"
    );
}

#[test]
fn a_job_step_takes_allow_sparse() {
    let dir = tempfile::tempdir().unwrap();
    let job = |allow: bool| {
        format!(
            "report = false\noutput_dir = \"{}\"\n[inputs]\ndem = \"{}\"\n[[step]]\nname = \"s\"\n\
             run = \"slope\"\ninput = \"dem\"\noutput = \"s.tif\"\nargs = {{ allow_sparse = {allow} }}\n",
            dir.path().join("out").display(),
            data("vrt/sparse.vrt").display()
        )
    };
    let p = dir.path().join("job.toml");
    std::fs::write(&p, job(false)).unwrap();
    let o = orogen().arg("run").arg(&p).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("allow_sparse") && err.contains("21.1 %"),
        "{err}"
    );
    assert!(!dir.path().join("out/s.tif").exists());
    std::fs::write(&p, job(true)).unwrap();
    let said = ok(orogen().arg("run").arg(&p));
    assert!(
        said.contains("--allow-sparse"),
        "the step's command line: {said}"
    );
    assert!(dir.path().join("out/s.tif").exists());
}
