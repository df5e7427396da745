//! `orogen fill-nodata` through the built binary: the output's type, nodata
//! and cells against the library, a job step equal to the command, and the
//! clear failures (no nodata in the input, not a raster, an absurd
//! distance) that leave no output.

use super::common::cli::{data, fails, ok, orogen, s};
use orogen::io::{open_raster, OpenOptions};
use orogen::ops::fill_nodata::{self, FillNodataOptions};
use orogen::ops::parse::Reach;
use orogen::ops::Target;
use orogen::raster::{AnyGrid, DType, Window};
use std::path::Path;

fn native(p: &Path) -> (AnyGrid, Option<f64>) {
    let src = open_raster(p, &OpenOptions::default()).unwrap();
    let i = src.info();
    (
        src.read_native(Window::new(0, 0, i.width, i.height))
            .unwrap(),
        i.georef.nodata,
    )
}

#[test]
fn command_writes_the_inputs_type_and_nodata_and_equals_the_library_and_a_job() {
    let dem = data("hydro/srtm3_N46E008_voids_crop.tif");
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("filled.tif");
    ok(orogen().args([
        "fill-nodata",
        s(&dem),
        "-o",
        s(&out),
        "--max-distance",
        "1km",
        "-q",
        "--tile",
        "37",
    ]));
    let (got, nodata) = native(&out);
    let (input, in_nodata) = native(&dem);
    assert_eq!(got.dtype(), DType::I16);
    assert_eq!(nodata, Some(-32767.0));
    assert_eq!(nodata, in_nodata);
    // Valid cells unchanged; most voids filled, some (more than 1 km from
    // any valid cell along the rays) left.
    let (AnyGrid::I16(g), AnyGrid::I16(i)) = (&got, &input) else {
        panic!("int16 in and out")
    };
    let (mut filled, mut left) = (0, 0);
    for (&o, &v) in g.data().iter().zip(i.data()) {
        match (v == -32767, o == -32767) {
            (false, _) => assert_eq!(o, v),
            (true, false) => filled += 1,
            (true, true) => left += 1,
        }
    }
    assert!(filled > 10_000 && left > 0, "{filled} filled, {left} left");

    // The library, one tile.
    let src = open_raster(&dem, &OpenOptions::default()).unwrap();
    let lib = d.path().join("lib.tif");
    let opts = FillNodataOptions {
        max_distance: Reach::Metres(1000.0),
    };
    fill_nodata::run(src.as_ref(), &opts, &Target::new(&lib), &Default::default()).unwrap();
    assert_eq!(native(&lib).0.as_le_bytes(), got.as_le_bytes());

    // A job step running the same command.
    let job = d.path().join("job.toml");
    let toml = format!(
        "output_dir = {:?}\nreport = false\n\n[inputs]\ndem = {:?}\n\n[[step]]\nname = \"voids\"\nrun = \"fill-nodata\"\ninput = \"dem\"\noutput = \"filled.tif\"\nargs = {{ max_distance = \"1km\", tile = 64 }}\n",
        s(&d.path().join("job_out")),
        s(&dem)
    );
    std::fs::write(&job, toml).unwrap();
    ok(orogen().arg("run").arg(&job).arg("-q"));
    let from_job = native(&d.path().join("job_out/filled.tif")).0;
    assert_eq!(from_job.as_le_bytes(), got.as_le_bytes());
}

#[test]
fn an_integer_input_without_nodata_fails_clearly_and_writes_nothing() {
    use orogen::io::geotiff::{write_geotiff, WriteOptions};
    use orogen::raster::{Crs, GeoRef, Grid};
    let d = tempfile::tempdir().unwrap();
    let dem = d.path().join("no_nodata.tif");
    let g = Grid::from_fn(40, 30, |x, y| (x * 3 + y) as i16);
    let geo = GeoRef::north_up(500_000.0, 4_000_000.0, 30.0, Crs::projected(32611));
    write_geotiff(&dem, &AnyGrid::I16(g), &geo, &WriteOptions::default()).unwrap();
    assert_eq!(native(&dem).1, None, "the input declares no nodata");
    let outs = tempfile::tempdir().unwrap();
    let out = outs.path().join("out.tif");
    let err = fails(orogen().args(["fill-nodata", s(&dem), "-o", s(&out)]));
    assert!(err.contains("declares no nodata value"), "{err}");
    assert_eq!(
        err.lines().filter(|l| l.starts_with("error:")).count(),
        1,
        "{err}"
    );
    assert_eq!(
        std::fs::read_dir(outs.path()).unwrap().count(),
        0,
        "output left"
    );
}

#[test]
fn a_float_input_without_nodata_fills_its_nan_cells() {
    use orogen::io::geotiff::{write_geotiff, WriteOptions};
    use orogen::raster::{Crs, GeoRef, Grid};
    let d = tempfile::tempdir().unwrap();
    let dem = d.path().join("nan_voids.tif");
    // z = 2x + y with a NaN cell at (5, 5): the 16 rays are symmetric
    // about it, so the plane is exact there.
    let g = Grid::from_fn(11, 11, |x, y| {
        if (x, y) == (5, 5) {
            f32::NAN
        } else {
            (2 * x + y) as f32
        }
    });
    let geo = GeoRef::north_up(500_000.0, 4_000_000.0, 30.0, Crs::projected(32611));
    write_geotiff(&dem, &AnyGrid::F32(g), &geo, &WriteOptions::default()).unwrap();
    let out = d.path().join("out.tif");
    ok(orogen().args(["fill-nodata", s(&dem), "-o", s(&out), "-q"]));
    let (AnyGrid::F32(o), nodata) = native(&out) else {
        panic!("f32 out")
    };
    assert_eq!(nodata, None);
    assert!((o.get(5, 5) - 15.0).abs() < 1e-5, "{}", o.get(5, 5));
    assert_eq!(o.get(3, 4), 10.0);
}

#[test]
fn a_non_raster_and_absurd_distances_fail_clearly_and_write_nothing() {
    let d = tempfile::tempdir().unwrap();
    let bogus = d.path().join("notes.tif");
    std::fs::write(&bogus, "not a raster\n").unwrap();
    let out = d.path().join("out.tif");
    let err = fails(orogen().args(["fill-nodata", s(&bogus), "-o", s(&out)]));
    assert!(err.contains("notes.tif"), "{err}");
    assert!(!out.exists());

    let dem = data("hydro/srtm3_N46E008_voids_crop.tif");
    for (max, says) in [
        ("1e12", "smaller --max-distance"),
        ("50000", "smaller --max-distance"),
        ("10000km", "smaller --max-distance"),
        ("inf", "--max-distance"),
        ("0", "--max-distance"),
        ("3 parsecs", "--max-distance"),
    ] {
        let err =
            fails(orogen().args(["fill-nodata", s(&dem), "-o", s(&out), "--max-distance", max]));
        assert!(err.contains(says), "{max}: {err}");
        assert!(!out.exists(), "{max}: output left");
    }
    assert_eq!(
        std::fs::read_dir(d.path()).unwrap().count(),
        1,
        "only the bogus input"
    );
}
