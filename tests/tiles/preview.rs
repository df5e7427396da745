//! Preview renderer: lighting direction on a cone, transparency of nodata,
//! output size, ramp-end colours on flat plateaus, block means against brute
//! force, bounded reads on a large procedural source, and real DEMs (written
//! to `$OROGEN_RENDER_DIR` when set, for looking at).

use orogen::io::hgt::read_hgt;
use orogen::io::mosaic::Mosaic;
use orogen::io::png::read_png_heightmap;
use orogen::raster::{AnyGrid, Crs, GeoRef, Grid, MemRaster, RasterInfo, RasterSource, Window};
use orogen::tiles::render::{
    downsample_mean, ramp_ends, render_preview, RenderKind, RenderOptions, CHUNK_CELLS,
};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

/// Decode an RGBA PNG with the `png` crate: (width, height, pixels).
fn load(p: &Path) -> (usize, usize, Vec<[u8; 4]>) {
    let d = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(p).unwrap()));
    let mut r = d.read_info().unwrap();
    let mut buf = vec![0; r.output_buffer_size().unwrap()];
    let info = r.next_frame(&mut buf).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgba);
    let px = buf[..info.buffer_size()]
        .chunks_exact(4)
        .map(|c| [c[0], c[1], c[2], c[3]])
        .collect();
    (info.width as usize, info.height as usize, px)
}

fn mem(g: Grid<f32>, cell: f64) -> MemRaster {
    MemRaster::new(
        AnyGrid::F32(g),
        GeoRef::north_up(0.0, 0.0, cell, Crs::projected(32632)),
        "mem.tif",
    )
}

#[test]
fn cone_is_brightest_on_the_north_west_flank() {
    let n = 101;
    let c = 50.0;
    let g = Grid::from_fn(n, n, |x, y| {
        let d = ((x as f32 - c).powi(2) + (y as f32 - c).powi(2)).sqrt();
        (2000.0 - 15.0 * d).max(1000.0)
    });
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cone.png");
    let opts = RenderOptions {
        sea: false,
        ..Default::default()
    };
    let info = render_preview(&mem(g.clone(), 10.0), &out, &opts).unwrap();
    assert_eq!((info.width, info.height, info.factor), (101, 101, 1));
    let (w, _, px) = load(&out);
    // Compare pixels on the cone's flanks at the same distance from the apex
    // (same tint): the one facing the light (NW, azimuth 315) is brightest.
    let lum = |x: usize, y: usize| px[y * w + x].iter().take(3).map(|&v| v as u32).sum::<u32>();
    // On a cone of constant slope the Lambertian shade is
    // A + B·cos(a − 315°) around a ring (a the flank's azimuth), so the
    // first harmonic of the ring's luminance points at the light: fitted over
    // rings at three radii (pixel rounding moves each sample by < 0.5 px).
    let (mut sx, mut sy) = (0.0f64, 0.0f64);
    for r in [16.0f64, 20.0, 24.0] {
        for k in 0..720 {
            let a = (k as f64 * 0.5).to_radians();
            // Map azimuth a (clockwise from north) to image coordinates (y down).
            let (x, y) = (
                (c as f64 + r * a.sin()).round() as usize,
                (c as f64 - r * a.cos()).round() as usize,
            );
            let l = lum(x, y) as f64;
            sx += l * a.sin();
            sy += l * a.cos();
        }
    }
    let fitted = sx.atan2(sy).to_degrees().rem_euclid(360.0);
    assert!(
        (fitted - 315.0).abs() <= 0.5,
        "light fitted at azimuth {fitted}"
    );
    // The sunlit flank is lighter than the opposite one.
    assert!(
        lum(36, 36) > lum(64, 64) + 60,
        "{} vs {}",
        lum(36, 36),
        lum(64, 64)
    );
}

#[test]
fn nodata_is_transparent_and_size_respects_max_size() {
    let g = Grid::from_fn(1000, 300, |x, y| {
        if x < 100 && y < 50 {
            f32::NAN
        } else {
            (x + y) as f32
        }
    });
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("s.png");
    let opts = RenderOptions {
        max_size: 100,
        ..Default::default()
    };
    let info = render_preview(&mem(g.clone(), 30.0), &out, &opts).unwrap();
    assert_eq!((info.width, info.height, info.factor), (100, 30, 10));
    let (w, h, px) = load(&out);
    assert_eq!((w, h), (100, 30));
    for y in 0..h {
        for x in 0..w {
            let want = if x < 10 && y < 5 { 0 } else { 255 };
            assert_eq!(px[y * w + x][3], want, "alpha at ({x}, {y})");
        }
    }
    // A raster without valid cells renders fully transparent.
    let empty = Grid::new(50, 40, f32::NAN);
    let info = render_preview(
        &mem(empty, 1.0),
        &out,
        &RenderOptions {
            legend: true,
            ..Default::default()
        },
    )
    .unwrap();
    assert!(info.data_min.is_nan() && !info.legend);
    let (_, _, px) = load(&out);
    assert!(px.iter().all(|p| p[3] == 0));
    // With a legend: extra rows below, all opaque; odd sizes round up.
    let g = Grid::from_fn(333, 70, |x, _| x as f32);
    let opts = RenderOptions {
        max_size: 64,
        legend: true,
        kind: RenderKind::Grey,
        ..Default::default()
    };
    let info = render_preview(&mem(g, 1.0), &out, &opts).unwrap();
    assert_eq!(info.factor, 6);
    assert_eq!((info.width, info.height), (56, 12));
    assert!(!info.legend, "too narrow for a legend");
    let g = Grid::from_fn(640, 100, |x, _| x as f32);
    let info = render_preview(
        &mem(g, 1.0),
        &out,
        &RenderOptions {
            max_size: 320,
            legend: true,
            ..Default::default()
        },
    )
    .unwrap();
    assert!(info.legend);
    let (w, h, px) = load(&out);
    assert_eq!((w, h), (320, info.height));
    assert!(h > 50 && px[(h - 1) * w..].iter().all(|p| p[3] == 255));
}

#[test]
fn min_and_max_take_the_ramp_ends() {
    // Two flat plateaus: interior pixels have zero gradient, so the hillshade
    // leaves their tint unchanged.
    let g = Grid::from_fn(60, 20, |x, _| if x < 30 { 120.0 } else { 870.0 });
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("p.png");
    for (kind, ramp) in [
        (RenderKind::Elevation, "terrain"),
        (RenderKind::Ramp("viridis".into()), "viridis"),
        (RenderKind::Ramp("magma".into()), "magma"),
        (RenderKind::Grey, "grey"),
    ] {
        let info = render_preview(
            &mem(g.clone(), 25.0),
            &out,
            &RenderOptions {
                kind,
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(info.range, (120.0, 870.0));
        assert!(!info.sea);
        let (w, _, px) = load(&out);
        let (lo, hi) = ramp_ends(ramp).unwrap();
        for y in 2..18 {
            assert_eq!(px[y * w + 10][..3], lo, "{ramp} min");
            assert_eq!(px[y * w + 50][..3], hi, "{ramp} max");
        }
    }
    assert!(ramp_ends("rainbow").is_err());
}

#[test]
fn sea_is_blue_only_when_the_data_has_sea() {
    let g = Grid::from_fn(40, 10, |x, _| if x < 20 { 0.0 } else { 300.0 });
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sea.png");
    let info = render_preview(&mem(g, 90.0), &out, &RenderOptions::default()).unwrap();
    assert!(info.sea);
    let (w, _, px) = load(&out);
    let p = px[5 * w + 5];
    assert!(p[2] > p[0] + 50 && p[2] > p[1], "sea pixel {p:?} is blue");
    assert_eq!(px[5 * w + 35][..3], ramp_ends("terrain").unwrap().1);
}

#[test]
fn block_means_match_brute_force() {
    let g = Grid::from_fn(37, 23, |x, y| {
        if (x * 3 + y) % 11 == 0 {
            f32::NAN
        } else {
            (x * x) as f32 * 0.5 - y as f32 * 3.0
        }
    });
    // A 4x4 block of nodata gives NaN.
    let mut g = g;
    for y in 4..8 {
        for x in 8..12 {
            g.set(x, y, f32::NAN);
        }
    }
    let src = mem(g.clone(), 1.0);
    let (small, lo, hi) = downsample_mean(&src, 4).unwrap();
    assert_eq!((small.width(), small.height()), (10, 6));
    let valid: Vec<f32> = g.data().iter().copied().filter(|v| !v.is_nan()).collect();
    assert_eq!(
        lo,
        valid.iter().copied().fold(f32::INFINITY, f32::min) as f64
    );
    assert_eq!(
        hi,
        valid.iter().copied().fold(f32::NEG_INFINITY, f32::max) as f64
    );
    for by in 0..6 {
        for bx in 0..10 {
            let (mut s, mut n) = (0.0f64, 0);
            for y in by * 4..(by * 4 + 4).min(23) {
                for x in bx * 4..(bx * 4 + 4).min(37) {
                    let v = g.get(x, y);
                    if !v.is_nan() {
                        s += v as f64;
                        n += 1;
                    }
                }
            }
            let got = small.get(bx, by);
            if n == 0 {
                assert!(got.is_nan());
            } else {
                assert!(
                    (got as f64 - s / n as f64).abs() < 1e-4,
                    "block ({bx}, {by})"
                );
            }
        }
    }
}

/// A procedural raster that is never held in memory; records its reads.
struct Procedural {
    info: RasterInfo,
    max_cells: AtomicUsize,
    total: AtomicUsize,
}
impl RasterSource for Procedural {
    fn info(&self) -> &RasterInfo {
        &self.info
    }
    fn read_native(&self, win: Window) -> orogen::Result<AnyGrid> {
        self.max_cells.fetch_max(win.len(), Ordering::SeqCst);
        self.total.fetch_add(win.len(), Ordering::SeqCst);
        Ok(AnyGrid::F32(Grid::from_fn(win.w, win.h, |x, y| {
            let (gx, gy) = ((win.x + x as i64) as f32, (win.y + y as i64) as f32);
            (gx * 0.01).sin() * 300.0 + (gy * 0.013).cos() * 200.0 + 1000.0
        })))
    }
}

#[test]
fn large_sources_are_streamed_in_bounded_chunks() {
    let (w, h) = (6000, 5000);
    let src = Procedural {
        info: RasterInfo {
            width: w,
            height: h,
            dtype: orogen::raster::DType::F32,
            georef: GeoRef::north_up(0.0, 0.0, 30.0, Crs::projected(32632)),
            block: (256, 256),
            path: PathBuf::from("procedural"),
        },
        max_cells: AtomicUsize::new(0),
        total: AtomicUsize::new(0),
    };
    let dir = tempfile::tempdir().unwrap();
    let info = render_preview(
        &src,
        &dir.path().join("big.png"),
        &RenderOptions {
            max_size: 300,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!((info.width, info.height, info.factor), (300, 250, 20));
    assert!(src.max_cells.load(Ordering::SeqCst) <= CHUNK_CELLS);
    assert_eq!(
        src.total.load(Ordering::SeqCst),
        w * h,
        "every cell read exactly once"
    );
    // Blocks larger than a chunk (factor 3000) are read in row slices.
    src.total.store(0, Ordering::SeqCst);
    let info = render_preview(
        &src,
        &dir.path().join("tiny.png"),
        &RenderOptions {
            max_size: 2,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!((info.width, info.height, info.factor), (2, 2, 3000));
    assert!(src.max_cells.load(Ordering::SeqCst) <= CHUNK_CELLS);
    assert_eq!(src.total.load(Ordering::SeqCst), w * h);
}

fn out_dir(tmp: &Path) -> PathBuf {
    std::env::var_os("OROGEN_RENDER_DIR").map_or(tmp.to_path_buf(), PathBuf::from)
}

/// The 200 x 300 crop of the Mont Blanc PNG in `tests/data`: the source's
/// range as GDAL reports it, one opaque pixel per cell, and a relief that
/// shows (most pixels differ from their neighbours).
#[test]
fn real_dem_crop_renders() {
    let dir = tempfile::tempdir().unwrap();
    let od = out_dir(dir.path());
    let p = crate::common::test_data("terraindescriptors_alps-montblanc_crop.png");
    let r = read_png_heightmap(p, (4810.0 - 454.0) / 65535.0, 454.0).unwrap();
    let opts = RenderOptions {
        cell_size_m: Some(60000.0 / 647.0),
        ..Default::default()
    };
    let out = od.join("montblanc_crop.png");
    let info = render_preview(&r, &out, &opts).unwrap();
    assert_eq!((info.width, info.height, info.factor), (200, 300, 1));
    // gdalinfo -mm of the same window of the GeoTIFF: 785.344, 4810.000.
    assert!((info.data_min - 785.344).abs() < 1e-3 && (info.data_max - 4810.0).abs() < 1e-3);
    assert!(!info.sea && !info.legend);
    let (w, h, px) = load(&out);
    assert_eq!((w, h), (200, 300));
    assert!(
        px.iter().all(|p| p[3] == 255),
        "a cell with data drawn transparent"
    );
    let differ = (1..w * h).filter(|&i| px[i] != px[i - 1]).count();
    assert!(
        differ > w * h * 3 / 4,
        "only {differ} pixels differ from their left neighbour"
    );
}

#[test]
fn real_dems_render() {
    let dir = tempfile::tempdir().unwrap();
    let od = out_dir(dir.path());
    let (a, b) = (
        crate::common::test_data("srtm/N43E006.hgt"),
        crate::common::test_data("srtm/N43E007.hgt"),
    );
    let m = Mosaic::new(vec![
        Box::new(read_hgt(a).unwrap()),
        Box::new(read_hgt(b).unwrap()),
    ])
    .unwrap();
    let opts = RenderOptions {
        max_size: 1200,
        legend: true,
        ..Default::default()
    };
    let info = render_preview(&m, &od.join("n43_e006_e007.png"), &opts).unwrap();
    assert_eq!(info.factor, 3);
    assert_eq!((info.data_min, info.data_max), (-16.0, 2060.0));
    assert!(info.sea, "the Mediterranean is in the tiles");
    let p = crate::common::test_data("terraindescriptors_alps-montblanc.png");
    let r = read_png_heightmap(p, (4810.0 - 454.0) / 65535.0, 454.0).unwrap();
    let opts = RenderOptions {
        legend: true,
        cell_size_m: Some(60000.0 / 647.0),
        ..Default::default()
    };
    let info = render_preview(&r, &od.join("montblanc.png"), &opts).unwrap();
    assert!(!info.sea);
    assert!((info.data_min - 454.0).abs() < 1e-3 && (info.data_max - 4810.0).abs() < 1e-3);
}
