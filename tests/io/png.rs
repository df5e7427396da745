//! PNG heightmaps: files built byte by byte with the `png` encoder (the
//! oracle is the sample array written), the 16-bit writer round trip, hostile
//! and unsupported files, and the real Mont Blanc heightmap against GDAL 3.6's
//! reading of its float32 GeoTIFF twin.

use orogen::io::png::{read_png_heightmap, write_png16};
use orogen::raster::{AnyGrid, DType, Grid, RasterSource};
use orogen::Error;
use std::path::Path;

fn err<T>(r: orogen::Result<T>) -> Error {
    match r {
        Err(e) => e,
        Ok(_) => panic!("expected an error"),
    }
}

fn encode(path: &Path, w: u32, h: u32, color: png::ColorType, depth: png::BitDepth, data: &[u8]) {
    let f = std::fs::File::create(path).unwrap();
    let mut e = png::Encoder::new(std::io::BufWriter::new(f), w, h);
    e.set_color(color);
    e.set_depth(depth);
    let mut wr = e.write_header().unwrap();
    wr.write_image_data(data).unwrap();
    wr.finish().unwrap();
}

#[test]
fn eight_bit_grey_scaled_and_native() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("g8.png");
    let data: Vec<u8> = (0..5 * 3).map(|i| (i * 17) as u8).collect();
    encode(
        &p,
        5,
        3,
        png::ColorType::Grayscale,
        png::BitDepth::Eight,
        &data,
    );
    let r = read_png_heightmap(&p, 2.0, -10.0).unwrap();
    assert_eq!(
        (r.info().width, r.info().height, r.info().dtype),
        (5, 3, DType::F32)
    );
    assert!(!r.info().georef.georeferenced);
    for y in 0..3 {
        for x in 0..5 {
            assert_eq!(r.grid().get_f64(x, y), -10.0 + 2.0 * data[y * 5 + x] as f64);
        }
    }
    let r = read_png_heightmap(&p, 1.0, 0.0).unwrap();
    assert_eq!(r.info().dtype, DType::U8);
    assert_eq!(r.grid().get_f64(4, 2), data[14] as f64);
}

#[test]
fn sixteen_bit_grey_alpha_marks_nodata() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("ga16.png");
    let (w, h) = (4usize, 3usize);
    let mut data = Vec::new();
    for i in 0..w * h {
        let v = (i as u16) * 5000 + 7;
        let a: u16 = if i % 5 == 0 { 0 } else { 65535 };
        data.extend_from_slice(&v.to_be_bytes());
        data.extend_from_slice(&a.to_be_bytes());
    }
    encode(
        &p,
        w as u32,
        h as u32,
        png::ColorType::GrayscaleAlpha,
        png::BitDepth::Sixteen,
        &data,
    );
    // Identity mapping with alpha still gives f32 (NaN marks nodata).
    let r = read_png_heightmap(&p, 1.0, 0.0).unwrap();
    assert_eq!(r.info().dtype, DType::F32);
    let g: Grid<f32> = r.grid().to_typed(None);
    for i in 0..w * h {
        let v = g.data()[i];
        if i % 5 == 0 {
            assert!(v.is_nan(), "cell {i}");
        } else {
            assert_eq!(v, (i as f32) * 5000.0 + 7.0);
        }
    }
}

#[test]
fn write_png16_round_trip_within_half_step() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("rt.png");
    let g = Grid::from_fn(61, 37, |x, y| {
        if x == 3 && y == 4 {
            f32::NAN
        } else {
            454.0 + ((x as f32 * 0.37).sin() + (y as f32 * 0.21).cos() + 2.0) * 1089.0
        }
    });
    let (min, max) = (454.0, 4810.0);
    let (scale, offset) = write_png16(&p, &g, min, max).unwrap();
    assert!((scale - (max - min) / 65535.0).abs() < 1e-15 && offset == min);
    let r = read_png_heightmap(&p, scale, offset).unwrap();
    let back: Grid<f32> = r.grid().to_typed(None);
    for (a, b) in g.data().iter().zip(back.data()) {
        if a.is_nan() {
            assert!(b.is_nan());
        } else {
            // Quantisation (scale/2) plus f32 rounding of values near 5000.
            assert!(((a - b).abs() as f64) <= scale / 2.0 + 1e-3, "{a} vs {b}");
        }
    }
    // Values beyond the range clamp to the ends; no alpha without NaN.
    let g2 = Grid::from_vec(2, 1, vec![-100.0f32, 1e6]).unwrap();
    let (s, o) = write_png16(&p, &g2, 0.0, 10.0).unwrap();
    let r = read_png_heightmap(&p, 1.0, 0.0).unwrap();
    assert_eq!(r.info().dtype, DType::U16);
    assert_eq!(
        (r.grid().get_f64(0, 0), r.grid().get_f64(1, 0)),
        (0.0, 65535.0)
    );
    assert_eq!(o + 65535.0 * s, 10.0);
    assert!(write_png16(&p, &g2, 5.0, 5.0).is_err());
}

#[test]
fn colour_png_is_unsupported() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("rgb.png");
    encode(
        &p,
        2,
        2,
        png::ColorType::Rgb,
        png::BitDepth::Eight,
        &[9u8; 12],
    );
    let e = err(read_png_heightmap(&p, 1.0, 0.0));
    assert!(matches!(e, Error::Unsupported { .. }), "{e}");
    assert!(e.to_string().contains("greyscale"), "{e}");
}

/// Rewrite the IHDR width/height of a PNG (and its CRC).
fn patch_size(bytes: &mut [u8], w: u32, h: u32) {
    // Signature (8) + length (4) + "IHDR" (4): data at 16..29, CRC at 29..33.
    assert_eq!(&bytes[12..16], b"IHDR");
    bytes[16..20].copy_from_slice(&w.to_be_bytes());
    bytes[20..24].copy_from_slice(&h.to_be_bytes());
    let crc = crc32fast::hash(&bytes[12..29]);
    bytes[29..33].copy_from_slice(&crc.to_be_bytes());
}

#[test]
fn hostile_and_truncated_files_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("ok.png");
    let g = Grid::from_fn(64, 64, |x, y| (x * y) as f32);
    write_png16(&p, &g, 0.0, 4096.0).unwrap();
    let good = std::fs::read(&p).unwrap();
    // Declares 60000 x 60000 (7.2 GB decoded) in a file of a few KB.
    let mut huge = good.clone();
    patch_size(&mut huge, 60000, 60000);
    let ph = dir.path().join("huge.png");
    std::fs::write(&ph, &huge).unwrap();
    let e = err(read_png_heightmap(&ph, 1.0, 0.0));
    assert!(matches!(e, Error::TooLarge { .. }), "{e}");
    // Truncated in the image data.
    let pt = dir.path().join("trunc.png");
    std::fs::write(&pt, &good[..good.len() / 2]).unwrap();
    assert!(read_png_heightmap(&pt, 1.0, 0.0).is_err());
    // Not a PNG at all.
    let pn = dir.path().join("text.png");
    std::fs::write(&pn, b"hello").unwrap();
    assert!(matches!(
        err(read_png_heightmap(&pn, 1.0, 0.0)),
        Error::Corrupt { .. }
    ));
    // Non-finite mapping.
    assert!(read_png_heightmap(&p, f64::NAN, 0.0).is_err());
}

/// The 200 x 300 crop (srcwin 300 40) of the 16-bit Mont Blanc PNG in
/// `tests/data` against GDAL's reading of the same window of its GeoTIFF.
#[test]
fn mont_blanc_crop_matches_its_geotiff() {
    let p = crate::common::test_data("terraindescriptors_alps-montblanc_crop.png");
    let r = read_png_heightmap(&p, (4810.0 - 454.0) / 65535.0, 454.0).unwrap();
    assert_eq!((r.info().width, r.info().height), (200, 300));
    let AnyGrid::F32(g) = r.grid() else {
        panic!("not f32")
    };
    // gdallocationinfo -valonly on `gdal_translate -srcwin 300 40 200 300
    // terraindescriptors_alps_montblanc.tif` (col row).
    let gdal = [
        (23, 283, 4737.15087890625),
        (31, 114, 2446.7197265625),
        (104, 9, 1120.14526367188),
        (0, 0, 1194.98864746094),
        (199, 299, 2720.17016601562),
        (150, 200, 3047.92529296875),
        (77, 33, 1486.65148925781),
    ];
    for (x, y, v) in gdal {
        assert!(
            (g.get(x, y) as f64 - v).abs() < 1e-3,
            "({x}, {y}): {} vs {v}",
            g.get(x, y)
        );
    }
    // gdalinfo -mm of that window: Computed Min/Max=785.344,4810.000.
    let lo = g.data().iter().copied().fold(f32::INFINITY, f32::min);
    let hi = g.data().iter().copied().fold(f32::NEG_INFINITY, f32::max);
    assert!(
        (lo - 785.344).abs() < 1e-3 && (hi - 4810.0).abs() < 1e-3,
        "{lo} {hi}"
    );
}

#[test]
fn mont_blanc_matches_its_geotiff() {
    let p = crate::common::test_data("terraindescriptors_alps-montblanc.png");
    let r = read_png_heightmap(&p, (4810.0 - 454.0) / 65535.0, 454.0).unwrap();
    assert_eq!((r.info().width, r.info().height), (647, 647));
    let AnyGrid::F32(g) = r.grid() else {
        panic!("not f32")
    };
    // gdallocationinfo -valonly terraindescriptors_alps_montblanc.tif (col row).
    let gdal = [
        (0, 0, 1381.36572265625),
        (646, 646, 2678.62744140625),
        (323, 323, 4737.15087890625),
        (100, 500, 1764.62194824219),
        (500, 100, 2217.736328125),
        (331, 154, 2446.7197265625),
        (404, 49, 1120.14526367188),
        (74, 548, 1987.95544433594),
        (96, 374, 1829.49499511719),
        (596, 59, 1939.10119628906),
        (519, 219, 1750.99597167969),
        (38, 88, 1935.04663085938),
        (444, 428, 1706.92749023438),
        (71, 246, 1847.90673828125),
        (92, 564, 1826.70336914062),
    ];
    for (x, y, v) in gdal {
        assert!(
            (g.get(x, y) as f64 - v).abs() < 1e-3,
            "({x}, {y}): {} vs {v}",
            g.get(x, y)
        );
    }
    // gdalinfo -mm of the tif: Computed Min/Max=454.000,4810.000.
    let lo = g.data().iter().copied().fold(f32::INFINITY, f32::min);
    let hi = g.data().iter().copied().fold(f32::NEG_INFINITY, f32::max);
    assert!(
        (lo - 454.0).abs() < 1e-3 && (hi - 4810.0).abs() < 1e-3,
        "{lo} {hi}"
    );
}
