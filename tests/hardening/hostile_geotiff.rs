//! Hostile and broken GeoTIFFs: each gives a typed error naming the file,
//! never a panic or a huge allocation. The files are hand-built here (a few
//! bytes of classic little-endian TIFF) or made by corrupting a fixture.

use orogen::io::geotiff::{GeoTiffReader, ReaderOptions};
use orogen::raster::{RasterSource, Window};
use orogen::Error;
use std::path::{Path, PathBuf};

const SHORT: u16 = 3;
const LONG: u16 = 4;
const ASCII: u16 = 2;

/// One IFD entry: tag, type, count, value bytes (little-endian).
#[derive(Clone)]
struct E(u16, u16, u32, Vec<u8>);

fn short(tag: u16, v: u16) -> E {
    E(tag, SHORT, 1, v.to_le_bytes().to_vec())
}
fn long(tag: u16, v: u32) -> E {
    E(tag, LONG, 1, v.to_le_bytes().to_vec())
}
fn long_n(tag: u16, v: &[u32]) -> E {
    E(
        tag,
        LONG,
        v.len() as u32,
        v.iter().flat_map(|x| x.to_le_bytes()).collect(),
    )
}

/// A classic little-endian TIFF: header, `data` at offset 8, then the IFD
/// (entries sorted by tag) and its out-of-line values.
fn tiff(mut entries: Vec<E>, data: &[u8]) -> Vec<u8> {
    entries.sort_by_key(|e| e.0);
    let ifd_at = 8 + data.len() + data.len() % 2;
    let mut out = b"II*\0".to_vec();
    out.extend_from_slice(&(ifd_at as u32).to_le_bytes());
    out.extend_from_slice(data);
    out.resize(ifd_at, 0);
    let mut extra_at = ifd_at + 2 + 12 * entries.len() + 4;
    let mut extra = Vec::new();
    out.extend_from_slice(&(entries.len() as u16).to_le_bytes());
    for E(tag, typ, count, bytes) in &entries {
        out.extend_from_slice(&tag.to_le_bytes());
        out.extend_from_slice(&typ.to_le_bytes());
        out.extend_from_slice(&count.to_le_bytes());
        if bytes.len() <= 4 {
            let mut v = bytes.clone();
            v.resize(4, 0);
            out.extend_from_slice(&v);
        } else {
            out.extend_from_slice(&(extra_at as u32).to_le_bytes());
            extra.extend_from_slice(bytes);
            extra_at += bytes.len();
        }
    }
    out.extend_from_slice(&0u32.to_le_bytes());
    out.extend_from_slice(&extra);
    out
}

/// The tags of a valid 4 x 2 uint8 single-strip image at offset 8.
fn base(width: u32, height: u32) -> Vec<E> {
    vec![
        long(256, width),
        long(257, height),
        short(258, 8),
        short(259, 1),
        short(262, 1),
        long(273, 8),
        short(277, 1),
        long(278, height),
        long(279, width.wrapping_mul(height)),
        short(339, 1),
    ]
}

fn replace(mut v: Vec<E>, e: E) -> Vec<E> {
    v.retain(|x| x.0 != e.0);
    v.push(e);
    v
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

/// Open (and, if that works, read everything); return the error.
fn fail(path: &Path) -> Error {
    let r = match GeoTiffReader::open(path) {
        Err(e) => return e,
        Ok(r) => r,
    };
    let i = r.info();
    match r.read_native(Window::full(i.width, i.height)) {
        Err(e) => e,
        Ok(_) => panic!("{} was read without error", path.display()),
    }
}

fn assert_names_file(e: &Error, path: &Path) {
    let msg = e.to_string();
    assert!(
        msg.contains(&*path.file_name().unwrap().to_string_lossy()),
        "error does not name the file: {msg}"
    );
}

#[test]
fn the_hand_built_base_file_is_valid() {
    // Guards the builder: the hostile cases below differ from a good file
    // only by what each one breaks.
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "ok.tif",
        &tiff(base(4, 2), &[1, 2, 3, 4, 5, 6, 7, 8]),
    );
    let r = GeoTiffReader::open(&p).unwrap();
    let g = r.read_native(Window::full(4, 2)).unwrap();
    assert_eq!(g.as_le_bytes(), &[1, 2, 3, 4, 5, 6, 7, 8]);
    assert!(!r.info().georef.georeferenced);
}

#[test]
fn missing_file() {
    let e = fail(Path::new("/nonexistent/dir/missing.tif"));
    assert!(matches!(e, Error::Io { .. }), "{e:?}");
    assert_names_file(&e, Path::new("missing.tif"));
}

#[test]
fn wrong_magic() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = tiff(base(4, 2), &[0; 8]);
    b[0] = b'X';
    b[1] = b'X';
    let p = write(dir.path(), "magic.tif", &b);
    let e = fail(&p);
    assert!(matches!(e, Error::Corrupt { .. }), "{e:?}");
    assert_names_file(&e, &p);
    let p = write(dir.path(), "png.tif", b"\x89PNG\r\n\x1a\n0000");
    assert!(matches!(fail(&p), Error::Corrupt { .. }));
}

#[test]
fn truncated_files() {
    let dir = tempfile::tempdir().unwrap();
    let fixture = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/gdal/int16_tiled_deflate_p2_classic.tif");
    let full = std::fs::read(fixture).unwrap();
    for cut in [0, 3, 7, 12, full.len() / 2, full.len() - 1] {
        let p = write(dir.path(), &format!("cut{cut}.tif"), &full[..cut]);
        let e = fail(&p);
        assert!(matches!(e, Error::Corrupt { .. }), "cut at {cut}: {e:?}");
        assert_names_file(&e, &p);
    }
}

#[test]
fn absurd_dimensions() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "huge.tif",
        &tiff(base(1 << 31, 1 << 31), &[0; 8]),
    );
    let e = fail(&p);
    assert!(matches!(e, Error::TooLarge { .. }), "{e:?}");
    assert_names_file(&e, &p);
    // Fewer cells, but a single strip of 10^10 bytes: refused before decoding.
    let p = write(
        dir.path(),
        "bigstrip.tif",
        &tiff(replace(base(100_000, 100_000), long(279, 8)), &[0; 8]),
    );
    let e = fail(&p);
    assert!(matches!(e, Error::TooLarge { .. }), "{e:?}");
    assert!(e.to_string().contains("gdal_translate"), "{e}");
}

#[test]
fn unsupported_compressions() {
    let dir = tempfile::tempdir().unwrap();
    for code in [7u16, 6, 34925, 2, 12345] {
        let p = write(
            dir.path(),
            &format!("c{code}.tif"),
            &tiff(replace(base(4, 2), short(259, code)), &[0; 8]),
        );
        let e = fail(&p);
        assert!(matches!(e, Error::Unsupported { .. }), "{code}: {e:?}");
        let msg = e.to_string();
        assert!(
            msg.contains(&format!("({code})")) && msg.contains("supported: none (1), LZW (5)"),
            "{msg}"
        );
        assert_names_file(&e, &p);
    }
}

/// A LERC block that is not a LERC blob, or whose additional compression
/// is unknown, is refused as corrupt or unsupported, naming the file.
#[test]
fn garbage_lerc_blocks() {
    let dir = tempfile::tempdir().unwrap();
    let lerc = replace(base(4, 2), short(259, 34887));
    for (name, t, data) in [
        ("zeros.tif", lerc.clone(), vec![0u8; 8]),
        (
            "text.tif",
            lerc.clone(),
            b"Lerc2 \x03\0\0\0garbage!".to_vec(),
        ),
        (
            "deflate_junk.tif",
            [lerc.clone(), vec![long_n(50674, &[4, 1])]].concat(),
            vec![0x78, 0x9c, 1, 2, 3, 4, 5, 6],
        ),
    ] {
        let p = write(dir.path(), name, &tiff(t, &data));
        let e = fail(&p);
        assert!(matches!(e, Error::Corrupt { .. }), "{name}: {e:?}");
        assert!(e.to_string().contains("LERC"), "{name}: {e}");
        assert_names_file(&e, &p);
    }
    let p = write(
        dir.path(),
        "lerc_lzma.tif",
        &tiff([lerc, vec![long_n(50674, &[4, 7])]].concat(), &[0; 8]),
    );
    let e = fail(&p);
    assert!(
        matches!(e, Error::Unsupported { .. })
            && e.to_string().contains("additional compression 7"),
        "{e:?}"
    );
}

#[test]
fn wrong_tag_types() {
    let dir = tempfile::tempdir().unwrap();
    // ImageWidth as text.
    let p = write(
        dir.path(),
        "width_ascii.tif",
        &tiff(
            replace(base(4, 2), E(256, ASCII, 4, b"abc\0".to_vec())),
            &[0; 8],
        ),
    );
    let e = fail(&p);
    assert!(matches!(e, Error::Corrupt { .. }), "{e:?}");
    assert_names_file(&e, &p);
    // Strip offsets as text (the crate alone would read character codes).
    let p = write(
        dir.path(),
        "offsets_ascii.tif",
        &tiff(
            replace(base(4, 2), E(273, ASCII, 2, b"x\0".to_vec())),
            &[0; 8],
        ),
    );
    let e = fail(&p);
    assert!(
        matches!(e, Error::Corrupt { .. }) && e.to_string().contains("StripOffsets"),
        "{e:?}"
    );
    // Strip offsets as a double.
    let p = write(
        dir.path(),
        "offsets_double.tif",
        &tiff(
            replace(base(4, 2), E(273, 12, 1, 8f64.to_le_bytes().to_vec())),
            &[0; 8],
        ),
    );
    assert!(matches!(fail(&p), Error::Corrupt { .. }));
    // An unknown field type (99).
    let p = write(
        dir.path(),
        "badtype.tif",
        &tiff(replace(base(4, 2), E(258, 99, 1, vec![8, 0])), &[0; 8]),
    );
    assert!(matches!(
        fail(&p),
        Error::Corrupt { .. } | Error::Unsupported { .. }
    ));
    // GeoKeyDirectory as doubles / GDAL_NODATA that is not a number.
    let p = write(
        dir.path(),
        "nodata.tif",
        &tiff(
            [base(4, 2), vec![E(42113, ASCII, 4, b"abc\0".to_vec())]].concat(),
            &[0; 8],
        ),
    );
    let e = fail(&p);
    assert!(
        matches!(e, Error::Corrupt { .. }) && e.to_string().contains("GDAL_NODATA"),
        "{e:?}"
    );
}

#[test]
fn block_past_end_of_file() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "offset.tif",
        &tiff(replace(base(4, 2), long(273, 1_000_000)), &[0; 8]),
    );
    let e = fail(&p);
    assert!(
        matches!(e, Error::Corrupt { .. }) && e.to_string().contains("past the end"),
        "{e:?}"
    );
    assert_names_file(&e, &p);
    let p = write(
        dir.path(),
        "count.tif",
        &tiff(replace(base(4, 2), long(279, 4_000_000_000)), &[0; 8]),
    );
    assert!(matches!(fail(&p), Error::Corrupt { .. }));
    // Uncompressed strip shorter than its rows.
    let p = write(
        dir.path(),
        "short.tif",
        &tiff(replace(base(4, 2), long(279, 5)), &[0; 8]),
    );
    assert!(matches!(fail(&p), Error::Corrupt { .. }));
}

#[test]
fn offsets_array_of_wrong_length() {
    let dir = tempfile::tempdir().unwrap();
    // Two rows per strip of one row each = 2 strips expected, 3 given.
    let mut t = replace(base(4, 2), long(278, 1));
    t = replace(
        t,
        E(
            273,
            LONG,
            3,
            [8u32, 12, 12]
                .iter()
                .flat_map(|v| v.to_le_bytes())
                .collect(),
        ),
    );
    t = replace(
        t,
        E(
            279,
            LONG,
            3,
            [4u32, 4, 4].iter().flat_map(|v| v.to_le_bytes()).collect(),
        ),
    );
    let p = write(dir.path(), "len.tif", &tiff(t, &[0; 8]));
    let e = fail(&p);
    assert!(matches!(e, Error::Corrupt { .. }), "{e:?}");
    assert_names_file(&e, &p);
    // A huge declared count: refused without allocating it.
    let t = replace(
        base(4, 2),
        E(273, LONG, 0x4000_0000, 8u32.to_le_bytes().to_vec()),
    );
    let mut b = tiff(t, &[0; 8]);
    b.truncate(b.len()); // the array itself is absent: only the count is absurd
    let p = write(dir.path(), "count_huge.tif", &b);
    let e = fail(&p);
    assert!(
        matches!(e, Error::Corrupt { .. } | Error::TooLarge { .. }),
        "{e:?}"
    );
}

#[test]
fn bits_per_sample_inconsistent_with_sample_format() {
    let dir = tempfile::tempdir().unwrap();
    // Bit depths that exist but are not read are unsupported, saying what
    // they are ("12-bit unsigned integer samples"); float sizes that do
    // not exist are corrupt. 16-bit floats are read (as f32).
    for (bits, fmt, want_unsupported) in [
        (8u16, 3u16, false),
        (40, 3, false),
        (24, 1, true),
        (12, 1, true),
        (10, 2, true),
        (24, 3, true),
        (64, 2, true),
        (4, 1, true),
    ] {
        let t = replace(replace(base(4, 2), short(258, bits)), short(339, fmt));
        let p = write(
            dir.path(),
            &format!("b{bits}f{fmt}.tif"),
            &tiff(t, &[0; 64]),
        );
        let e = fail(&p);
        if want_unsupported {
            assert!(
                matches!(e, Error::Unsupported { .. })
                    && e.to_string().contains(&format!("{bits}-bit")),
                "{bits}/{fmt}: {e:?}"
            );
        } else {
            assert!(matches!(e, Error::Corrupt { .. }), "{bits}/{fmt}: {e:?}");
        }
        assert_names_file(&e, &p);
    }
    // Floating-point predictor on integers.
    let t = [base(4, 2), vec![short(317, 3)]].concat();
    let p = write(
        dir.path(),
        "pred3int.tif",
        &tiff(replace(t, short(259, 8)), &[0; 8]),
    );
    assert!(matches!(fail(&p), Error::Corrupt { .. }));
}

#[test]
fn zero_width() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "zero.tif", &tiff(base(0, 2), &[0; 8]));
    let e = fail(&p);
    assert!(matches!(e, Error::Corrupt { .. }), "{e:?}");
    assert_names_file(&e, &p);
}

#[test]
fn planar_multiband_reads_its_bands_and_refuses_a_missing_one() {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/gdal/bad_planar.tif");
    // An empty two-band band-interleaved file: both bands read as zeros.
    for band in [1, 2] {
        let opts = ReaderOptions {
            band,
            ..Default::default()
        };
        let r = GeoTiffReader::open_with(&p, &opts).unwrap();
        assert_eq!(r.band(), (band, 2));
        let g = r.read_native(Window::full(20, 10)).unwrap();
        assert!(g.as_le_bytes().iter().all(|&b| b == 0));
    }
    let opts = ReaderOptions {
        band: 3,
        ..Default::default()
    };
    let e = GeoTiffReader::open_with(&p, &opts)
        .err()
        .expect("band 3 refused");
    assert!(matches!(e, Error::InvalidArgument(_)), "{e:?}");
    assert!(e.to_string().contains("--band 1 to 2"), "{e}");
    assert_names_file(&e, &p);
}

#[test]
fn corrupt_compressed_data_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    for code in [5u16, 8, 50000, 32773] {
        let p = write(
            dir.path(),
            &format!("garbage{code}.tif"),
            &tiff(
                replace(base(4, 2), short(259, code)),
                &[0x7f, 1, 2, 3, 4, 5, 6, 7],
            ),
        );
        let e = fail(&p);
        assert!(
            matches!(e, Error::Corrupt { .. } | Error::Io { .. }),
            "{code}: {e:?}"
        );
        assert_names_file(&e, &p);
    }
    // A zlib bomb: a deflate stream that inflates to far more than the 8-byte
    // strip. Decoding stops at the expected size (the rest is ignored).
    let mut enc = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::best());
    std::io::Write::write_all(&mut enc, &vec![7u8; 50 << 20]).unwrap();
    let bomb = enc.finish().unwrap();
    let t = replace(
        replace(base(4, 2), short(259, 8)),
        long(279, bomb.len() as u32),
    );
    let p = write(dir.path(), "bomb.tif", &tiff(t, &bomb));
    let r = GeoTiffReader::open(&p).unwrap();
    assert_eq!(
        r.read_native(Window::full(4, 2)).unwrap().as_le_bytes(),
        &[7u8; 8]
    );
}

#[test]
fn all_nan_data_is_not_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let data: Vec<u8> = (0..8).flat_map(|_| f32::NAN.to_le_bytes()).collect();
    let t = replace(
        replace(replace(base(4, 2), short(258, 32)), short(339, 3)),
        long(279, 32),
    );
    let p = write(dir.path(), "nan.tif", &tiff(t, &data));
    let r = GeoTiffReader::open(&p).unwrap();
    let g = r.read_native(Window::full(4, 2)).unwrap();
    assert!((0..4).all(|x| g.get_f64(x, 1).is_nan()));
}

#[test]
fn block_size_limit_is_configurable() {
    use orogen::io::geotiff::ReaderOptions;
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/gdal/int16_tiled_deflate_p2_classic.tif");
    // 16 x 16 int16 tiles = 512 bytes each.
    let small = ReaderOptions {
        max_block_bytes: 511,
        ..ReaderOptions::default()
    };
    let e = GeoTiffReader::open_with(&p, &small).err().expect("refused");
    assert!(matches!(e, Error::TooLarge { .. }), "{e:?}");
    let exact = ReaderOptions {
        max_block_bytes: 512,
        ..ReaderOptions::default()
    };
    assert!(GeoTiffReader::open_with(&p, &exact).is_ok());
}

/// A block the codec cannot decode is an error naming the file, the block
/// and its cells, with no engine prefix, and `info` without `--stats`
/// reports it rather than describing the file as fine.
#[test]
fn undecodable_block_is_named_and_info_reports_it() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "bad_deflate.tif",
        &tiff(
            replace(base(4, 2), short(259, 8)),
            &[0x78, 0x9c, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff],
        ),
    );
    let e = fail(&p);
    let msg = e.to_string();
    assert!(matches!(e, Error::Corrupt { .. }), "{e:?}");
    assert!(
        msg.contains("strip 0 (cells 0..4 x 0..2) cannot be decoded")
            && msg.contains("re-download"),
        "{msg}"
    );
    assert_names_file(&e, &p);
    let r = GeoTiffReader::open(&p).unwrap();
    let cfg = orogen::exec::EngineConfig::default();
    let e = orogen::ops::info::describe(&r, false, &cfg)
        .unwrap_err()
        .to_string();
    assert!(e.contains("strip 0") && !e.contains("(map)"), "{e}");
    let e = orogen::ops::info::describe(&r, true, &cfg)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("strip 0") && !e.contains("(map)") && !e.contains("tile 0:"),
        "{e}"
    );
}

/// Tags real files omit and libtiff (so GDAL) supplies are supplied too:
/// PhotometricInterpretation on a single-band image (BlackIsZero) and
/// StripByteCounts of a one-strip image (its cells' bytes uncompressed,
/// the rest of the file compressed); the values read are the stored ones.
#[test]
fn missing_photometric_and_strip_byte_counts_are_tolerated() {
    let dir = tempfile::tempdir().unwrap();
    let cells: Vec<u8> = (0..8).map(|v| v * 30 + 1).collect();
    let without = |tags: &[u16], v: Vec<E>| -> Vec<E> {
        v.into_iter().filter(|e| !tags.contains(&e.0)).collect()
    };
    let mut deflated = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
    std::io::Write::write_all(&mut deflated, &cells).unwrap();
    let deflated = deflated.finish().unwrap();
    for (name, tags, data) in [
        (
            "no_photometric.tif",
            without(&[262], base(4, 2)),
            cells.clone(),
        ),
        (
            "no_byte_counts.tif",
            without(&[279], base(4, 2)),
            cells.clone(),
        ),
        (
            "neither.tif",
            without(&[262, 279], base(4, 2)),
            cells.clone(),
        ),
        (
            "no_byte_counts_deflate.tif",
            without(&[279], replace(base(4, 2), short(259, 8))),
            deflated.clone(),
        ),
    ] {
        let p = write(dir.path(), name, &tiff(tags, &data));
        let r = GeoTiffReader::open(&p).unwrap_or_else(|e| panic!("{name}: {e}"));
        let g = r.read_native(Window::full(4, 2)).unwrap();
        let got: Vec<f64> = (0..8).map(|k| g.get_f64(k % 4, k / 4)).collect();
        let want: Vec<f64> = cells.iter().map(|&v| v as f64).collect();
        assert_eq!(got, want, "{name}");
    }
    // Several samples without a photometric tag stay refused, naming it.
    let three = replace(without(&[262], base(4, 2)), short(277, 3));
    let three = replace(three, long(279, 24));
    let p = write(dir.path(), "rgb_no_photometric.tif", &tiff(three, &[7; 24]));
    let e = fail(&p);
    assert_names_file(&e, &p);
}

/// Old-style (pre-TIFF 6.0) LZW, LSB-first codes without the early code
/// size change, which libtiff (so GDAL) still reads: the stored values,
/// little- and 16-bit; with a predictor it is refused, saying why.
#[test]
fn old_style_lzw_reads_its_values() {
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (40u32, 30u32);
    let values: Vec<i16> = (0..w * h).map(|k| (k as i16 % 97) * 13 - 400).collect();
    let raw: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
    let stored = weezl::encode::Encoder::new(weezl::BitOrder::Lsb, 8)
        .encode(&raw)
        .unwrap();
    assert_eq!((stored[0], stored[1] & 1), (0, 1), "an old-style stream");
    let tags = [
        replace(base(w, h), short(259, 5)),
        vec![
            short(258, 16),
            short(339, 2),
            long(279, stored.len() as u32),
        ],
    ];
    let mut t = tags[0].clone();
    for e in tags[1].clone() {
        t = replace(t, e);
    }
    let p = write(dir.path(), "old_lzw.tif", &tiff(t.clone(), &stored));
    if let Ok(keep) = std::env::var("OROGEN_KEEP_OLD_LZW") {
        std::fs::copy(&p, keep).unwrap();
    }
    let r = GeoTiffReader::open(&p).unwrap();
    let g = r.read_native(Window::full(w as usize, h as usize)).unwrap();
    let got: Vec<f64> = (0..(w * h) as usize)
        .map(|k| g.get_f64(k % w as usize, k / w as usize))
        .collect();
    let want: Vec<f64> = values.iter().map(|&v| v as f64).collect();
    assert_eq!(got, want);
    let p = write(
        dir.path(),
        "old_lzw_p2.tif",
        &tiff(replace(t, short(317, 2)), &stored),
    );
    let e = GeoTiffReader::open(&p).err().expect("refused").to_string();
    assert!(
        e.contains("old-style") && e.contains("predictor 2") && e.contains("old_lzw_p2.tif"),
        "{e}"
    );
}

/// The decoder's messages that name nothing ("inconsistent sizes
/// encountered") say which tags disagree.
#[test]
fn inconsistent_strip_counts_name_the_tags() {
    let dir = tempfile::tempdir().unwrap();
    // Two strips of one row each are implied, one offset is given.
    let p = write(
        dir.path(),
        "one_offset_two_strips.tif",
        &tiff(replace(base(4, 2), long(278, 1)), &[0; 8]),
    );
    let e = fail(&p);
    let msg = e.to_string();
    assert!(matches!(e, Error::Corrupt { .. }), "{e:?}");
    assert!(
        msg.contains("StripOffsets") && msg.contains("RowsPerStrip"),
        "{msg}"
    );
    assert_names_file(&e, &p);
}
