//! GeoTIFF cases GDAL reads and writes its own way, against what GDAL 3.6
//! did with the committed files of tests/data/gdal/cases (written by
//! `tools/gdal_variants.sh --case-fixtures`): internal masks and alpha read
//! as nodata where GDAL's mask band is 0, sparse blocks (`SPARSE_OK`) read
//! as the nodata value (0 without one), float16 samples read as f32, LERC
//! blocks (plain, with DEFLATE or ZSTD, lossless and lossy) decoded to
//! GDAL's values, and
//! georeferencing written with the tags GDAL writes (ModelTransformation
//! for a south-up grid, no GeoKey directory without a CRS, GTRasterType
//! alone for PixelIsPoint without a CRS), and ground control points and
//! RPCs named as not used.

use orogen::io::geotiff::{write_geotiff, GeoTiffReader, WriteOptions};
use orogen::raster::{DType, RasterSource, Window};
use serde_json::Value;
use std::path::{Path, PathBuf};

fn dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/gdal/cases")
}

fn cases() -> Vec<Value> {
    super::geotiff_read::manifest_files(&dir())
}

/// Little-endian numpy values of `dtype` as f64 (decoded here, not by orogen).
pub fn values(bytes: &[u8], dtype: &str) -> Vec<f64> {
    let size = match dtype {
        "uint8" | "int8" => 1,
        "uint16" | "int16" | "float16" => 2,
        "uint32" | "int32" | "float32" => 4,
        "float64" => 8,
        other => panic!("dtype {other}"),
    };
    bytes
        .chunks_exact(size)
        .map(|c| match dtype {
            "uint8" => c[0] as f64,
            "int8" => c[0] as i8 as f64,
            "uint16" => u16::from_le_bytes([c[0], c[1]]) as f64,
            "int16" => i16::from_le_bytes([c[0], c[1]]) as f64,
            "uint32" => u32::from_le_bytes(c.try_into().unwrap()) as f64,
            "int32" => i32::from_le_bytes(c.try_into().unwrap()) as f64,
            "float32" => f32::from_le_bytes(c.try_into().unwrap()) as f64,
            _ => f64::from_le_bytes(c.try_into().unwrap()),
        })
        .collect()
}

/// Every cell of `r` equals GDAL's `reference` where GDAL's `mask` (one
/// byte a cell, 0 = masked; all valid without one) is valid, and is
/// nodata (the declared value, or NaN) where it is masked.
pub fn assert_reads_like_gdal(
    name: &str,
    r: &GeoTiffReader,
    reference: &[f64],
    mask: Option<&[u8]>,
) {
    let info = r.info();
    let g = r
        .read_native(Window::full(info.width, info.height))
        .unwrap_or_else(|e| panic!("{name}: {e}"));
    let nodata = info.georef.nodata;
    let is_nodata =
        |v: f64| v.is_nan() || nodata.is_some_and(|n| v == n || (n.is_nan() && v.is_nan()));
    assert_eq!(reference.len(), info.width * info.height, "{name}");
    let mut masked = 0;
    for (k, &want) in reference.iter().enumerate() {
        let got = g.get_f64(k % info.width, k / info.width);
        if mask.is_some_and(|m| m[k] == 0) {
            masked += 1;
            assert!(
                is_nodata(got),
                "{name}: masked cell {k} reads {got}, not nodata ({nodata:?})"
            );
        } else {
            assert!(
                got == want || (got.is_nan() && want.is_nan()),
                "{name}: cell {k} reads {got}, GDAL {want}"
            );
        }
    }
    if let Some(m) = mask {
        assert!(
            masked > 0 && masked == m.iter().filter(|&&v| v == 0).count(),
            "{name}"
        );
    }
}

/// A JSON array of numbers.
pub fn numbers(v: &Value) -> Vec<f64> {
    v.as_array()
        .expect("an array")
        .iter()
        .map(|x| x.as_f64().expect("a number"))
        .collect()
}

fn read_case(e: &Value) -> (String, GeoTiffReader, Vec<f64>, Option<Vec<u8>>) {
    let name = e["file"].as_str().unwrap().to_string();
    let r = GeoTiffReader::open(dir().join(&name)).unwrap_or_else(|err| panic!("{name}: {err}"));
    let bytes = std::fs::read(dir().join(e["reference"].as_str().unwrap())).unwrap();
    let reference = values(&bytes, e["dtype"].as_str().unwrap());
    let mask = e["mask"]
        .as_str()
        .map(|m| std::fs::read(dir().join(m)).unwrap());
    (name, r, reference, mask)
}

/// Every case whose file name starts with `prefix` (there must be `count`)
/// reads as GDAL read it, unmasked; then `more(case, reader, reference)`.
fn each_case(prefix: &str, count: usize, more: impl Fn(&Value, &GeoTiffReader, &[f64])) {
    let mut seen = 0;
    for e in cases()
        .iter()
        .filter(|e| e["file"].as_str().unwrap().starts_with(prefix))
    {
        let (name, r, reference, _) = read_case(e);
        seen += 1;
        assert_reads_like_gdal(&name, &r, &reference, None);
        more(e, &r, &reference);
    }
    assert_eq!(seen, count, "{prefix} cases");
}

#[test]
fn masks_and_alpha_read_as_nodata_where_gdal_masks() {
    let mut seen = 0;
    for e in cases() {
        let (name, r, reference, mask) = read_case(&e);
        let Some(mask) = mask else { continue };
        seen += 1;
        assert_reads_like_gdal(&name, &r, &reference, Some(&mask));
        // A file without nodata gets NaN; integers are widened exactly
        // (f32 for 8 and 16 bits, f64 for 32) so NaN can mark the mask.
        let info = r.info();
        match (e["nodata"].as_f64(), e["dtype"].as_str().unwrap()) {
            (Some(v), dtype) => {
                assert_eq!(info.georef.nodata, Some(v), "{name}");
                assert_eq!(
                    info.dtype.name(),
                    &dtype
                        .replace("uint", "u")
                        .replace("int", "i")
                        .replace("float", "f"),
                    "{name}"
                );
            }
            (None, dtype) => {
                assert!(info.georef.nodata.is_some_and(f64::is_nan), "{name}");
                let want = match dtype {
                    "int32" | "uint32" | "float64" => DType::F64,
                    _ => DType::F32,
                };
                assert_eq!(info.dtype, want, "{name}");
            }
        }
    }
    assert_eq!(seen, 6, "mask and alpha cases");
}

#[test]
fn sparse_blocks_read_as_nodata_or_zero() {
    each_case("sparse_", 3, |e, _, reference| {
        // Most of the file is sparse: the written block's cells are 1..=256.
        let fill = e["nodata"].as_f64().unwrap_or(0.0);
        let filled = reference.iter().filter(|&&v| v == fill).count();
        assert!(filled > reference.len() / 2, "{e}: {filled} fill cells");
    });
}

#[test]
fn float16_samples_read_as_the_float32_gdal_returns() {
    each_case("float16_", 2, |e, r, reference| {
        assert_eq!(r.info().dtype, DType::F32, "{e}");
        // Half precision: 0.37 * 499 - 3 = 181.63 is stored as 181.625.
        assert!(reference.contains(&181.625), "{e}");
    });
}

/// The georeferencing tags of `path`'s first IFD, decoded by the tiff crate.
fn geo_tags(path: &Path) -> Vec<(u16, Vec<f64>)> {
    let mut d = tiff::decoder::Decoder::new(std::fs::File::open(path).unwrap()).unwrap();
    [33550u16, 33922, 34264, 34735]
        .iter()
        .filter_map(|&t| {
            let v = d
                .find_tag(tiff::tags::Tag::from_u16_exhaustive(t))
                .unwrap()?;
            let v = if t == 34735 {
                v.into_u64_vec()
                    .unwrap()
                    .into_iter()
                    .map(|k| k as f64)
                    .collect()
            } else {
                v.into_f64_vec().unwrap()
            };
            Some((t, v))
        })
        .collect()
}

#[test]
fn georeferencing_is_written_with_the_tags_gdal_writes() {
    let tmp = tempfile::tempdir().unwrap();
    let mut seen = 0;
    for e in cases() {
        let name = e["file"].as_str().unwrap();
        let r = GeoTiffReader::open(dir().join(name)).unwrap();
        let info = r.info();
        // Ground control points and RPCs are named as not used; several
        // tiepoints are no geotransform (GDAL reports GCPs instead).
        match name {
            "georef_gcps.tif" => {
                assert_eq!(r.unused_georef(), Some("4 ground control points (GCPs)"));
                assert!(!info.georef.georeferenced, "{name}");
                // The GeoKeys are the GCPs' CRS: the grid has none (GDAL).
                assert_eq!(info.georef.crs.epsg, None, "{name}");
                continue;
            }
            "georef_rpc.tif" => {
                assert_eq!(r.unused_georef(), Some("RPC coefficients"));
                assert!(info.georef.georeferenced, "{name}");
            }
            _ => assert_eq!(r.unused_georef(), None, "{name}"),
        }
        // What GDAL reported on reading: transform and EPSG.
        let t = numbers(&e["transform"]);
        assert_eq!(info.georef.transform.to_vec(), t, "{name} transform");
        assert_eq!(
            info.georef.crs.epsg.map(|c| c as u64),
            e["epsg"].as_u64(),
            "{name} EPSG"
        );
        if !name.starts_with("georef_") || name == "georef_rpc.tif" {
            continue;
        }
        seen += 1;
        // Written by orogen from a raster that holds only the facts (no
        // GeoKeys carried from the file): the tags must be GDAL's.
        let mut georef = info.georef.clone();
        georef.crs.geokeys = None;
        let g = r
            .read_native(Window::full(info.width, info.height))
            .unwrap();
        let out = tmp.path().join(name);
        write_geotiff(&out, &g, &georef, &WriteOptions::default()).unwrap();
        let want: Vec<(u16, Vec<f64>)> = e["tags"]
            .as_object()
            .unwrap()
            .iter()
            .map(|(k, v)| {
                (
                    k.parse().unwrap(),
                    v.as_array()
                        .unwrap()
                        .iter()
                        .map(|x| x.as_f64().unwrap())
                        .collect(),
                )
            })
            .collect();
        let mut got = geo_tags(&out);
        if let (Some(ours), Some(gdals)) = (
            got.iter_mut().find(|t| t.0 == 34735),
            want.iter().find(|t| t.0 == 34735),
        ) {
            // GDAL writes its CRS keys from PROJ (citations, units); orogen
            // from the EPSG code: compare the model and raster type keys
            // and the code only.
            let keep = |d: &[f64]| -> Vec<f64> {
                d[4..]
                    .chunks(4)
                    .filter(|k| [1024.0, 1025.0, 2048.0, 3072.0].contains(&k[0]))
                    .flat_map(|k| k.to_vec())
                    .collect()
            };
            assert_eq!(keep(&ours.1), keep(&gdals.1), "{name} GeoKeys");
            ours.1 = gdals.1.clone();
        }
        assert_eq!(got, want, "{name}: tags differ from GDAL's");
    }
    assert_eq!(seen, 3);
}

#[test]
fn lerc_blocks_read_as_gdal_reads_them() {
    each_case("lerc_", 5, |e, _, reference| {
        // Nodata cells are LERC's invalid pixels; they read as the nodata.
        if let Some(v) = e["nodata"].as_f64() {
            assert_eq!(reference.iter().filter(|&&x| x == v).count(), 66, "{e}");
        }
    });
}

/// A u8 file declaring nodata 256 (GDAL accepts it; no cell can equal it)
/// exports without nodata, with a warning, instead of failing.
#[test]
fn unstorable_nodata_is_dropped_on_export_with_a_warning() {
    use orogen::raster::{GeoRef, Grid};
    let tmp = tempfile::tempdir().unwrap();
    let src = tmp.path().join("u8_256.tif");
    let g = orogen::raster::AnyGrid::U8(Grid::from_fn(5, 4, |x, y| (x * 50 + y) as u8));
    let georef = GeoRef {
        nodata: Some(255.0),
        ..GeoRef::pixel()
    };
    write_geotiff(&src, &g, &georef, &WriteOptions::default()).unwrap();
    let mut bytes = std::fs::read(&src).unwrap();
    let at = bytes
        .windows(4)
        .position(|w| w == b"255\0")
        .expect("GDAL_NODATA text");
    bytes[at..at + 3].copy_from_slice(b"256");
    std::fs::write(&src, bytes).unwrap();
    let r = GeoTiffReader::open(&src).unwrap();
    assert_eq!(r.info().georef.nodata, Some(256.0));
    let out = tmp.path().join("out.tif");
    let mut notes = Vec::new();
    orogen::ops::convert::run(
        &r,
        &orogen::ops::Target::new(&out),
        &orogen::exec::EngineConfig::default(),
        &mut |n| notes.push(format!("{n:?}")),
    )
    .unwrap();
    assert!(
        notes
            .iter()
            .any(|n| n.contains("nodata 256 cannot be stored in u8")),
        "{notes:?}"
    );
    let back = GeoTiffReader::open(&out).unwrap();
    assert_eq!(back.info().georef.nodata, None);
    let a = back.read_native(Window::full(5, 4)).unwrap();
    assert_eq!(a.get_f64(4, 3), 203.0);
}

/// TIFFs no GDAL driver writes but GDAL reads (made by hand in
/// tools/gdal_compare.py, independently of orogen's codecs: its own
/// old-style LZW encoder): no PhotometricInterpretation, no
/// StripByteCounts (raw and DEFLATE), old-style LZW, "1.#INF" nodata.
#[test]
fn hand_made_tiffs_read_as_gdal_reads_them() {
    each_case("hand_", 5, |e, r, reference| {
        if e["file"] == "hand_msvc_inf_nodata.tif" {
            assert_eq!(r.info().georef.nodata, Some(f64::INFINITY));
            assert!(reference.contains(&f64::INFINITY));
        }
    });
}
