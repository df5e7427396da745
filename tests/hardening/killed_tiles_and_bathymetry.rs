//! Hardening (issue 12), end to end with the real binary:
//! web tiles killed mid-run leave no torn tile under a final name, and the
//! elevation-valued outputs of `erode --model stream-power` and `metric`
//! keep real cells at −9999 (bathymetry) apart from their nodata.

use orogen::exec::EngineConfig;
use orogen::raster::{read_window, GeoRef, Grid, MemRaster, Window};
use std::path::{Path, PathBuf};

use crate::common::cli::{data, run_env as run};

fn ok(args: &[&str]) {
    let o = run(args, &[]);
    assert!(
        o.status.success(),
        "orogen {args:?} failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Every regular file under `dir`, relative path -> bytes, sorted.
fn tree(dir: &Path) -> Vec<(String, Vec<u8>)> {
    fn walk(root: &Path, d: &Path, out: &mut Vec<(String, Vec<u8>)>) {
        for e in std::fs::read_dir(d).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                walk(root, &p, out);
            } else {
                let rel = p.strip_prefix(root).unwrap().to_string_lossy().into_owned();
                out.push((rel, std::fs::read(&p).unwrap()));
            }
        }
    }
    let mut v = vec![];
    walk(dir, dir, &mut v);
    v.sort();
    v
}

/// Decode a PNG completely (the png crate checks every chunk CRC and the
/// zlib stream's Adler-32): the tile's RGBA pixels, or an error.
fn decode_png(bytes: &[u8]) -> Result<Vec<u8>, String> {
    let dec = png::Decoder::new(std::io::Cursor::new(bytes));
    let mut r = dec.read_info().map_err(|e| e.to_string())?;
    let mut buf = vec![0; r.output_buffer_size().ok_or("size")?];
    let info = r.next_frame(&mut buf).map_err(|e| e.to_string())?;
    if (info.width, info.height) != (256, 256) {
        return Err(format!("{} x {}", info.width, info.height));
    }
    Ok(buf)
}

fn tiles_args<'a>(dem: &'a str, out: &'a str) -> Vec<&'a str> {
    vec!["tiles", dem, "-o", out, "--threads", "1", "-q"]
}

#[test]
fn tiles_killed_mid_run_leave_only_complete_tiles_and_a_rerun_completes() {
    let tmp = tempfile::tempdir().unwrap();
    let dem = data("bigtujunga_crop.tif");
    // Reference: one uninterrupted run, logging its crash points.
    let reference = tmp.path().join("ref");
    let log = tmp.path().join("points.log");
    let o = run(
        &tiles_args(s(&dem), s(&reference)),
        &[("OROGEN_CRASH_LOG", s(&log))],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let points = std::fs::read_to_string(&log).unwrap();
    let n_tiles = points.lines().filter(|l| *l == "tile.tmp").count();
    let reference = tree(&reference);
    let pngs = reference
        .iter()
        .filter(|(n, _)| n.ends_with(".png"))
        .count();
    assert_eq!(n_tiles, pngs, "one tile.tmp point per tile");
    assert!(n_tiles >= 4, "{n_tiles} tiles: too few for the test");
    for (n, b) in &reference {
        if n.ends_with(".png") {
            decode_png(b).unwrap_or_else(|e| panic!("{n}: {e}"));
        }
    }
    // Kill (abort: no cleanup) once the k-th tile's temporary is complete.
    for k in [1, n_tiles / 2, n_tiles] {
        let out = tmp.path().join(format!("k{k}"));
        let o = run(
            &tiles_args(s(&dem), s(&out)),
            &[("OROGEN_CRASH_AT", &format!("tile.tmp:{k}"))],
        );
        assert!(!o.status.success(), "the crash point was not reached");
        let left = tree(&out);
        let done: Vec<_> = left.iter().filter(|(n, _)| n.ends_with(".png")).collect();
        // With one thread, exactly the k − 1 tiles before were renamed.
        assert_eq!(
            done.len(),
            k - 1,
            "{:?}",
            left.iter().map(|f| &f.0).collect::<Vec<_>>()
        );
        for (n, b) in &done {
            decode_png(b).unwrap_or_else(|e| panic!("{n}: {e}"));
            let r = reference.iter().find(|(m, _)| m == n).unwrap();
            assert_eq!(&r.1, b, "{n} differs from the uninterrupted run");
        }
        // The killed tile is a hidden temporary, not a .png, and no
        // metadata.json claims the pyramid is complete.
        let temps: Vec<_> = left
            .iter()
            .filter(|(n, _)| n.contains(".orogen-tmp-"))
            .collect();
        assert_eq!(
            temps.len(),
            1,
            "{:?}",
            left.iter().map(|f| &f.0).collect::<Vec<_>>()
        );
        assert!(!left.iter().any(|(n, _)| n == "metadata.json"));
        // A rerun completes to the reference bytes and removes the temporary.
        ok(&tiles_args(s(&dem), s(&out)));
        assert_eq!(tree(&out), reference, "rerun after a kill at tile {k}");
    }
}

/// An MBTiles-only run cuts its pyramid in a hidden scratch folder beside the
/// output; a run killed mid-pyramid leaves it behind, and the next run
/// removes it (its pid no longer runs) and completes.
#[test]
fn tiles_scratch_folder_of_a_killed_run_is_removed_by_the_rerun() {
    let tmp = tempfile::tempdir().unwrap();
    let dem = data("bigtujunga_crop.tif");
    let out = tmp.path().join("t.mbtiles");
    let scratch = |d: &Path| -> Vec<String> {
        std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.starts_with(".t.mbtiles.orogen-tiles-"))
            .collect()
    };
    let o = run(
        &tiles_args(s(&dem), s(&out)),
        &[("OROGEN_CRASH_AT", "tile.tmp:2")],
    );
    assert!(!o.status.success(), "the crash point was not reached");
    assert_eq!(
        scratch(tmp.path()).len(),
        1,
        "the killed run's scratch folder"
    );
    assert!(!out.exists(), "no MBTiles from a killed run");
    ok(&tiles_args(s(&dem), s(&out)));
    assert!(out.exists());
    assert!(
        scratch(tmp.path()).is_empty(),
        "left behind: {:?}",
        scratch(tmp.path())
    );
}

/// Write `g` (f32, no declared nodata) as a GeoTIFF at `p`.
fn write_tif(g: Grid<f32>, p: &Path) {
    let mem = MemRaster::from_grid(g, GeoRef::pixel());
    orogen::ops::convert(&mem, p, &Default::default(), None, &EngineConfig::default()).unwrap();
}

fn read_back(p: &Path) -> (Grid<f32>, Option<f64>) {
    let src = orogen::io::open_raster(p, &Default::default()).unwrap();
    let i = src.info().clone();
    let g = read_window::<f32>(src.as_ref(), Window::full(i.width, i.height)).unwrap();
    (g, i.georef.nodata)
}

/// A bathymetric DEM: a 20-cell-wide band at exactly −9999 m on the west,
/// deeper water eastwards, and one NaN cell (nodata).
fn bathymetry() -> Grid<f32> {
    let mut g = Grid::from_fn(48, 40, |x, y| {
        if x < 20 {
            -9999.0
        } else {
            -9999.0 - 3.0 * (x - 19) as f32 - 0.25 * ((x * 7 + y * 13) % 5) as f32
        }
    });
    g.set(30, 30, f32::NAN);
    g
}

#[test]
fn metric_outputs_keep_cells_at_minus_9999() {
    let tmp = tempfile::tempdir().unwrap();
    let dem = tmp.path().join("bathy.tif");
    let g = bathymetry();
    write_tif(g.clone(), &dem);
    let out = tmp.path().join("m");
    ok(&[
        "metric",
        s(&dem),
        "--metric",
        "mean:radius=1c,slope",
        "-o",
        s(&out),
        "-q",
    ]);
    let files: Vec<PathBuf> = std::fs::read_dir(&out)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .collect();
    let mean_p = files
        .iter()
        .find(|p| p.file_name().unwrap().to_string_lossy().starts_with("mean"))
        .unwrap();
    let slope_p = files
        .iter()
        .find(|p| {
            p.file_name()
                .unwrap()
                .to_string_lossy()
                .starts_with("slope")
        })
        .unwrap();
    let (mean, nd) = read_back(mean_p);
    let nd = nd.expect("a declared nodata");
    assert!(
        nd < -9999.0 - 1.0,
        "mean nodata {nd} collides with the data"
    );
    // Brute force: the mean of the valid cells of the 3 x 3 window inside
    // the raster; NaN at the NaN cell itself.
    let (w, h) = (g.width() as i64, g.height() as i64);
    let mut at_9999 = 0;
    for y in 0..h {
        for x in 0..w {
            let got = mean.get(x as usize, y as usize);
            if (x, y) == (30, 30) {
                assert!(got.is_nan(), "nodata cell reads {got}");
                continue;
            }
            let (mut sum, mut n) = (0.0f64, 0);
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let (u, v) = (x + dx, y + dy);
                    if u >= 0 && v >= 0 && u < w && v < h {
                        let z = g.get(u as usize, v as usize);
                        if z.is_finite() {
                            sum += z as f64;
                            n += 1;
                        }
                    }
                }
            }
            let want = sum / n as f64;
            assert!(
                (got as f64 - want).abs() < 1e-2,
                "mean at ({x},{y}): {got} != {want}"
            );
            at_9999 += (got == -9999.0) as usize;
        }
    }
    assert!(at_9999 > 500, "{at_9999} cells at exactly -9999");
    // Slope (degrees, >= 0) keeps gdaldem's −9999.
    let (_, snd) = read_back(slope_p);
    assert_eq!(snd, Some(-9999.0));
}

#[test]
fn erode_stream_power_keeps_cells_at_minus_9999_in_memory_and_tiled() {
    let tmp = tempfile::tempdir().unwrap();
    let dem = tmp.path().join("bathy.tif");
    let mut g = bathymetry();
    g.set(30, 30, -10_100.0);
    write_tif(g.clone(), &dem);
    let mut outs = vec![];
    for (name, extra) in [
        ("mem.tif", vec![]),
        ("tiled.tif", vec!["--tiled", "--tile", "16"]),
    ] {
        let out = tmp.path().join(name);
        let mut args = vec![
            "erode",
            s(&dem),
            "--model",
            "stream-power",
            "--steps",
            "3",
            "--k",
            "4e-5",
            "--cell",
            "30",
            "-o",
            s(&out),
            "-q",
        ];
        args.extend(extra);
        ok(&args);
        let (e, nd) = read_back(&out);
        let nd = nd.expect("a declared nodata");
        assert!(nd < -10_100.0 - 1.0, "{name}: nodata {nd}");
        // Every input cell is valid, so is every output cell; boundary cells
        // are fixed base levels: the west edge stays exactly −9999.
        assert!(e.data().iter().all(|v| v.is_finite()), "{name}");
        for y in 0..g.height() {
            assert_eq!(e.get(0, y), -9999.0, "{name}: west edge row {y}");
        }
        outs.push((e, nd));
    }
    assert_eq!(outs[0].1, outs[1].1, "in-memory and tiled nodata differ");
    let same = outs[0]
        .0
        .data()
        .iter()
        .zip(outs[1].0.data())
        .all(|(a, b)| a.to_bits() == b.to_bits());
    assert!(same, "in-memory and tiled outputs differ");
}
