//! Cloud-Optimized GeoTIFF writer: the layout rules of the COG specification
//! (as GDAL's validator checks them), overview values against a brute-force
//! 2x2 reduction, independence from the engine's tile size. The file is read
//! back with the `tiff` crate, which shares no code with the writer.

use orogen::exec::{EngineConfig, LocalEngine};
use orogen::io::geotiff::{CogWriter, Compression, Resampling, WriteOptions};
use orogen::raster::{AnyGrid, GeoRef, Grid, MemRaster, RasterSource, TileLayout};
use std::fs::File;
use std::path::Path;
use tiff::decoder::{Decoder, DecodingResult};
use tiff::tags::Tag;

fn smooth(w: usize, h: usize, seed: u64) -> Grid<f32> {
    let mut s = seed;
    Grid::from_fn(w, h, |x, y| {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let noise = ((s >> 33) % 1000) as f32 / 100.0;
        if (s >> 20).is_multiple_of(97) {
            f32::NAN
        } else {
            (x as f32 * 0.05).sin() * 300.0 + (y as f32 * 0.031).cos() * 200.0 + noise
        }
    })
}

/// Write `src` through the engine with work tiles of `tile` cells.
fn write_cog(src: &MemRaster, path: &Path, opts: &WriteOptions, r: Resampling, tile: usize) {
    let info = src.info().clone();
    let sink = Box::new(
        CogWriter::create(
            path,
            info.width,
            info.height,
            info.dtype,
            &info.georef,
            opts,
            r,
        )
        .unwrap(),
    );
    let cfg = EngineConfig {
        threads: 2,
        memory_budget: 256 << 20,
        progress: false,
        observer: None,
        engine: Default::default(),
    };
    let engine = LocalEngine::new(cfg);
    orogen::exec::copy(
        src,
        sink,
        TileLayout::new(info.width, info.height, tile),
        &engine,
    )
    .unwrap();
}

/// Brute-force next level: mean of the finite cells of each 2x2 footprint
/// (NaN when none), or its top-left cell.
fn reduce(g: &[f64], w: usize, h: usize, nearest: bool) -> (Vec<f64>, usize, usize) {
    let (ow, oh) = (w.div_ceil(2), h.div_ceil(2));
    let mut out = vec![0.0; ow * oh];
    for oy in 0..oh {
        for ox in 0..ow {
            if nearest {
                out[oy * ow + ox] = g[2 * oy * w + 2 * ox];
                continue;
            }
            let mut vals = vec![];
            for y in 2 * oy..(2 * oy + 2).min(h) {
                for x in 2 * ox..(2 * ox + 2).min(w) {
                    if g[y * w + x].is_finite() {
                        vals.push(g[y * w + x]);
                    }
                }
            }
            out[oy * ow + ox] = if vals.is_empty() {
                f64::NAN
            } else {
                vals.iter().sum::<f64>() / vals.len() as f64
            };
        }
    }
    (out, ow, oh)
}

struct Level {
    w: usize,
    h: usize,
    offsets: Vec<u64>,
    counts: Vec<u64>,
    values: Vec<f64>,
}

fn read_levels(path: &Path, nodata: Option<f64>) -> Vec<Level> {
    let mut d = Decoder::new(File::open(path).unwrap()).unwrap();
    let mut out = vec![];
    loop {
        let (w, h) = d.dimensions().unwrap();
        let offsets = d.get_tag_u64_vec(Tag::TileOffsets).unwrap();
        let counts = d.get_tag_u64_vec(Tag::TileByteCounts).unwrap();
        let values: Vec<f64> = match d.read_image().unwrap() {
            DecodingResult::F32(v) => v.into_iter().map(|x| x as f64).collect(),
            DecodingResult::I16(v) => v.into_iter().map(|x| x as f64).collect(),
            DecodingResult::U8(v) => v.into_iter().map(|x| x as f64).collect(),
            _ => panic!("unexpected type"),
        };
        let values = values
            .into_iter()
            .map(|v| if Some(v) == nodata { f64::NAN } else { v })
            .collect();
        out.push(Level {
            w: w as usize,
            h: h as usize,
            offsets,
            counts,
            values,
        });
        if !d.more_images() {
            break;
        }
        d.next_image().unwrap();
    }
    out
}

/// The rules of GDAL's validate_cloud_optimized_geotiff (with --full-check),
/// checked on the raw bytes.
fn check_layout(path: &Path, block: usize) {
    let bytes = std::fs::read(path).unwrap();
    let bigtiff = bytes[2] == 43;
    let header = if bigtiff { 16 } else { 8 };
    let first_ifd = if bigtiff {
        u64::from_le_bytes(bytes[8..16].try_into().unwrap())
    } else {
        u32::from_le_bytes(bytes[4..8].try_into().unwrap()) as u64
    } as usize;
    let ghost = std::str::from_utf8(&bytes[header..first_ifd]).unwrap();
    assert!(
        ghost.starts_with("GDAL_STRUCTURAL_METADATA_SIZE="),
        "{ghost}"
    );
    let size: usize = ghost[30..36].parse().unwrap();
    let mut expect = header + 43 + size;
    expect += expect % 2;
    assert_eq!(
        first_ifd, expect,
        "main IFD right after the structural metadata"
    );
    for key in [
        "LAYOUT=IFDS_BEFORE_DATA",
        "BLOCK_ORDER=ROW_MAJOR",
        "BLOCK_LEADER=SIZE_AS_UINT4",
        "BLOCK_TRAILER=LAST_4_BYTES_REPEATED",
    ] {
        assert!(ghost.contains(key), "{key}");
    }
    // IFD chain: increasing offsets, all before any data.
    let mut ifds = vec![];
    let mut at = first_ifd;
    while at != 0 {
        ifds.push(at);
        let (n, entry, cnt) = if bigtiff {
            (
                u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap()) as usize,
                20,
                8,
            )
        } else {
            (
                u16::from_le_bytes(bytes[at..at + 2].try_into().unwrap()) as usize,
                12,
                2,
            )
        };
        let next_at = at + cnt + n * entry;
        at = if bigtiff {
            u64::from_le_bytes(bytes[next_at..next_at + 8].try_into().unwrap()) as usize
        } else {
            u32::from_le_bytes(bytes[next_at..next_at + 4].try_into().unwrap()) as usize
        };
    }
    assert!(ifds.windows(2).all(|p| p[0] < p[1]));
    let levels = read_levels(path, None);
    assert_eq!(levels.len(), ifds.len());
    for (i, l) in levels.iter().enumerate() {
        if i > 0 {
            assert_eq!(l.w, levels[i - 1].w.div_ceil(2));
            assert_eq!(l.h, levels[i - 1].h.div_ceil(2));
        }
        // Row-major block order, leaders and trailers.
        assert!(l.offsets.windows(2).all(|p| p[0] < p[1]));
        for (&o, &c) in l.offsets.iter().zip(&l.counts) {
            let (o, c) = (o as usize, c as usize);
            assert_eq!(
                u32::from_le_bytes(bytes[o - 4..o].try_into().unwrap()) as usize,
                c
            );
            assert_eq!(bytes[o + c - 4..o + c], bytes[o + c..o + c + 4]);
        }
    }
    let last = levels.last().unwrap();
    assert!(
        last.w <= block && last.h <= block,
        "smallest overview fits a block"
    );
    // Data: smallest overview first, full resolution last, all after the IFDs.
    let first: Vec<u64> = levels.iter().map(|l| l.offsets[0]).collect();
    assert!(first.windows(2).all(|p| p[0] > p[1]), "{first:?}");
    assert!(*first.last().unwrap() as usize > *ifds.last().unwrap());
}

#[test]
fn float_cog_layout_and_average_overviews() {
    let tmp = tempfile::tempdir().unwrap();
    let g = smooth(700, 530, 3);
    let src = MemRaster::new(AnyGrid::F32(g.clone()), GeoRef::pixel(), "f.mem");
    let opts = WriteOptions {
        compression: Compression::Deflate { level: 6 },
        block: 128,
        ..WriteOptions::default()
    };
    let path = tmp.path().join("a.tif");
    write_cog(&src, &path, &opts, Resampling::Average, 256);
    check_layout(&path, 128);
    let levels = read_levels(&path, None);
    assert_eq!(levels.len(), 4); // 700x530, 350x265, 175x133, 88x67
    let (mut want, mut w, mut h) = (
        g.data().iter().map(|&v| v as f64).collect::<Vec<_>>(),
        700,
        530,
    );
    for (i, l) in levels.iter().enumerate() {
        assert_eq!((l.w, l.h), (w, h));
        let mut worst = 0f64;
        for (a, b) in l.values.iter().zip(&want) {
            assert_eq!(a.is_nan(), b.is_nan(), "level {i}");
            if a.is_finite() {
                worst = worst.max((a - b).abs() / b.abs().max(1.0));
            }
        }
        // Each level is stored as f32 and reduced from the stored level above.
        assert!(worst < 1e-6, "level {i}: relative error {worst}");
        // The next oracle level starts from what was stored (f32 rounding).
        let stored: Vec<f64> = l.values.clone();
        let r = reduce(&stored, w, h, false);
        want = r.0;
        w = r.1;
        h = r.2;
    }
    // The same bytes whatever the engine's tile size.
    let other = tmp.path().join("b.tif");
    write_cog(&src, &other, &opts, Resampling::Average, 37);
    assert!(std::fs::read(&path).unwrap() == std::fs::read(&other).unwrap());
}

#[test]
fn integer_cog_with_nodata_rounds_averages_and_nearest_keeps_classes() {
    let tmp = tempfile::tempdir().unwrap();
    let (w, h) = (301, 200);
    let g: Grid<i16> = Grid::from_fn(w, h, |x, y| {
        if (x + 3 * y) % 17 == 0 {
            -32768
        } else {
            ((x * 7 + y * 13) % 50) as i16
        }
    });
    let georef = GeoRef::pixel().with_nodata(Some(-32768.0));
    let src = MemRaster::new(AnyGrid::I16(g.clone()), georef, "i.mem");
    let opts = WriteOptions {
        compression: Compression::Zstd { level: 3 },
        block: 64,
        ..WriteOptions::default()
    };
    for (r, nearest) in [(Resampling::Average, false), (Resampling::Nearest, true)] {
        let path = tmp.path().join(format!("i{nearest}.tif"));
        write_cog(&src, &path, &opts, r, 100);
        check_layout(&path, 64);
        let levels = read_levels(&path, Some(-32768.0));
        let mut want: Vec<f64> = levels[0].values.clone();
        let (mut lw, mut lh) = (w, h);
        for l in &levels[1..] {
            let (red, nw, nh) = reduce(&want, lw, lh, nearest);
            for (a, b) in l.values.iter().zip(&red) {
                if b.is_nan() {
                    assert!(a.is_nan());
                } else {
                    assert_eq!(*a, b.round(), "integers round to nearest");
                }
            }
            want = l.values.clone();
            lw = nw;
            lh = nh;
        }
        if nearest {
            // Classes stay classes: every overview value exists in the input.
            let input: std::collections::HashSet<i64> =
                g.data().iter().map(|&v| v as i64).collect();
            for l in &levels {
                assert!(l
                    .values
                    .iter()
                    .all(|v| v.is_nan() || input.contains(&(*v as i64))));
            }
        }
    }
}

#[test]
fn a_small_raster_is_one_level_and_an_incomplete_one_leaves_no_file() {
    let tmp = tempfile::tempdir().unwrap();
    let g = smooth(100, 90, 5);
    let src = MemRaster::new(AnyGrid::F32(g), GeoRef::pixel(), "s.mem");
    let opts = WriteOptions {
        block: 128,
        ..WriteOptions::default()
    };
    let path = tmp.path().join("s.tif");
    write_cog(&src, &path, &opts, Resampling::Average, 64);
    check_layout(&path, 128);
    assert_eq!(read_levels(&path, None).len(), 1);

    let bad = tmp.path().join("bad.tif");
    let w = CogWriter::create(
        &bad,
        100,
        90,
        orogen::raster::DType::F32,
        &GeoRef::pixel(),
        &opts,
        Resampling::Average,
    )
    .unwrap();
    let e = Box::new(w).finish_boxed().unwrap_err().to_string();
    assert!(e.contains("0 of 90 rows"), "{e}");
    let left: Vec<_> = std::fs::read_dir(tmp.path())
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    assert!(!left.iter().any(|n| n.contains("bad")), "{left:?}");
}

trait FinishBoxed {
    fn finish_boxed(self: Box<Self>) -> orogen::Result<()>;
}
impl FinishBoxed for CogWriter {
    fn finish_boxed(self: Box<Self>) -> orogen::Result<()> {
        orogen::exec::TileSink::finish(self)
    }
}

/// D8 directions of a real DEM (`orogen flow`) as a COG with 64-cell
/// blocks, overviews made as `overviews` says; the levels, full resolution
/// first.
fn d8_cog_levels(dir: &Path, overviews: orogen::io::Overviews) -> Vec<Level> {
    let dem = orogen::io::open_raster(
        Path::new("tests/data/whitebox_DEM.tif"),
        &Default::default(),
    )
    .unwrap();
    let mut target = orogen::ops::Target::new(dir.join(format!("d8-{overviews:?}.tif")));
    target.options.tiff.block = 64;
    target.options.cog = Some(overviews);
    target.tile = Some(100);
    orogen::ops::flow::run(
        dem.as_ref(),
        &Default::default(),
        &target,
        &EngineConfig::default(),
    )
    .unwrap();
    read_levels(&target.path, None)
}

#[test]
fn categorical_outputs_get_nearest_overviews_unless_told_otherwise() {
    use orogen::io::Overviews;
    let tmp = tempfile::tempdir().unwrap();
    // The D8 codes (ESRI), no flow and nodata: the only values a direction
    // raster may hold, at any level.
    let codes = [0.0, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0, 128.0, 255.0];
    let levels = d8_cog_levels(tmp.path(), Overviews::ByKind);
    assert!(
        levels.len() >= 3,
        "237 x 188 in 64-cell blocks has overviews"
    );
    let full: std::collections::HashSet<u64> =
        levels[0].values.iter().map(|v| v.to_bits()).collect();
    assert!(levels[0].values.iter().all(|v| codes.contains(v)));
    for l in &levels[1..] {
        for v in &l.values {
            assert!(codes.contains(v), "overview value {v} is not a D8 code");
            assert!(
                full.contains(&v.to_bits()),
                "{v} is not in the full resolution"
            );
        }
    }
    // Each overview cell is the top-left cell of its footprint one level up.
    for k in 1..levels.len() {
        let (up, l) = (&levels[k - 1], &levels[k]);
        let (want, w, h) = reduce(&up.values, up.w, up.h, true);
        assert_eq!((w, h), (l.w, l.h));
        assert_eq!(l.values, want, "level {k}");
    }
    // Told to average, the same output's overviews hold means of codes.
    let averaged = d8_cog_levels(tmp.path(), Overviews::Fixed(Resampling::Average));
    assert!(averaged[1..]
        .iter()
        .any(|l| l.values.iter().any(|v| !codes.contains(v))));
}
