//! A band's scale and offset applied on read: GeoTIFFs written by GDAL 3.6
//! with `SetScale`/`SetOffset` (tests/data/gdal/scaled, made by
//! `tools/gdal_variants.sh --scaled-fixtures`) against GDAL's own
//! `gdal_translate -unscale` of each band; and PNG heightmaps, whose mapping
//! orogen records in `tEXt` chunks and a PAM sidecar and reads back.

use super::common::cli::{fails, ok, orogen};
use orogen::io::png::{read_png, recorded_scaling, write_png16_mapped};
use orogen::io::{open_raster, OpenOptions};
use orogen::raster::{read_window, DType, Grid, RasterSource, Scaling, Window};
use serde_json::Value;
use std::path::{Path, PathBuf};

fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/gdal/scaled")
}

/// GDAL's unscaled values of one fixture (NaN at the raw nodata cells).
fn reference(e: &Value) -> Vec<f64> {
    let bytes = std::fs::read(dir().join(e["reference"].as_str().unwrap())).unwrap();
    bytes
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
        .collect()
}

fn read_all(src: &dyn RasterSource) -> Vec<f64> {
    let i = src.info();
    let g: Grid<f64> = read_window(src, Window::new(0, 0, i.width, i.height)).unwrap();
    g.data().to_vec()
}

#[test]
fn scaled_geotiff_bands_read_as_gdal_unscales_them() {
    let files = super::geotiff_read::manifest_files(&dir());
    assert_eq!(files.len(), 4);
    for e in &files {
        let name = e["file"].as_str().unwrap();
        let band = e["band"].as_u64().unwrap() as usize;
        let opts = OpenOptions {
            band,
            ..Default::default()
        };
        let src = open_raster(&dir().join(name), &opts).unwrap();
        let s = src.info();
        let wide = e["raw_dtype"] == "int32";
        assert_eq!(
            s.dtype,
            if wide { DType::F64 } else { DType::F32 },
            "{name}"
        );
        assert_eq!(
            src.scaling(),
            Some(Scaling {
                scale: e["scale"].as_f64().unwrap(),
                offset: e["offset"].as_f64().unwrap()
            }),
            "{name}"
        );
        let want = reference(e);
        let got = read_all(src.as_ref());
        assert_eq!(got.len(), want.len());
        let mut nodata = 0;
        for (i, (&g, &w)) in got.iter().zip(&want).enumerate() {
            if w.is_nan() {
                nodata += 1;
                assert!(g.is_nan(), "{name} cell {i}: {g} should be nodata");
            } else {
                let w = if wide { w } else { w as f32 as f64 };
                assert_eq!(g, w, "{name} cell {i}");
            }
        }
        assert_eq!(nodata > 0, !e["raw_nodata"].is_null(), "{name}");
        // Read raw (the reader itself) the cells are not those values.
        let raw = orogen::io::geotiff::GeoTiffReader::open_with(
            dir().join(name),
            &orogen::io::geotiff::ReaderOptions {
                band,
                ..Default::default()
            },
        )
        .unwrap();
        assert_ne!(read_all(&raw)[100], got[100], "{name}");
    }
}

#[test]
fn nodata_override_is_raw_and_sea_level_is_an_elevation() {
    let p = dir().join("u16_scale_offset_nodata.tif");
    let want = reference(&super::geotiff_read::manifest_files(&dir())[0]);
    // --sea-level 0 (metres, after scaling): raw cells below 5000 are sea.
    let sea = open_raster(
        &p,
        &OpenOptions {
            sea_level: Some(0.0),
            ..Default::default()
        },
    )
    .unwrap();
    let got = read_all(sea.as_ref());
    for (&g, &w) in got.iter().zip(&want) {
        if w.is_nan() || w <= 0.0 {
            assert!(g.is_nan());
        } else {
            assert_eq!(g, w as f32 as f64);
        }
    }
    assert!(want.iter().any(|&w| w <= 0.0) && want.iter().any(|&w| w > 0.0));
    // --nodata 5000 names a raw value: the raw 65535 cells become data
    // (65535 * 0.1 - 500 = 6053.5 m) and the raw 5000 cells (0 m) nodata.
    let nd = open_raster(
        &p,
        &OpenOptions {
            nodata: Some(5000.0),
            ..Default::default()
        },
    )
    .unwrap();
    let got = read_all(nd.as_ref());
    let cell = 2 * 41 + 3; // inside the raw nodata block rows 2..6, columns 3..9
    assert!(want[cell].is_nan());
    assert_eq!(got[cell], 6053.5);
    assert!(got[0].is_nan(), "raw 5000 at cell 0 is nodata: {}", got[0]);
}

#[test]
fn cli_reads_the_scaled_band_everywhere() {
    let t = tempfile::tempdir().unwrap();
    let p = dir().join("u16_scale_offset_nodata.tif");
    let info = ok(orogen().args(["info", "--json"]).arg(&p));
    let j: Value = serde_json::from_str(&info[..info.rfind('}').unwrap() + 1]).unwrap();
    assert_eq!(j["dtype"], "f32");
    assert_eq!(j["scaling"]["scale"], 0.1);
    assert_eq!(j["scaling"]["offset"], -500.0);
    let text = ok(orogen().arg("info").arg(&p));
    assert!(text.contains("raw * 0.1 + -500"), "{text}");
    let out = t.path().join("m.tif");
    ok(orogen().arg("export").arg(&p).arg("-o").arg(&out).arg("-q"));
    let got = read_all(open_raster(&out, &OpenOptions::default()).unwrap().as_ref());
    let want = reference(&super::geotiff_read::manifest_files(&dir())[0]);
    for (&g, &w) in got.iter().zip(&want) {
        assert!(g == w as f32 as f64 || (g.is_nan() && w.is_nan()));
    }
}

fn ramp() -> Grid<f32> {
    Grid::from_fn(23, 9, |x, y| {
        if (x, y) == (4, 4) {
            f32::NAN
        } else {
            -120.5 + 13.25 * x as f32 + 0.75 * y as f32
        }
    })
}

#[test]
fn png_mapping_is_recorded_in_text_and_sidecar_and_read_back() {
    let t = tempfile::tempdir().unwrap();
    let p = t.path().join("h.png");
    let m = Scaling {
        scale: 0.25,
        offset: -200.0,
    };
    write_png16_mapped(&p, &ramp(), m).unwrap();
    // The tEXt chunks, as the png decoder reads them.
    let dec = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&p).unwrap()));
    let r = dec.read_info().unwrap();
    let text: Vec<(String, String)> = r
        .info()
        .uncompressed_latin1_text
        .iter()
        .map(|c| (c.keyword.clone(), c.text.clone()))
        .collect();
    assert!(
        text.contains(&("height_scale".into(), "0.25".into())),
        "{text:?}"
    );
    assert!(
        text.contains(&("height_offset".into(), "-200.0".into())),
        "{text:?}"
    );
    let aux = std::fs::read_to_string(t.path().join("h.png.aux.xml")).unwrap();
    assert!(
        aux.contains("<Scale>0.25</Scale>") && aux.contains("<Offset>-200.0</Offset>"),
        "{aux}"
    );
    assert_eq!(recorded_scaling(&p).unwrap(), Some(m));
    // Read back without a mapping: metres (the ramp's values are multiples
    // of 0.25 from -200, so exact), the void as NaN.
    let back = read_all(&read_png(&p, None).unwrap());
    for (&g, &w) in back.iter().zip(ramp().data()) {
        assert!(g == w as f64 || (g.is_nan() && w.is_nan()), "{g} {w}");
    }
    // A given mapping overrides the recorded one.
    let raw = read_all(
        &read_png(
            &p,
            Some(Scaling {
                scale: 1.0,
                offset: 0.0,
            }),
        )
        .unwrap(),
    );
    assert_eq!(raw[0], (-120.5 + 200.0) / 0.25);
    // Without tEXt, the sidecar alone gives the mapping (a PNG scaled by
    // `gdal_edit -scale`).
    let bare = t.path().join("bare.png");
    let data: Vec<u8> = (0..6u16).flat_map(|v| (v * 1000).to_be_bytes()).collect();
    let mut bytes = Vec::new();
    {
        let mut e = png::Encoder::new(&mut bytes, 3, 2);
        e.set_color(png::ColorType::Grayscale);
        e.set_depth(png::BitDepth::Sixteen);
        let mut w = e.write_header().unwrap();
        w.write_image_data(&data).unwrap();
    }
    std::fs::write(&bare, bytes).unwrap();
    assert_eq!(recorded_scaling(&bare).unwrap(), None);
    std::fs::write(
        t.path().join("bare.png.aux.xml"),
        "<PAMDataset>\n  <PAMRasterBand band=\"1\">\n    <Offset>-10</Offset>\n    <Scale>0.5</Scale>\n  </PAMRasterBand>\n</PAMDataset>\n",
    )
    .unwrap();
    let v = read_all(&read_png(&bare, None).unwrap());
    assert_eq!(v, vec![-10.0, 490.0, 990.0, 1490.0, 1990.0, 2490.0]);
}

#[test]
fn png_output_mapping_is_honoured_and_a_misfit_refused() {
    let t = tempfile::tempdir().unwrap();
    let src = t.path().join("r.asc");
    let g = ramp();
    let mut geo = orogen::raster::GeoRef::pixel();
    geo.nodata = Some(-9999.0);
    orogen::io::ascii::write_ascii(&src, &orogen::raster::AnyGrid::F32(g.clone()), &geo).unwrap();
    let out = t.path().join("o.png");
    ok(orogen()
        .args(["export"])
        .arg(&src)
        .arg("-o")
        .arg(&out)
        .args(["--png-out-scale", "0.25", "--png-out-offset", "-200", "-q"]));
    assert_eq!(
        recorded_scaling(&out).unwrap(),
        Some(Scaling {
            scale: 0.25,
            offset: -200.0
        })
    );
    let back = read_all(&read_png(&out, None).unwrap());
    assert_eq!(back[1], g.data()[1] as f64);
    // The data reach 1.5 + 13.25 * 22 + 0.75 * 8 ≈ 178.5 m: above what
    // 0.001 m steps from 0 can hold (65.535 m), and below the offset 0.
    let bad = t.path().join("bad.png");
    let e = fails(
        orogen()
            .args(["export"])
            .arg(&src)
            .arg("-o")
            .arg(&bad)
            .args(["--png-out-scale", "0.001", "--png-out-offset", "0"]),
    );
    assert!(
        e.contains("do not fit the PNG mapping") && e.contains("--png-out-scale"),
        "{e}"
    );
    assert!(!bad.exists() && !t.path().join("bad.png.aux.xml").exists());
}
