//! Web-map pyramids: projections against GDAL's (PROJ) figures, encodings
//! against their published formulas, tile pixels against the DEM they were
//! cut from, MBTiles/PMTiles read back and byte-identical across runs.

use orogen::raster::{AnyGrid, Crs, GeoRef, Grid, MemRaster};
use orogen::tiles::archive::{write_mbtiles, write_pmtiles};
use orogen::tiles::proj::{lonlat_to_merc, merc_to_lonlat, TransverseMercator};
use orogen::tiles::pyramid::{encode_pixels, pixel_merc, tile_of};
use orogen::tiles::{build_pyramid, Encoding, PyramidOptions, Resampling};

#[test]
fn utm_matches_proj_to_the_millimetre() {
    // gdaltransform -s_srs EPSG:4326 -t_srs EPSG:326zz/327zz/25834 (GDAL 3.6, PROJ 9).
    let cases = [
        (33, true, 15.5, 52.25, 534133.62367744, 5788962.28075772),
        (33, true, 12.0, 0.5, 166034.098266797, 55341.388215555),
        (33, true, 18.9, 49.1, 784653.090679538, 5445900.28591061),
        (19, false, -70.0, -32.65, 406215.075462894, 6387071.4281892),
        (19, false, -71.2, -33.9, 296577.968319636, 6246752.86090683),
        (34, true, 20.5, 54.1, 467303.957945693, 5994763.36759943),
    ];
    for (zone, north, lon, lat, e, n) in cases {
        let tm = TransverseMercator::utm(zone, north);
        let (x, y) = tm.forward(lon, lat);
        assert!(
            (x - e).abs() < 1e-3 && (y - n).abs() < 1e-3,
            "{lon},{lat}: {x},{y} vs {e},{n}"
        );
        let (lo, la) = tm.inverse(e, n);
        assert!(
            (lo - lon).abs() < 1e-8 && (la - lat).abs() < 1e-8,
            "{lo},{la}"
        );
    }
    // Web Mercator: round trip and a known value (lon 180 = half the equator).
    let (x, _) = lonlat_to_merc(180.0, 0.0);
    assert!((x - 20037508.342789244).abs() < 1e-6);
    let (lo, la) = merc_to_lonlat(1_234_567.0, 6_543_210.0);
    let (x2, y2) = lonlat_to_merc(lo, la);
    assert!((x2 - 1_234_567.0).abs() < 1e-6 && (y2 - 6_543_210.0).abs() < 1e-6);
}

/// Mapbox Terrain-RGB as published (Mapbox docs, "Terrain-RGB"):
/// h = −10000 + (R·65536 + G·256 + B)·0.1 m.
fn terrain_rgb(r: u8, g: u8, b: u8) -> f64 {
    -10000.0 + (r as f64 * 65536.0 + g as f64 * 256.0 + b as f64) * 0.1
}

/// Terrarium as published (Mapzen / AWS Terrain Tiles):
/// h = R·256 + G + B/256 − 32768 m.
fn terrarium(r: u8, g: u8, b: u8) -> f64 {
    r as f64 * 256.0 + g as f64 + b as f64 / 256.0 - 32768.0
}

#[test]
fn encodings_give_the_published_pixels() {
    // By hand. Terrain-RGB: 0 m = 100000 = 0x0186A0, 1234.5 m = 112345 =
    // 0x01B6D9, −10000 m = 0, 8848 m = 188480 = 0x02E040, −420.2 m (f32:
    // −420.20001) = 95798 = 0x0176B6. Terrarium (heights that are whole
    // 256ths, so that no rounding rule matters): 0 m = 32768 = (128, 0, 0),
    // 1234.5 m = 34002.5 = (132, 210, 128), −10000 m = 22768 = (88, 240, 0),
    // −420.25 m = 32347.75 = (126, 91, 192).
    let lut = [[0u8; 3]; 256];
    let rgb: [(f32, [u8; 3]); 5] = [
        (0.0, [1, 134, 160]),
        (1234.5, [1, 182, 217]),
        (-10000.0, [0, 0, 0]),
        (8848.0, [2, 224, 64]),
        (-420.2, [1, 118, 54]),
    ];
    let tr: [(f32, [u8; 3]); 5] = [
        (0.0, [128, 0, 0]),
        (1234.5, [132, 210, 128]),
        (-10000.0, [88, 240, 0]),
        (8848.0, [162, 144, 0]),
        (-420.25, [126, 91, 192]),
    ];
    for (enc, cases) in [(Encoding::TerrainRgb, rgb), (Encoding::Terrarium, tr)] {
        for (h, c) in cases {
            let a = encode_pixels(&[h], &enc, &lut, (0.0, 1.0));
            assert_eq!(&a[..4], &[c[0], c[1], c[2], 255], "{enc:?} {h}");
        }
    }
    // The crate's decoders are the published formulas.
    for r in (0..=255u8).step_by(17) {
        for g in (0..=255u8).step_by(15) {
            for b in [0u8, 1, 127, 128, 255] {
                let d = orogen::tiles::pyramid::decode_terrain_rgb(r, g, b);
                assert!(
                    (d - terrain_rgb(r, g, b)).abs() < 1e-6,
                    "Terrain-RGB {r} {g} {b}"
                );
                let d = orogen::tiles::pyramid::decode_terrarium(r, g, b);
                assert!(
                    (d - terrarium(r, g, b)).abs() < 1e-9,
                    "Terrarium {r} {g} {b}"
                );
            }
        }
    }
}

#[test]
fn encodings_decode_within_their_precision() {
    let lut = [[0u8; 3]; 256];
    let heights: Vec<f32> = (0..2000)
        .map(|i| -420.5 + i as f32 * 4.4321)
        .chain([f32::NAN])
        .collect();
    for (enc, tol) in [
        (Encoding::TerrainRgb, 0.05 + 1e-3),
        (Encoding::Terrarium, 1.0 / 256.0 + 1e-3),
    ] {
        let rgba = encode_pixels(&heights, &enc, &lut, (0.0, 1.0));
        for (i, &h) in heights.iter().enumerate() {
            let p = &rgba[i * 4..i * 4 + 4];
            if h.is_nan() {
                assert_eq!(p[3], 0, "nodata is transparent");
                continue;
            }
            assert_eq!(p[3], 255);
            let d = match enc {
                Encoding::TerrainRgb => terrain_rgb(p[0], p[1], p[2]),
                _ => terrarium(p[0], p[1], p[2]),
            };
            assert!((d - h as f64).abs() <= tol, "{enc:?} {h} -> {d}");
        }
    }
}

/// A geographic DEM: a smooth surface over 2 x 1.5 degrees around Kraków.
fn geo_dem() -> (MemRaster, Grid<f32>) {
    let (w, h) = (600, 450);
    let g = Grid::from_fn(w, h, |x, y| {
        if (x / 40 + y / 40) % 7 == 3 && x % 40 < 5 {
            f32::NAN
        } else {
            200.0 + (x as f32 * 0.02).sin() * 150.0 + (y as f32 * 0.015).cos() * 90.0
        }
    });
    let cell = 2.0 / w as f64;
    let georef = GeoRef {
        transform: [19.0, cell, 0.0, 50.8, 0.0, -cell],
        crs: Crs::wgs84(),
        nodata: None,
        georeferenced: true,
        ..GeoRef::pixel()
    };
    (
        MemRaster::new(AnyGrid::F32(g.clone()), georef, "geo.mem"),
        g,
    )
}

fn decode_png(bytes: &[u8]) -> Vec<u8> {
    let dec = png::Decoder::new(std::io::Cursor::new(bytes));
    let mut r = dec.read_info().unwrap();
    let mut buf = vec![0; r.output_buffer_size().unwrap()];
    r.next_frame(&mut buf).unwrap();
    buf
}

#[test]
fn tile_pixels_are_the_dem_at_that_point() {
    let tmp = tempfile::tempdir().unwrap();
    let (src, g) = geo_dem();
    let opts = PyramidOptions {
        encoding: Encoding::Terrarium,
        resampling: Resampling::Bilinear,
        min_zoom: None,
        max_zoom: None,
    };
    let dir = tmp.path().join("t");
    let info = build_pyramid(&src, &dir, &opts, None).unwrap();
    // 2/600 degree cells ≈ 240 m east-west at 50° N: zoom 10 pixels are ~98 m... the
    // first zoom with pixels no larger than the cells.
    assert!(info.max_zoom >= 9 && info.max_zoom <= 10, "{info:?}");
    assert!((info.bounds[0] - 19.0).abs() < 1e-9 && (info.bounds[3] - 50.8).abs() < 1e-9);
    let z = info.max_zoom;
    let mut checked = 0;
    let mut worst = 0f64;
    for (lon, lat) in [(19.5, 50.5), (20.3, 49.7), (19.05, 49.4), (20.9, 50.1)] {
        let (tx, ty) = tile_of(lon, lat, z);
        let p = dir.join(format!("{z}/{tx}/{ty}.png"));
        let rgba = decode_png(&std::fs::read(&p).unwrap());
        for (px, py) in [(10usize, 20usize), (128, 128), (250, 3)] {
            let (mx, my) = pixel_merc(z, tx, ty, px as f64, py as f64);
            let (plon, plat) = merc_to_lonlat(mx, my);
            // Independent bilinear on the source grid (cell centres at +0.5).
            let fx = (plon - 19.0) / (2.0 / 600.0) - 0.5;
            let fy = (50.8 - plat) / (2.0 / 600.0) - 0.5;
            if fx < 0.0 || fy < 0.0 || fx + 1.0 >= 600.0 || fy + 1.0 >= 450.0 {
                continue; // beyond the raster
            }
            let (x0, y0) = (fx.floor() as usize, fy.floor() as usize);
            let vals = [
                g.get(x0, y0),
                g.get(x0 + 1, y0),
                g.get(x0, y0 + 1),
                g.get(x0 + 1, y0 + 1),
            ];
            if vals.iter().any(|v| v.is_nan()) {
                continue;
            }
            let (tx_, ty_) = (fx - x0 as f64, fy - y0 as f64);
            let want = (vals[0] as f64 * (1.0 - tx_) + vals[1] as f64 * tx_) * (1.0 - ty_)
                + (vals[2] as f64 * (1.0 - tx_) + vals[3] as f64 * tx_) * ty_;
            let i = (py * 256 + px) * 4;
            let got = terrarium(rgba[i], rgba[i + 1], rgba[i + 2]);
            assert_eq!(
                rgba[i + 3],
                255,
                "transparent at {lon},{lat} px {px},{py} tile {z}/{tx}/{ty}: src cell {fx},{fy}"
            );
            worst = worst.max((got - want).abs());
            checked += 1;
        }
    }
    assert!(checked >= 8, "{checked}");
    // Encoding step 1/256 m plus the control-grid interpolation of positions.
    assert!(worst < 0.05, "worst {worst} m");

    // Archives: read back, TMS flip, and identical bytes on a second run.
    let mb = tmp.path().join("a.mbtiles");
    let pm = tmp.path().join("a.pmtiles");
    let n = write_mbtiles(&dir, &info, &mb).unwrap();
    assert_eq!(n, info.tiles);
    write_pmtiles(&dir, &info, &pm).unwrap();
    let db = rusqlite::Connection::open(&mb).unwrap();
    let count: i64 = db
        .query_row("SELECT COUNT(*) FROM tiles", [], |r| r.get(0))
        .unwrap();
    assert_eq!(count as u64, info.tiles);
    let (tx, ty) = tile_of(19.5, 50.5, z);
    let row = (1i64 << z) - 1 - ty as i64;
    let blob: Vec<u8> = db
        .query_row(
            "SELECT tile_data FROM tiles WHERE zoom_level=?1 AND tile_column=?2 AND tile_row=?3",
            rusqlite::params![z as i64, tx as i64, row],
            |r| r.get(0),
        )
        .unwrap();
    assert_eq!(
        blob,
        std::fs::read(dir.join(format!("{z}/{tx}/{ty}.png"))).unwrap()
    );
    let head = std::fs::read(&pm).unwrap();
    assert_eq!(&head[0..7], b"PMTiles");
    assert_eq!(head[7], 3);
    let dir2 = tmp.path().join("t2");
    let info2 = build_pyramid(&src, &dir2, &opts, None).unwrap();
    let (mb2, pm2) = (tmp.path().join("b.mbtiles"), tmp.path().join("b.pmtiles"));
    write_mbtiles(&dir2, &info2, &mb2).unwrap();
    write_pmtiles(&dir2, &info2, &pm2).unwrap();
    assert!(std::fs::read(&pm).unwrap() == std::fs::read(&pm2).unwrap());
    assert!(std::fs::read(&mb).unwrap() == std::fs::read(&mb2).unwrap());
}

#[test]
fn lower_zooms_are_means_of_their_children_and_nodata_is_transparent() {
    let tmp = tempfile::tempdir().unwrap();
    let (src, _) = geo_dem();
    let opts = PyramidOptions {
        encoding: Encoding::TerrainRgb,
        resampling: Resampling::Bilinear,
        min_zoom: Some(7),
        max_zoom: Some(9),
    };
    let dir = tmp.path().join("t");
    let info = build_pyramid(&src, &dir, &opts, None).unwrap();
    assert_eq!((info.min_zoom, info.max_zoom), (7, 9));
    // Pick a z8 tile and compare a pixel with the mean of its 2x2 children at z9.
    let (x8, y8) = tile_of(19.8, 50.2, 8);
    let parent = decode_png(&std::fs::read(dir.join(format!("8/{x8}/{y8}.png"))).unwrap());
    let mut checked = 0;
    for (px, py) in [(5usize, 7usize), (130, 60), (200, 201)] {
        let (cx, cy) = (2 * x8 + (px / 128) as u32, 2 * y8 + (py / 128) as u32);
        let Ok(bytes) = std::fs::read(dir.join(format!("9/{cx}/{cy}.png"))) else {
            continue;
        };
        let child = decode_png(&bytes);
        let (lx, ly) = ((px % 128) * 2, (py % 128) * 2);
        let mut vals = vec![];
        for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
            let i = ((ly + dy) * 256 + lx + dx) * 4;
            if child[i + 3] == 255 {
                vals.push(terrain_rgb(child[i], child[i + 1], child[i + 2]));
            }
        }
        let i = (py * 256 + px) * 4;
        if vals.is_empty() {
            assert_eq!(parent[i + 3], 0);
            continue;
        }
        let want = vals.iter().sum::<f64>() / vals.len() as f64;
        let got = terrain_rgb(parent[i], parent[i + 1], parent[i + 2]);
        // Children are stored at 0.1 m steps; the parent is made from unrounded values.
        assert!((got - want).abs() <= 0.1 + 1e-6, "{got} vs {want}");
        checked += 1;
    }
    assert!(checked >= 2);
    // Tiles beyond the raster are not written; zooms above min are not written.
    assert!(!dir.join("6").exists());
    let (ox, oy) = tile_of(25.0, 45.0, 9);
    assert!(!dir.join(format!("9/{ox}/{oy}.png")).exists());
}

#[test]
fn unsupported_crs_is_a_clear_error() {
    let tmp = tempfile::tempdir().unwrap();
    let g: Grid<f32> = Grid::new(50, 50, 1.0);
    let georef = GeoRef {
        transform: [0.0, 10.0, 0.0, 0.0, 0.0, -10.0],
        crs: Crs::projected(2180),
        georeferenced: true,
        ..GeoRef::pixel()
    };
    let src = MemRaster::new(AnyGrid::F32(g), georef, "pl.mem");
    let opts = PyramidOptions {
        encoding: Encoding::TerrainRgb,
        resampling: Resampling::Bilinear,
        min_zoom: None,
        max_zoom: None,
    };
    let e = build_pyramid(&src, &tmp.path().join("x"), &opts, None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("EPSG:2180") && e.contains("gdalwarp"), "{e}");
}
