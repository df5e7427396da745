//! GeoTIFF writer: write -> read back (with the reader, i.e. the `tiff`
//! crate's independent decoder) gives identical cells and georeferencing for
//! every option; output bytes do not depend on the engine's tile size or the
//! thread count; no file is left behind on failure.

use orogen::exec::TileSink;
use orogen::io::geotiff::{write_geotiff, Compression, GeoTiffReader, GeoTiffWriter, WriteOptions};
use orogen::raster::{
    AnyGrid, Crs, DType, GeoRef, Grid, RasterSource, RasterType, TileLayout, Window,
};
use std::path::Path;

/// A deterministic test surface of `dtype` with some nodata (and NaN) cells.
fn surface(dtype: DType, w: usize, h: usize, nodata: Option<f64>) -> AnyGrid {
    let g = Grid::from_fn(w, h, |x, y| {
        let (xf, yf) = (x as f64, y as f64);
        let v = 40.0 * (xf * 0.13).sin() + 25.0 * (yf * 0.07).cos() + 0.5 * xf - 0.3 * yf
            + (x * y % 7) as f64;
        if (x * 5 + y * 3) % 29 == 0 {
            nodata.unwrap_or(0.0)
        } else {
            v
        }
    });
    let mut a = AnyGrid::from_typed(&g, dtype, nodata);
    if dtype.is_float() {
        // Exact float bit patterns, incl. a NaN and a denormal.
        if let AnyGrid::F32(g) = &mut a {
            g.set(1, 1, f32::NAN);
            g.set(2, 1, 1.0e-40);
            g.set(3, 1, 123.456_79);
        }
        if let AnyGrid::F64(g) = &mut a {
            g.set(1, 1, f64::NAN);
            g.set(2, 1, 1.0e-310);
            g.set(3, 1, std::f64::consts::PI * 1000.0);
        }
    }
    a
}

fn same_bits(a: &AnyGrid, b: &AnyGrid) -> bool {
    a.dtype() == b.dtype()
        && a.width() == b.width()
        && a.height() == b.height()
        && a.as_le_bytes() == b.as_le_bytes()
}

fn read_all(path: &Path) -> (AnyGrid, GeoRef) {
    let r = GeoTiffReader::open(path).unwrap_or_else(|e| panic!("{e}"));
    let i = r.info();
    (
        r.read_native(Window::full(i.width, i.height)).unwrap(),
        i.georef.clone(),
    )
}

#[test]
fn every_option_round_trips() {
    let dir = tempfile::tempdir().unwrap();
    let georef = GeoRef::north_up(500_000.0, 4_600_000.0, 25.0, Crs::projected(32632));
    let cases = [
        (DType::I16, Some(-32768.0)),
        (DType::F32, Some(-9999.0)),
        (DType::F64, Some(f64::NAN)),
        (DType::U8, Some(255.0)),
        (DType::I8, None),
        (DType::U16, Some(0.0)),
        (DType::I32, Some(-2147483648.0)),
        (DType::U32, None),
    ];
    let comps = [
        Compression::None,
        Compression::Deflate { level: 6 },
        Compression::Lzw,
        Compression::Zstd { level: 3 },
    ];
    let mut n = 0;
    for (dtype, nodata) in cases {
        let grid = surface(dtype, 83, 57, nodata);
        let g = georef.clone().with_nodata(nodata);
        let preds: &[Option<u16>] = if dtype.is_float() {
            &[None, Some(1), Some(2), Some(3)]
        } else {
            &[None, Some(1), Some(2)]
        };
        for comp in comps {
            for &pred in preds {
                for big in [Some(false), Some(true)] {
                    let path = dir.path().join(format!("w{n}.tif"));
                    n += 1;
                    let opts = WriteOptions {
                        compression: comp,
                        predictor: pred,
                        block: 32,
                        bigtiff: big,
                    };
                    write_geotiff(&path, &grid, &g, &opts).unwrap();
                    let magic = std::fs::read(&path).unwrap()[..4].to_vec();
                    assert_eq!(
                        magic,
                        if big == Some(true) {
                            b"II+\0".to_vec()
                        } else {
                            b"II*\0".to_vec()
                        }
                    );
                    let (back, bg) = read_all(&path);
                    assert!(same_bits(&back, &grid), "{dtype} {comp:?} {pred:?} {big:?}");
                    assert_eq!(bg.transform, g.transform);
                    assert_eq!(bg.crs.epsg, Some(32632));
                    assert!(!bg.crs.geographic);
                    match nodata {
                        Some(v) if v.is_nan() => assert!(bg.nodata.is_some_and(f64::is_nan)),
                        _ => assert_eq!(bg.nodata, nodata),
                    }
                }
            }
        }
    }
}

#[test]
fn compression_and_predictors_shrink_a_smooth_surface() {
    // Guards against a predictor silently not being applied: on a smooth
    // integer ramp, differencing makes DEFLATE output much smaller.
    let dir = tempfile::tempdir().unwrap();
    let g = AnyGrid::I16(Grid::from_fn(256, 256, |x, y| {
        (x as i16) * 3 + (y as i16) * 5
    }));
    let size = |pred: u16| {
        let p = dir.path().join(format!("p{pred}.tif"));
        let o = WriteOptions {
            compression: Compression::Deflate { level: 6 },
            predictor: Some(pred),
            block: 256,
            bigtiff: None,
        };
        write_geotiff(&p, &g, &GeoRef::pixel(), &o).unwrap();
        std::fs::metadata(&p).unwrap().len()
    };
    let (p1, p2) = (size(1), size(2));
    assert!(p2 * 3 < p1, "predictor 2 {p2} bytes vs none {p1}");
}

#[test]
fn georeferencing_variants_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let grid = surface(DType::F32, 40, 30, Some(-3.4028234663852886e38));
    let mut rotated = GeoRef::north_up(1000.0, 2000.0, 10.0, Crs::projected(2056));
    rotated.transform = [1000.0, 9.6, 2.8, 2000.0, 2.8, -9.6];
    let mut point = GeoRef::north_up(
        7.9995833333333,
        47.0004166666667,
        1.0 / 1200.0,
        Crs::wgs84(),
    );
    point.raster_type = RasterType::Point;
    let mut feet = GeoRef::north_up(100.0, 200.0, 3.0, Crs::projected(2227));
    feet.crs.linear_unit_m = 1200.0 / 3937.0;
    let cases = [
        ("rotated", rotated),
        ("point", point),
        (
            "geographic",
            GeoRef::north_up(-71.0, -32.0, 1.0 / 1200.0, Crs::wgs84()),
        ),
        ("usfeet", feet),
        ("none", GeoRef::pixel()),
    ];
    for (name, g) in cases {
        let g = g.with_nodata(Some(-3.4028234663852886e38));
        let path = dir.path().join(format!("{name}.tif"));
        write_geotiff(&path, &grid, &g, &WriteOptions::default()).unwrap();
        let (back, bg) = read_all(&path);
        assert!(same_bits(&back, &grid), "{name}");
        assert_eq!(bg.georeferenced, g.georeferenced, "{name}");
        assert_eq!(bg.raster_type, g.raster_type, "{name}");
        assert_eq!(bg.crs.epsg, g.crs.epsg, "{name}");
        assert_eq!(bg.crs.geographic, g.crs.geographic, "{name}");
        assert_eq!(bg.crs.linear_unit_m, g.crs.linear_unit_m, "{name}");
        assert_eq!(bg.nodata, g.nodata, "{name}");
        for k in 0..6 {
            // PixelIsPoint shifts by half a cell and back: allow one ulp-scale error.
            let tol = 1e-12 * g.transform[k].abs().max(1.0);
            assert!(
                (bg.transform[k] - g.transform[k]).abs() <= tol,
                "{name} t[{k}] {} vs {}",
                bg.transform[k],
                g.transform[k]
            );
        }
    }
}

#[test]
fn original_geokeys_are_written_back_exactly() {
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/gdal");
    let dir = tempfile::tempdir().unwrap();
    for f in [
        "int16_tiled_deflate_p2_classic.tif",
        "float32_tiled_zstd_p3_big.tif",
        "float32_rotated_deflate_p3.tif",
    ] {
        let (grid, g) = read_all(&fixtures.join(f));
        let out = dir.path().join(f);
        write_geotiff(&out, &grid, &g, &WriteOptions::default()).unwrap();
        let (back, bg) = read_all(&out);
        assert!(same_bits(&back, &grid), "{f}");
        assert_eq!(bg.crs.geokeys, g.crs.geokeys, "{f}");
        assert!(bg.crs.geokeys.is_some());
        assert_eq!(bg.transform, g.transform, "{f}");
        assert_eq!(bg.raster_type, g.raster_type, "{f}");
    }
}

/// Feed `grid` to a writer as the engine would: tiles of `tile` cells in
/// increasing id order.
fn write_tiled(path: &Path, grid: &AnyGrid, g: &GeoRef, opts: &WriteOptions, tile: usize) {
    let (w, h) = (grid.width(), grid.height());
    let mut sink: Box<dyn TileSink> =
        Box::new(GeoTiffWriter::create(path, w, h, grid.dtype(), g, opts).unwrap());
    let layout = TileLayout::new(w, h, tile);
    for id in 0..layout.count() {
        let core = layout.window(id);
        sink.write(id, core, grid.crop(core)).unwrap();
    }
    sink.finish().unwrap();
}

#[test]
fn bytes_do_not_depend_on_engine_tile_size_or_threads() {
    let dir = tempfile::tempdir().unwrap();
    let grid = surface(DType::F32, 150, 97, Some(-9999.0));
    let g = GeoRef::north_up(0.0, 0.0, 1.0, Crs::projected(3857)).with_nodata(Some(-9999.0));
    for comp in [
        Compression::Zstd { level: 5 },
        Compression::Lzw,
        Compression::Deflate { level: 6 },
    ] {
        let opts = WriteOptions {
            compression: comp,
            predictor: None,
            block: 32,
            bigtiff: None,
        };
        let reference = dir.path().join("ref.tif");
        write_geotiff(&reference, &grid, &g, &opts).unwrap();
        let want = std::fs::read(&reference).unwrap();
        for tile in [1, 7, 32, 45, 64, 100, 1000] {
            for threads in [1, 3] {
                let p = dir.path().join(format!("t{tile}_{threads}.tif"));
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                pool.install(|| write_tiled(&p, &grid, &g, &opts, tile));
                assert!(
                    std::fs::read(&p).unwrap() == want,
                    "{comp:?} tile {tile} threads {threads}"
                );
            }
        }
    }
}

fn leftovers(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect()
}

#[test]
fn failed_or_abandoned_writes_leave_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("out.tif");
    let g = GeoRef::pixel();
    // Dropped without finish.
    {
        let mut w = GeoTiffWriter::create(&path, 100, 50, DType::I16, &g, &WriteOptions::default())
            .unwrap();
        w.write(
            0,
            Window::new(0, 0, 100, 20),
            AnyGrid::filled(DType::I16, 100, 20, 1.0),
        )
        .unwrap();
        assert_eq!(
            leftovers(dir.path()).len(),
            1,
            "the temporary file exists while writing"
        );
        assert!(!path.exists(), "nothing under the final name before finish");
    }
    assert!(
        leftovers(dir.path()).is_empty(),
        "{:?}",
        leftovers(dir.path())
    );
    // Finished with rows missing: error, no file.
    let mut w: Box<dyn TileSink> = Box::new(
        GeoTiffWriter::create(&path, 100, 50, DType::I16, &g, &WriteOptions::default()).unwrap(),
    );
    w.write(
        0,
        Window::new(0, 0, 100, 20),
        AnyGrid::filled(DType::I16, 100, 20, 1.0),
    )
    .unwrap();
    let err = w.finish().unwrap_err().to_string();
    assert!(err.contains("20 of 50 rows"), "{err}");
    assert!(leftovers(dir.path()).is_empty());
    // A tile of the wrong type or outside the raster: error.
    let mut w =
        GeoTiffWriter::create(&path, 100, 50, DType::I16, &g, &WriteOptions::default()).unwrap();
    assert!(w
        .write(
            0,
            Window::new(0, 0, 10, 10),
            AnyGrid::filled(DType::F32, 10, 10, 1.0)
        )
        .is_err());
    assert!(w
        .write(
            0,
            Window::new(95, 0, 10, 10),
            AnyGrid::filled(DType::I16, 10, 10, 1.0)
        )
        .is_err());
    drop(w);
    assert!(leftovers(dir.path()).is_empty());
    // Bad options are refused before anything is created.
    let bad = [
        WriteOptions {
            block: 20,
            ..WriteOptions::default()
        },
        WriteOptions {
            predictor: Some(3),
            ..WriteOptions::default()
        },
        WriteOptions {
            predictor: Some(7),
            ..WriteOptions::default()
        },
    ];
    for o in bad {
        assert!(GeoTiffWriter::create(&path, 10, 10, DType::I16, &g, &o).is_err());
    }
    assert!(GeoTiffWriter::create(
        &path,
        10,
        10,
        DType::U8,
        &g.clone().with_nodata(Some(-1.0)),
        &WriteOptions::default()
    )
    .is_err());
    assert!(leftovers(dir.path()).is_empty());
}

#[test]
fn bigtiff_and_predictor_are_chosen_automatically() {
    let dir = tempfile::tempdir().unwrap();
    let g = GeoRef::pixel();
    let auto = WriteOptions::default();
    let small =
        GeoTiffWriter::create(dir.path().join("a.tif"), 1000, 1000, DType::F32, &g, &auto).unwrap();
    assert!(!small.is_bigtiff());
    assert_eq!(small.predictor(), 3);
    // 40000 x 30000 f32 = 4.8 GB uncompressed: BigTIFF (nothing is written yet).
    let big = GeoTiffWriter::create(
        dir.path().join("b.tif"),
        40000,
        30000,
        DType::F32,
        &g,
        &auto,
    )
    .unwrap();
    assert!(big.is_bigtiff());
    let int =
        GeoTiffWriter::create(dir.path().join("c.tif"), 10, 10, DType::I16, &g, &auto).unwrap();
    assert_eq!(int.predictor(), 2);
    let none = WriteOptions {
        compression: Compression::None,
        predictor: Some(2),
        ..auto.clone()
    };
    let raw =
        GeoTiffWriter::create(dir.path().join("d.tif"), 10, 10, DType::I16, &g, &none).unwrap();
    assert_eq!(raw.predictor(), 1);
    let forced = WriteOptions {
        bigtiff: Some(true),
        ..auto
    };
    assert!(
        GeoTiffWriter::create(dir.path().join("e.tif"), 10, 10, DType::I16, &g, &forced)
            .unwrap()
            .is_bigtiff()
    );
}

#[test]
fn partial_edge_blocks_are_padded_with_nodata() {
    // A 20x20 raster in one 32x32 block: the decoded block's padding is not
    // visible through the reader, but the file must hold exactly one tile
    // whose uncompressed size is a full block.
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("edge.tif");
    let grid = surface(DType::I16, 20, 20, Some(-5.0));
    let g = GeoRef::pixel().with_nodata(Some(-5.0));
    write_geotiff(
        &p,
        &grid,
        &g,
        &WriteOptions {
            compression: Compression::None,
            predictor: None,
            block: 32,
            bigtiff: Some(false),
        },
    )
    .unwrap();
    let bytes = std::fs::read(&p).unwrap();
    // Uncompressed tile data is the last 32*32*2 bytes; the cell right of the
    // raster in row 0 (x = 20) is padding = nodata.
    let tile = &bytes[bytes.len() - 32 * 32 * 2..];
    assert_eq!(i16::from_le_bytes([tile[40], tile[41]]), -5);
    assert_eq!(
        i16::from_le_bytes([tile[0], tile[1]]) as f64,
        grid.get_f64(0, 0)
    );
    let (back, _) = read_all(&p);
    assert!(same_bits(&back, &grid));
}
