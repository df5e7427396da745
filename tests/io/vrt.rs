//! GDAL VRT mosaics against GDAL's own reading of them (`gdal_translate
//! X.vrt X_ref.tif`, committed) and the uncut DEM the tiles were cut from
//! (tests/data/vrt/SOURCES.md): complex and simple sources, a missing tile
//! read as nodata, a later source over an earlier one with its NODATA
//! transparent, absolute source paths, streaming (a window reads only the
//! sources it overlaps), the refusals (resampling, scaling, warped, bands,
//! missing files), mangled VRTs (errors, no panic) and sparse mosaics
//! refused unless asked.

use orogen::io::mosaic::Coverage;
use orogen::io::vrt::Vrt;
use orogen::io::{open_inputs, open_raster, OpenOptions};
use orogen::raster::{AnyGrid, RasterSource, Window};
use std::path::{Path, PathBuf};

fn vrt_data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/vrt")
        .join(name)
}

fn original() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/bigtujunga_crop.tif")
}

fn whole(src: &dyn RasterSource) -> AnyGrid {
    let i = src.info();
    src.read_native(Window::full(i.width, i.height)).unwrap()
}

fn open(p: &Path) -> Box<dyn RasterSource> {
    open_raster(p, &OpenOptions::default()).unwrap()
}

fn err_of<T>(r: orogen::Result<T>) -> String {
    match r {
        Err(e) => e.to_string(),
        Ok(_) => panic!("expected an error"),
    }
}

/// Windows straddling the tiles' edges (x 140, y 90), at the raster's
/// corners and inside one tile.
const WINDOWS: [(i64, i64, usize, usize); 6] = [
    (130, 80, 20, 20),
    (0, 0, 301, 203),
    (139, 0, 2, 203),
    (0, 89, 301, 2),
    (290, 190, 11, 13),
    (10, 10, 50, 40),
];

#[test]
fn gdalbuildvrt_mosaic_reads_as_the_uncut_dem() {
    let orig = open(&original());
    for name in ["mosaic.vrt", "simple.vrt"] {
        let v = open(&vrt_data(name));
        let (i, o) = (v.info(), orig.info());
        assert_eq!(
            (i.width, i.height, i.dtype),
            (o.width, o.height, o.dtype),
            "{name}"
        );
        assert_eq!(i.georef.transform, o.georef.transform, "{name}");
        assert_eq!(i.georef.crs.epsg, Some(32611), "{name}");
        assert!(!i.georef.crs.geographic);
        for &(x, y, w, h) in &WINDOWS {
            let win = Window::new(x, y, w, h);
            assert_eq!(
                v.read_native(win).unwrap(),
                orig.read_native(win).unwrap(),
                "{name} window {win:?}"
            );
        }
    }
    // ComplexSource NODATA and the band's NoDataValue; simple sources
    // (gdalbuildvrt -srcnodata None) declare none, and cover everything.
    assert_eq!(
        open(&vrt_data("mosaic.vrt")).info().georef.nodata,
        Some(32767.0)
    );
    assert_eq!(open(&vrt_data("simple.vrt")).info().georef.nodata, None);
}

#[test]
fn a_missing_tile_reads_nodata_as_gdal_does() {
    let v = open(&vrt_data("gap.vrt"));
    let gdal = open(&vrt_data("gap_ref.tif"));
    assert_eq!(v.info().georef.nodata, Some(32767.0));
    let got = whole(v.as_ref());
    assert_eq!(got, whole(gdal.as_ref()));
    // The missing tile is t_d: x >= 140, y >= 90.
    assert_eq!(got.get_f64(200, 150), 32767.0);
    assert_eq!(
        got.get_f64(139, 150),
        whole(open(&original()).as_ref()).get_f64(139, 150)
    );
}

#[test]
fn a_later_source_paints_over_an_earlier_one_except_its_nodata() {
    // t_e.tif (80 x 60 at 100, 60: the DEM + 1000 with a hole of nodata) is last.
    let v = open(&vrt_data("overlap.vrt"));
    let gdal = open(&vrt_data("overlap_ref.tif"));
    for &(x, y, w, h) in &WINDOWS {
        let win = Window::new(x, y, w, h);
        assert_eq!(
            v.read_native(win).unwrap(),
            gdal.read_native(win).unwrap(),
            "{win:?}"
        );
    }
    let (got, orig) = (whole(v.as_ref()), whole(open(&original()).as_ref()));
    assert_eq!(got.get_f64(100, 60), orig.get_f64(100, 60) + 1000.0);
    // Inside the hole (rows 20..35, columns 10..50 of t_e) the tiles below show.
    assert_eq!(got.get_f64(120, 85), orig.get_f64(120, 85));
}

/// mosaic.vrt rewritten with absolute source paths (relativeToVRT="0")
/// into `dir`, with `edit` applied to its text.
fn rewritten(dir: &Path, name: &str, edit: impl Fn(String) -> String) -> PathBuf {
    let text = std::fs::read_to_string(vrt_data("mosaic.vrt")).unwrap();
    let abs = vrt_data("");
    let text = text.replace(
        "relativeToVRT=\"1\">",
        &format!("relativeToVRT=\"0\">{}", abs.display()),
    );
    let p = dir.join(name);
    std::fs::write(&p, edit(text)).unwrap();
    p
}

#[test]
fn absolute_source_paths_read_as_given() {
    let dir = tempfile::tempdir().unwrap();
    let p = rewritten(dir.path(), "abs.vrt", |t| t);
    assert!(std::fs::read_to_string(&p)
        .unwrap()
        .contains("relativeToVRT=\"0\">/"));
    assert_eq!(whole(open(&p).as_ref()), whole(open(&original()).as_ref()));
}

#[test]
fn a_window_opens_only_the_sources_it_overlaps() {
    // t_d.tif replaced by a file that is not a GeoTIFF: windows away from
    // it read; one that overlaps it fails naming it.
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("t_d.tif");
    std::fs::write(&bad, b"not a tiff at all").unwrap();
    let abs_d = vrt_data("t_d.tif");
    let p = rewritten(dir.path(), "bad.vrt", |t| {
        t.replace(abs_d.to_str().unwrap(), bad.to_str().unwrap())
    });
    let v = open(&p);
    let orig = open(&original());
    let away = Window::new(0, 0, 140, 203);
    assert_eq!(
        v.read_native(away).unwrap(),
        orig.read_native(away).unwrap()
    );
    let msg = err_of(v.read_native(Window::new(130, 80, 20, 20)));
    assert!(msg.contains("t_d.tif"), "{msg}");
}

#[test]
fn missing_source_files_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(vrt_data("mosaic.vrt")).unwrap();
    let p = dir.path().join("tiles.vrt");
    std::fs::write(&p, text).unwrap();
    let msg = err_of(open_raster(&p, &OpenOptions::default()));
    assert!(
        msg.contains("tiles.vrt") && msg.contains("t_a.tif") && msg.contains("missing"),
        "{msg}"
    );
}

#[test]
fn no_nodata_value_and_a_gap_declare_the_types_default() {
    // simple.vrt without its last source: GDAL would read 0 in the gap.
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(vrt_data("simple.vrt")).unwrap();
    let last = text.rfind("<SimpleSource>").unwrap();
    let end = text.rfind("</SimpleSource>").unwrap() + "</SimpleSource>".len();
    let text = format!("{}{}", &text[..last], &text[end..]).replace(
        "relativeToVRT=\"1\">",
        &format!("relativeToVRT=\"0\">{}", vrt_data("").display()),
    );
    let p = dir.path().join("gap_simple.vrt");
    std::fs::write(&p, text).unwrap();
    let v = open(&p);
    assert_eq!(v.info().georef.nodata, Some(-32768.0));
    assert_eq!(whole(v.as_ref()).get_f64(200, 150), -32768.0);
}

#[test]
fn what_is_not_a_mosaic_is_refused_with_the_fix() {
    for (name, what) in [
        ("resample.vrt", "resampling"),
        ("scaled.vrt", "ScaleRatio 2"),
        ("warped.vrt", "VRTWarpedDataset"),
    ] {
        let msg = err_of(open_raster(&vrt_data(name), &OpenOptions::default()));
        assert!(msg.contains(name), "{msg}");
        assert!(msg.contains(what), "{name}: {msg}");
        assert!(msg.contains("gdal_translate"), "{name}: {msg}");
    }
    let opts = OpenOptions {
        band: 2,
        ..Default::default()
    };
    let msg = err_of(open_raster(&vrt_data("mosaic.vrt"), &opts));
    assert!(msg.contains("band 2") && msg.contains("1 band"), "{msg}");
    // Other refusals, written at run time.
    let dir = tempfile::tempdir().unwrap();
    for (edit, what) in [
        (
            ("<NODATA>32767</NODATA>", "<LUT>0:0,1000:2000</LUT>"),
            "LUT",
        ),
        (
            ("<ComplexSource>", "<KernelFilteredSource>"),
            "KernelFilteredSource",
        ),
        (
            ("band=\"1\"", "band=\"1\" subClass=\"VRTDerivedRasterBand\""),
            "derived band",
        ),
        (
            ("xOff=\"140\" yOff=\"0\"", "xOff=\"140.5\" yOff=\"0\""),
            "fractional",
        ),
    ] {
        let p = rewritten(dir.path(), "edited.vrt", |t| {
            let t = t.replacen(edit.0, edit.1, 1);
            if edit.1.starts_with("<Kernel") {
                t.replacen("</ComplexSource>", "</KernelFilteredSource>", 1)
            } else {
                t
            }
        });
        let msg = err_of(Vrt::open(&p, 1));
        assert!(
            msg.contains("edited.vrt") && msg.contains(what),
            "{what}: {msg}"
        );
    }
}

#[test]
fn sparse_mosaics_are_refused_unless_asked() {
    let allow = OpenOptions {
        allow_sparse: true,
        ..Default::default()
    };
    // t_a (140 x 90) and t_far (21 x 13 at the far corner) of a 301 x 203 extent.
    let covered = 140 * 90 + 21 * 13;
    let c = Coverage::of(
        301,
        203,
        &[Window::new(0, 0, 140, 90), Window::new(280, 190, 21, 13)],
    );
    assert_eq!(c.covered_cells, covered);
    let pct = format!("{:.1} %", 100.0 * covered as f64 / (301.0 * 203.0));
    let sparse = vrt_data("sparse.vrt");
    let msg = err_of(open_raster(&sparse, &OpenOptions::default()));
    assert!(
        msg.contains("sparse.vrt") && msg.contains("--allow-sparse"),
        "{msg}"
    );
    assert!(
        msg.contains(&pct) && msg.contains("301 x 203") && msg.contains("50 %"),
        "{msg}"
    );
    assert!(
        msg.contains("388313.6") && msg.contains("3801917.8"),
        "extent in map units: {msg}"
    );
    let v = open_raster(&sparse, &allow).unwrap();
    assert_eq!((v.info().width, v.info().height), (301, 203));
    // The same two files as a mosaic of inputs.
    let files = [vrt_data("t_a.tif"), vrt_data("t_far.tif")];
    let msg = err_of(open_inputs(&files, &OpenOptions::default()));
    assert!(
        msg.contains("2 files") && msg.contains("--allow-sparse") && msg.contains(&pct),
        "{msg}"
    );
    let m = open_inputs(&files, &allow).unwrap();
    assert_eq!(whole(m.as_ref()), whole(v.as_ref()));
    // Adjacent tiles are not sparse.
    let near = [vrt_data("t_a.tif"), vrt_data("t_b.tif")];
    assert!(open_inputs(&near, &OpenOptions::default()).is_ok());
}

#[test]
fn a_vrt_of_srtm_hgt_tiles_reads_the_later_tile_on_the_shared_column() {
    // gdalbuildvrt srtm.vrt ../srtm/N43E006.hgt ../srtm/N43E007.hgt
    let v = open(&vrt_data("srtm.vrt"));
    let i = v.info();
    assert_eq!((i.width, i.height), (2401, 1201));
    assert!(i.georef.crs.geographic && i.georef.crs.epsg == Some(4326));
    let w = open(&vrt_data("../srtm/N43E006.hgt"));
    let e = open(&vrt_data("../srtm/N43E007.hgt"));
    let win = Window::new(1150, 300, 100, 200);
    let got = v.read_native(win).unwrap();
    let gw = w.read_native(Window::new(1150, 300, 51, 200)).unwrap();
    let ge = e.read_native(Window::new(0, 300, 50, 200)).unwrap();
    let nd = -32768.0;
    for y in 0..200 {
        for x in 0..100 {
            let g = got.get_f64(x, y);
            // Column 1200 is both tiles' edge: N43E007, later, paints over
            // it unless it holds nodata there.
            let want = if x >= 50 && ge.get_f64(x - 50, y) != nd {
                ge.get_f64(x - 50, y)
            } else if x <= 50 {
                gw.get_f64(x, y)
            } else {
                nd
            };
            assert_eq!(g, want, "({x}, {y})");
        }
    }
}

#[test]
fn a_vrt_of_a_vrt_without_rectangles_reads_its_source_whole() {
    // SrcRect absent: the whole source; DstRect absent: the whole VRT.
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("outer.vrt");
    std::fs::write(
        &p,
        format!(
            "<?xml version=\"1.0\"?>\n<VRTDataset rasterXSize=\"301\" rasterYSize=\"203\">\n\
             <VRTRasterBand dataType=\"Float32\" band=\"1\"><SimpleSource>\
             <SourceFilename relativeToVRT=\"0\">{}</SourceFilename><SourceBand>1</SourceBand>\
             </SimpleSource></VRTRasterBand></VRTDataset>\n",
            vrt_data("mosaic.vrt").display()
        ),
    )
    .unwrap();
    let v = open(&p);
    assert_eq!(v.info().dtype, orogen::raster::DType::F32);
    assert!(!v.info().georef.georeferenced);
    let orig = whole(open(&original()).as_ref());
    let got = whole(v.as_ref());
    for (x, y) in [(0, 0), (139, 89), (140, 90), (300, 202), (200, 17)] {
        assert_eq!(got.get_f64(x, y), orig.get_f64(x, y), "({x}, {y})");
    }
}

#[test]
fn mangled_vrts_give_errors_not_panics() {
    // Deterministic mutations of a real VRT (digits, brackets, element
    // names, truncations): opening and reading a bounded window either
    // works or fails with an error.
    use orogen::oro::stats::SplitMix64;
    let dir = tempfile::tempdir().unwrap();
    let base = std::fs::read_to_string(vrt_data("overlap.vrt"))
        .unwrap()
        .replace(
            "relativeToVRT=\"1\">",
            &format!("relativeToVRT=\"0\">{}", vrt_data("").display()),
        );
    let alphabet: &[u8] = b"0123456789-.e[]\",<>/ \n";
    let mut rng = SplitMix64(7);
    let p = dir.path().join("m.vrt");
    let (mut opened, mut read) = (0, 0);
    for _ in 0..600 {
        let mut b = base.clone().into_bytes();
        for _ in 0..1 + rng.below(4) {
            if b.is_empty() {
                break;
            }
            let i = rng.below(b.len() as u64) as usize;
            match rng.below(4) {
                0 => b[i] = alphabet[rng.below(alphabet.len() as u64) as usize],
                1 => b.truncate(i),
                2 => {
                    b.remove(i);
                }
                _ => b.insert(i, b"9"[0]),
            }
        }
        std::fs::write(&p, &b).unwrap();
        if let Ok(v) = Vrt::open(&p, 1) {
            opened += 1;
            let i = v.info();
            let win = Window::new(90, 50, i.width.min(64), i.height.min(64));
            if v.read_native(win).is_ok() {
                read += 1;
            }
        }
    }
    assert!(opened > 50 && read > 50, "{opened} opened, {read} read");
}
