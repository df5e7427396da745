//! Every GDAL-written fixture in tests/data/gdal (see tools/gdal_compare.py
//! --fixtures) reads exactly as GDAL 3.6 read it: values, size, type,
//! geotransform, EPSG, nodata, pixel-is-point.

use orogen::io::geotiff::{GeoTiffReader, ReaderOptions};
use orogen::raster::{read_window_native, DType, RasterSource, RasterType, Window};
use serde_json::Value;
use std::path::PathBuf;

fn dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/gdal")
}

fn manifest() -> Vec<Value> {
    manifest_files(&dir())
}

/// The `files` of `folder`'s manifest.json (a fixture folder written by
/// tools/gdal_compare.py).
pub fn manifest_files(folder: &std::path::Path) -> Vec<Value> {
    let path = folder.join("manifest.json");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let v: Value = serde_json::from_str(&text).expect("valid manifest");
    v["files"].as_array().expect("files").clone()
}

fn dtype_of(numpy: &str) -> DType {
    match numpy {
        "uint8" => DType::U8,
        "int8" => DType::I8,
        "uint16" => DType::U16,
        "int16" => DType::I16,
        "uint32" => DType::U32,
        "int32" => DType::I32,
        "float32" => DType::F32,
        "float64" => DType::F64,
        other => panic!("unexpected dtype {other}"),
    }
}

#[test]
fn every_fixture_matches_gdal() {
    let files = manifest();
    assert!(
        files.len() >= 100,
        "expected the full variant set, got {}",
        files.len()
    );
    for e in &files {
        let name = e["file"].as_str().unwrap();
        let r = GeoTiffReader::open(dir().join(name)).unwrap_or_else(|err| panic!("{name}: {err}"));
        let info = r.info();
        assert_eq!(
            info.width as u64,
            e["width"].as_u64().unwrap(),
            "{name} width"
        );
        assert_eq!(
            info.height as u64,
            e["height"].as_u64().unwrap(),
            "{name} height"
        );
        assert_eq!(
            info.dtype,
            dtype_of(e["dtype"].as_str().unwrap()),
            "{name} dtype"
        );
        let t = super::geotiff_cases::numbers(&e["transform"]);
        let g = &info.georef;
        if name.contains("nogeo") {
            assert!(!g.georeferenced, "{name}");
            assert_eq!(g.transform, [0.0, 1.0, 0.0, 0.0, 0.0, 1.0]);
        } else {
            assert!(g.georeferenced, "{name}");
            assert_eq!(g.transform.to_vec(), t, "{name} transform");
        }
        assert_eq!(g.crs.epsg.map(u64::from), e["epsg"].as_u64(), "{name} epsg");
        assert_eq!(
            g.crs.geographic,
            e["epsg"].as_u64() == Some(4326),
            "{name} geographic"
        );
        match &e["nodata"] {
            Value::Null => assert_eq!(g.nodata, None, "{name} nodata"),
            v => assert_eq!(g.nodata, v.as_f64(), "{name} nodata"),
        }
        let rt = if e["raster_type"] == "point" {
            RasterType::Point
        } else {
            RasterType::Area
        };
        assert_eq!(g.raster_type, rt, "{name} raster type");

        let reference = std::fs::read(dir().join(e["reference"].as_str().unwrap())).unwrap();
        let all = r
            .read_native(Window::full(info.width, info.height))
            .unwrap();
        assert!(
            all.as_le_bytes() == reference.as_slice(),
            "{name}: values differ from GDAL's"
        );
    }
}

/// Windows of every shape and position (crossing block edges, single cells,
/// single rows) equal the same crop of GDAL's reference, with and without
/// the block cache, and from several threads at once.
#[test]
fn windows_equal_crops_of_the_reference() {
    let picks = [
        "int16_tiled_deflate_p2_classic.tif",
        "int16_strip_lzw_p2_big.tif",
        "float32_tiled_zstd_p3_big.tif",
        "float64_strip_deflate_p3_classic.tif",
        "int16_2band_pixel_deflate_p2.tif",
        "int16_tiled_be_none_big.tif",
    ];
    let files = manifest();
    for name in picks {
        let e = files
            .iter()
            .find(|e| e["file"] == name)
            .unwrap_or_else(|| panic!("{name} missing"));
        let reference = std::fs::read(dir().join(e["reference"].as_str().unwrap())).unwrap();
        for cache in [0usize, 1 << 20] {
            let opts = ReaderOptions {
                cache_bytes: cache,
                ..ReaderOptions::default()
            };
            let r = GeoTiffReader::open_with(dir().join(name), &opts).unwrap();
            let (w, h) = (r.info().width, r.info().height);
            let size = r.info().dtype.size();
            let wins: Vec<Window> = (0..40)
                .map(|k| {
                    let x = (k * 13) % w;
                    let y = (k * 7) % h;
                    let ww = 1 + (k * 11) % (w - x);
                    let hh = 1 + (k * 5) % (h - y);
                    Window::new(x as i64, y as i64, ww, hh)
                })
                .collect();
            std::thread::scope(|s| {
                for chunk in wins.chunks(10) {
                    let r = &r;
                    let reference = &reference;
                    s.spawn(move || {
                        for win in chunk {
                            let got = r.read_native(*win).unwrap();
                            let mut want = Vec::new();
                            for y in win.y as usize..win.y_end() as usize {
                                let a = (y * w + win.x as usize) * size;
                                want.extend_from_slice(&reference[a..a + win.w * size]);
                            }
                            assert!(got.as_le_bytes() == want.as_slice(), "{name} {win:?}");
                        }
                    });
                }
            });
            // Padding outside the raster is nodata (via read_window_native).
            let out = read_window_native(&r, Window::new(-2, -1, 4, 3)).unwrap();
            let fill = r.info().georef.nodata.unwrap_or(0.0);
            assert_eq!(out.get_f64(0, 0), fill);
            // Cell (2, 1) of the padded window is raster cell (0, 0).
            assert_eq!(
                out.as_le_bytes()[(4 + 2) * size..(4 + 3) * size],
                reference[..size]
            );
        }
    }
}

#[test]
fn window_outside_the_raster_is_an_error_not_a_panic() {
    let r = GeoTiffReader::open(dir().join("int16_strip_none_p1_classic.tif")).unwrap();
    let (w, h) = (r.info().width, r.info().height);
    assert!(r.read_native(Window::new(-1, 0, 2, 2)).is_err());
    assert!(r.read_native(Window::new(0, 0, w + 1, h)).is_err());
}

/// Every band of the multi-band and photometric fixtures in
/// tests/data/gdal/bands (`tools/gdal_variants.sh --band-fixtures`: pixel-
/// and band-interleaved, strips and tiles, WhiteIsZero, RGB with extra
/// samples of unspecified meaning, RGB + alpha, palette) reads exactly as
/// GDAL 3.6 read it (bands under an alpha masked where GDAL's mask is 0),
/// and the reader says which band of how many it read.
#[test]
fn every_band_of_every_layout_matches_gdal() {
    let bands = dir().join("bands");
    let files = manifest_files(&bands);
    assert!(files.len() >= 30, "{} band references", files.len());
    for e in &files {
        let name = e["file"].as_str().unwrap();
        let band = e["band"].as_u64().unwrap() as usize;
        let count = e["bands"].as_u64().unwrap() as usize;
        let opts = ReaderOptions {
            band,
            ..Default::default()
        };
        let r = GeoTiffReader::open_with(bands.join(name), &opts)
            .unwrap_or_else(|err| panic!("{name} band {band}: {err}"));
        assert_eq!(r.band(), (band, count), "{name}");
        let info = r.info();
        let reference = std::fs::read(bands.join(e["reference"].as_str().unwrap())).unwrap();
        if let Some(mask) = e["mask"].as_str() {
            // A band masked by the file's alpha (GDAL's mask band recorded).
            let mask = std::fs::read(bands.join(mask)).unwrap();
            let want = super::geotiff_cases::values(&reference, e["dtype"].as_str().unwrap());
            super::geotiff_cases::assert_reads_like_gdal(name, &r, &want, Some(&mask));
            continue;
        }
        assert_eq!(
            info.dtype,
            dtype_of(e["dtype"].as_str().unwrap()),
            "{name} dtype"
        );
        let all = r
            .read_native(Window::full(info.width, info.height))
            .unwrap();
        assert!(
            all.as_le_bytes() == reference.as_slice(),
            "{name} band {band}: values differ from GDAL's"
        );
        // One band past the last is refused, naming the file and the choice.
        let past = ReaderOptions {
            band: count + 1,
            ..Default::default()
        };
        let err = GeoTiffReader::open_with(bands.join(name), &past)
            .err()
            .unwrap_or_else(|| panic!("{name}: band {} read", count + 1))
            .to_string();
        assert!(err.contains(name) && err.contains("--band 1"), "{err}");
    }
}

/// A colour image whose stored samples are not what GDAL reads (CMYK, which
/// GDAL converts to RGBA) is refused, saying what it is and how to convert.
#[test]
fn cmyk_colour_is_refused_clearly() {
    let p = dir().join("bands/refused_cmyk.tif");
    let err = GeoTiffReader::open(&p).err().expect("refused").to_string();
    assert!(
        err.contains("CMYK") && err.contains("gdal_translate") && err.contains("refused_cmyk.tif"),
        "{err}"
    );
}
