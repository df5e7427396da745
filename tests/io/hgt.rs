//! SRTM .hgt reading: synthetic files in a temp dir (values and georeference
//! against closed forms) and the real N43E006 tile (`tests/data/srtm`; an
//! .hgt cannot be cropped) against values and georeference reported by
//! GDAL 3.6.

use orogen::io::hgt::{hgt_georef, read_hgt};
use orogen::raster::{AnyGrid, DType, RasterSource};
use orogen::Error;
use std::path::PathBuf;

/// The synthetic elevation of cell (x, y), with a few voids.
fn synth(x: usize, y: usize) -> i16 {
    if (x * 31 + y * 17).is_multiple_of(997) {
        -32768
    } else {
        ((x * 7 + y * 13) % 5000) as i16 - 100
    }
}

fn write_hgt(dir: &std::path::Path, name: &str, w: usize, h: usize) -> PathBuf {
    let mut bytes = Vec::with_capacity(w * h * 2);
    for y in 0..h {
        for x in 0..w {
            bytes.extend_from_slice(&synth(x, y).to_be_bytes());
        }
    }
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

#[test]
fn synthetic_3_arcsecond_tile() {
    let dir = tempfile::tempdir().unwrap();
    let p = write_hgt(dir.path(), "s33w071.hgt", 1201, 1201);
    let r = read_hgt(&p).unwrap();
    let i = r.info();
    assert_eq!((i.width, i.height, i.dtype), (1201, 1201, DType::I16));
    let AnyGrid::I16(g) = r.grid() else {
        panic!("not i16")
    };
    for y in 0..1201 {
        for x in 0..1201 {
            assert_eq!(g.get(x, y), synth(x, y), "cell ({x}, {y})");
        }
    }
    let c = 1.0 / 1200.0;
    let want = [-71.0 - c / 2.0, c, 0.0, -32.0 + c / 2.0, 0.0, -c];
    for (k, (got, want)) in i.georef.transform.iter().zip(want).enumerate() {
        assert!((got - want).abs() < 1e-12, "t[{k}]");
    }
    assert_eq!(i.georef.nodata, Some(-32768.0));
    assert_eq!(i.georef.crs.epsg, Some(4326));
    assert!(i.georef.crs.geographic && i.georef.georeferenced);
    // The south-west cell's centre lies on the whole degree.
    let (lon, lat) = i.georef.pixel_to_map(0.5, 1200.5);
    assert!((lon + 71.0).abs() < 1e-12 && (lat + 33.0).abs() < 1e-12);
}

#[test]
fn synthetic_high_latitude_1801x3601() {
    let dir = tempfile::tempdir().unwrap();
    let p = write_hgt(dir.path(), "N61E010.hgt", 1801, 3601);
    let r = read_hgt(&p).unwrap();
    let i = r.info();
    assert_eq!((i.width, i.height), (1801, 3601));
    assert_eq!(r.grid().get_f64(1800, 3600), synth(1800, 3600) as f64);
    assert_eq!(r.grid().get_f64(977, 2011), synth(977, 2011) as f64);
    let t = i.georef.transform;
    assert!((t[1] - 1.0 / 1800.0).abs() < 1e-15 && (t[5] + 1.0 / 3600.0).abs() < 1e-15);
    assert!((t[0] - (10.0 - 0.5 / 1800.0)).abs() < 1e-12);
    assert!((t[3] - (62.0 + 0.5 / 3600.0)).abs() < 1e-12);
}

#[test]
fn one_arcsecond_georef() {
    let g = hgt_georef(43, 6, 3601, 3601);
    let c = 1.0 / 3600.0;
    assert!((g.transform[0] - (6.0 - c / 2.0)).abs() < 1e-12);
    assert!((g.transform[3] - (44.0 + c / 2.0)).abs() < 1e-12);
    assert!((g.transform[1] - c).abs() < 1e-15);
}

#[test]
fn wrong_size_is_an_error_naming_accepted_sizes() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("N43E006.hgt");
    std::fs::write(&p, vec![0u8; 1000]).unwrap();
    let e = err(read_hgt(&p));
    assert!(matches!(e, Error::Corrupt { .. }), "{e}");
    let m = e.to_string();
    assert!(
        m.contains("1201x1201") && m.contains("3601x3601") && m.contains("N43E006.hgt"),
        "{m}"
    );
    // One byte short of a valid tile.
    std::fs::write(&p, vec![0u8; 1201 * 1201 * 2 - 1]).unwrap();
    assert!(read_hgt(&p).is_err());
}

#[test]
fn bad_name_is_an_error_with_the_pattern() {
    let dir = tempfile::tempdir().unwrap();
    let p = write_hgt(dir.path(), "dem.hgt", 1201, 1201);
    let e = err(read_hgt(&p));
    assert!(matches!(e, Error::Unsupported { .. }), "{e}");
    assert!(e.to_string().contains("N43E006"), "{e}");
    let e = err(read_hgt(dir.path().join("N00E000.hgt")));
    assert!(matches!(e, Error::Io { .. }), "{e}");
}

fn err<T>(r: orogen::Result<T>) -> Error {
    match r {
        Err(e) => e,
        Ok(_) => panic!("expected an error"),
    }
}

#[test]
fn real_tile_matches_gdal() {
    let p = crate::common::test_data("srtm/N43E006.hgt");
    let r = read_hgt(&p).unwrap();
    let i = r.info();
    assert_eq!((i.width, i.height), (1201, 1201));
    // gdalinfo: Origin = (5.999583333333334,44.000416666666666), Pixel Size = 0.000833333333333.
    let t = i.georef.transform;
    assert!((t[0] - 5.999583333333334).abs() < 1e-12, "{t:?}");
    assert!((t[3] - 44.000416666666666).abs() < 1e-12, "{t:?}");
    assert!((t[1] - 0.000833333333333).abs() < 1e-12 && (t[5] + 0.000833333333333).abs() < 1e-12);
    // gdallocationinfo -valonly at (col, row).
    for (x, y, v) in [
        (0, 0, 729.0),
        (517, 211, 672.0),
        (1200, 1200, 0.0),
        (1200, 600, 0.0),
    ] {
        assert_eq!(r.grid().get_f64(x, y), v, "({x}, {y})");
    }
    // gdalinfo -mm: Computed Min/Max=-12.000,1923.000 (voids excluded).
    let AnyGrid::I16(g) = r.grid() else { panic!() };
    let valid = g.data().iter().filter(|&&v| v != -32768);
    let (lo, hi) = valid.fold((i16::MAX, i16::MIN), |(a, b), &v| (a.min(v), b.max(v)));
    assert_eq!((lo, hi), (-12, 1923));
}
