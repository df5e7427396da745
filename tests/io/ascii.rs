//! ESRI ASCII grids: the real landlab grid against GDAL 3.6's reading of it,
//! header variants and values against hand-written expectations, errors for
//! bad files, and write/read round trips.

use orogen::io::ascii::{read_ascii, write_ascii};
use orogen::raster::{AnyGrid, Crs, DType, GeoRef, Grid, RasterSource};
use orogen::Error;
use std::path::{Path, PathBuf};

fn err<T>(r: orogen::Result<T>) -> Error {
    match r {
        Err(e) => e,
        Ok(_) => panic!("expected an error"),
    }
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn landlab_grid_matches_gdal() {
    let p =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/landlab_SRTMGL3_frontrange.asc");
    let r = read_ascii(&p).unwrap();
    let i = r.info();
    assert_eq!((i.width, i.height, i.dtype), (240, 144, DType::I32));
    assert_eq!(i.georef.nodata, Some(0.0));
    // gdalinfo: Origin = (-105.550416666684001,40.210416666623), Pixel Size = 0.000833333333.
    let t = i.georef.transform;
    assert!((t[0] + 105.550416666684).abs() < 1e-9, "{t:?}");
    assert!((t[3] - 40.210416666623).abs() < 1e-9, "{t:?}");
    assert!((t[1] - 0.000833333333).abs() < 1e-15 && (t[5] + 0.000833333333).abs() < 1e-15);
    // No .prj: CRS unknown.
    assert_eq!(i.georef.crs, Crs::default());
    // gdallocationinfo -valonly at (col, row).
    for (x, y, v) in [
        (0, 0, 2569.0),
        (3, 0, 2578.0),
        (0, 1, 2591.0),
        (239, 143, 2028.0),
        (120, 70, 2555.0),
        (17, 99, 2867.0),
        (200, 5, 2129.0),
    ] {
        assert_eq!(r.grid().get_f64(x, y), v, "({x}, {y})");
    }
    // gdalinfo -mm: Computed Min/Max=1943.000,3286.000.
    let AnyGrid::I32(g) = r.grid() else { panic!() };
    assert_eq!(g.data().iter().min(), Some(&1943));
    assert_eq!(g.data().iter().max(), Some(&3286));
}

#[test]
fn header_variants_and_float_values() {
    let dir = tempfile::tempdir().unwrap();
    // Centre-registered, mixed case, any order, NaN text, exponent.
    let p = write(
        dir.path(),
        "a.asc",
        "NROWS 2\nxllCenter 100.5\nNCOLS 3\nYLLCENTER 200.5\nCellSize 1\nnodata_value -9999\n\
         1.5 2 -9999\n\n  4e1\tnan 6.25\n",
    );
    let r = read_ascii(&p).unwrap();
    let i = r.info();
    assert_eq!((i.width, i.height, i.dtype), (3, 2, DType::F32));
    assert_eq!(i.georef.transform, [100.0, 1.0, 0.0, 202.0, 0.0, -1.0]);
    let g: Grid<f32> = r.grid().to_typed(i.georef.nodata);
    let want = [1.5, 2.0, f32::NAN, 40.0, f32::NAN, 6.25];
    for (k, (a, b)) in g.data().iter().zip(want).enumerate() {
        assert!(
            a == &b || (a.is_nan() && b.is_nan()),
            "cell {k}: {a} vs {b}"
        );
    }
    // dx/dy, no nodata, integers -> i32.
    let p = write(
        dir.path(),
        "b.asc",
        "ncols 2\nnrows 1\nxllcorner 0\nyllcorner 10\ndx 2\ndy 0.5\n-3 2147483647\n",
    );
    let r = read_ascii(&p).unwrap();
    assert_eq!(r.info().dtype, DType::I32);
    assert_eq!(r.info().georef.nodata, None);
    assert_eq!(r.info().georef.transform, [0.0, 2.0, 0.0, 10.5, 0.0, -0.5]);
    assert_eq!(r.grid().get_f64(1, 0), 2147483647.0);
    // More than 9 significant digits -> f64, exact.
    let p = write(
        dir.path(),
        "c.asc",
        "ncols 2\nnrows 1\nxllcorner 0\nyllcorner 0\ncellsize 1\n1234.56789012 1\n",
    );
    let r = read_ascii(&p).unwrap();
    assert_eq!(r.info().dtype, DType::F64);
    assert_eq!(r.grid().get_f64(0, 0), 1234.56789012);
}

#[test]
fn geographic_prj_sets_wgs84() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "g.asc",
        "ncols 1\nnrows 1\nxllcorner 6\nyllcorner 43\ncellsize 0.1\n5\n",
    );
    write(
        dir.path(),
        "g.prj",
        "GEOGCS[\"GCS_WGS_1984\",DATUM[\"D_WGS_1984\",SPHEROID[\"WGS_1984\",6378137,298.257223563]],PRIMEM[\"Greenwich\",0],UNIT[\"Degree\",0.017453292519943295]]",
    );
    assert_eq!(read_ascii(&p).unwrap().info().georef.crs, Crs::wgs84());
    write(
        dir.path(),
        "g.prj",
        "PROJCS[\"WGS_1984_UTM_Zone_32N\",GEOGCS[\"GCS_WGS_1984\"]]",
    );
    assert_eq!(read_ascii(&p).unwrap().info().georef.crs, Crs::default());
}

#[test]
fn bad_files_give_typed_errors() {
    let dir = tempfile::tempdir().unwrap();
    let hdr = "ncols 3\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 1\n";
    // Too few values.
    let p = write(dir.path(), "few.asc", &format!("{hdr}1 2 3 4 5\n"));
    let m = err(read_ascii(&p)).to_string();
    assert!(
        m.contains("expected 6 values") && m.contains("found 5") && m.contains("few.asc"),
        "{m}"
    );
    // Too many values.
    let p = write(dir.path(), "many.asc", &format!("{hdr}1 2 3 4 5 6 7\n"));
    let m = err(read_ascii(&p)).to_string();
    assert!(m.contains("found 7"), "{m}");
    // A non-number.
    let p = write(dir.path(), "bad.asc", &format!("{hdr}1 2 x3 4 5 6\n"));
    let m = err(read_ascii(&p)).to_string();
    assert!(m.contains("row 0, column 2") && m.contains("x3"), "{m}");
    // Absurd declared size in a tiny file: refused before allocating.
    let p = write(
        dir.path(),
        "huge.asc",
        "ncols 4000000000\nnrows 4000000000\nxllcorner 0\nyllcorner 0\ncellsize 1\n1 2\n",
    );
    let e = err(read_ascii(&p));
    assert!(
        matches!(e, Error::Corrupt { .. } | Error::TooLarge { .. }),
        "{e}"
    );
    // Missing cellsize.
    let p = write(
        dir.path(),
        "nocs.asc",
        "ncols 1\nnrows 1\nxllcorner 0\nyllcorner 0\n1\n",
    );
    assert!(err(read_ascii(&p)).to_string().contains("cellsize"));
    // Zero rows.
    let p = write(
        dir.path(),
        "zero.asc",
        "ncols 1\nnrows 0\nxllcorner 0\nyllcorner 0\ncellsize 1\n",
    );
    assert!(err(read_ascii(&p)).to_string().contains("positive integer"));
    // Negative cell size, infinite value.
    let p = write(
        dir.path(),
        "neg.asc",
        "ncols 1\nnrows 1\nxllcorner 0\nyllcorner 0\ncellsize -1\n1\n",
    );
    assert!(read_ascii(&p).is_err());
    let p = write(dir.path(), "inf.asc", &format!("{hdr}1 2 inf 4 5 6\n"));
    assert!(read_ascii(&p).is_err());
    // Binary garbage.
    let p = dir.path().join("garbage.asc");
    std::fs::write(&p, [0xffu8, 0x00, 0x13, 0x37, 0x80]).unwrap();
    assert!(read_ascii(&p).is_err());
}

#[test]
fn float_round_trip_with_nodata_and_prj() {
    let dir = tempfile::tempdir().unwrap();
    let g = Grid::from_fn(7, 5, |x, y| {
        if (x + y) % 6 == 0 {
            f32::NAN
        } else {
            (x as f32 * 0.1 - 3.3) * (y as f32 + 1.7) / 3.0
        }
    });
    let geo = GeoRef::north_up(6.0, 44.0, 1.0 / 1200.0, Crs::wgs84());
    let p = dir.path().join("rt.asc");
    write_ascii(&p, &AnyGrid::F32(g.clone()), &geo).unwrap();
    assert!(dir.path().join("rt.prj").exists());
    let r = read_ascii(&p).unwrap();
    assert_eq!(r.info().dtype, DType::F32);
    assert_eq!(r.info().georef.crs, Crs::wgs84());
    for k in 0..6 {
        assert!((r.info().georef.transform[k] - geo.transform[k]).abs() < 1e-12);
    }
    let back: Grid<f32> = r.grid().to_typed(r.info().georef.nodata);
    for (a, b) in g.data().iter().zip(back.data()) {
        assert!(a == b || (a.is_nan() && b.is_nan()), "{a} vs {b}");
    }
    // No temporary file left behind.
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names.len(), 2, "{names:?}");
}

#[test]
fn integer_round_trip_non_square_cells() {
    let dir = tempfile::tempdir().unwrap();
    let g = Grid::from_fn(4, 3, |x, y| (x as i16 - 2) * 1000 + y as i16);
    let mut geo =
        GeoRef::north_up(500.0, 9000.0, 30.0, Crs::projected(32611)).with_nodata(Some(-32768.0));
    geo.transform[5] = -20.0;
    let p = dir.path().join("i.asc");
    write_ascii(&p, &AnyGrid::I16(g.clone()), &geo).unwrap();
    let text = std::fs::read_to_string(&p).unwrap();
    assert!(
        text.contains("dx") && text.contains("NODATA_value -32768"),
        "{text}"
    );
    let r = read_ascii(&p).unwrap();
    assert_eq!(r.info().dtype, DType::I32);
    assert_eq!(
        r.info().georef.transform,
        [500.0, 30.0, 0.0, 9000.0, 0.0, -20.0]
    );
    for y in 0..3 {
        for x in 0..4 {
            assert_eq!(r.grid().get_f64(x, y), g.get(x, y) as f64);
        }
    }
    // Rotated transforms cannot be written.
    let mut rot = geo.clone();
    rot.transform[2] = 0.5;
    assert!(write_ascii(dir.path().join("r.asc"), &AnyGrid::I16(g), &rot).is_err());
}
