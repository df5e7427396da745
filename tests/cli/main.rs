//! The CLI as a user runs it: demo, info, ingest/export round trip, bad input.

#[path = "../common/mod.rs"]
mod common;

use common::cli::{data, fails, ok, orogen};

mod geojson_crs;
mod vrt;

#[test]
fn demo_writes_everything_it_lists() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("demo");
    let s = ok(orogen()
        .args(["demo", "--size", "300", "-q", "-o"])
        .arg(&out));
    for f in [
        "terrain.tiles",
        "terrain.tif",
        "slope.tif",
        "aspect.tif",
        "hillshade.tif",
        "preview.png",
    ] {
        assert!(s.contains(f), "demo output does not list {f}: {s}");
        assert!(out.join(f).exists(), "{f} missing");
    }
    // The exported terrain equals the store, cell for cell.
    let a = ok(orogen()
        .args(["info", "--json", "--stats"])
        .arg(out.join("terrain.tif")));
    let b = ok(orogen()
        .args(["info", "--json", "--stats"])
        .arg(out.join("terrain.tiles")));
    let ja: serde_json::Value = serde_json::from_str(&a[..a.rfind('}').unwrap() + 1]).unwrap();
    let jb: serde_json::Value = serde_json::from_str(&b[..b.rfind('}').unwrap() + 1]).unwrap();
    assert_eq!(ja["stats"], jb["stats"]);
    assert_eq!(ja["width"], 300);
    assert_eq!(ja["transform"], jb["transform"]);
    // Same seed, same bytes.
    let out2 = dir.path().join("demo2");
    ok(orogen()
        .args(["demo", "--size", "300", "-q", "--threads", "1", "-o"])
        .arg(&out2));
    for f in ["terrain.tif", "slope.tif", "hillshade.tif", "preview.png"] {
        assert_eq!(
            std::fs::read(out.join(f)).unwrap(),
            std::fs::read(out2.join(f)).unwrap(),
            "{f} not deterministic"
        );
    }
}

#[test]
fn info_reads_every_format() {
    let s = ok(orogen()
        .args(["info", "--json"])
        .arg(data("bigtujunga_crop.tif")));
    let j: serde_json::Value = serde_json::from_str(&s[..s.rfind('}').unwrap() + 1]).unwrap();
    assert_eq!(j["width"], 301);
    assert_eq!(j["height"], 203);
    assert_eq!(j["epsg"], 32611);
    assert_eq!(j["nodata"], 32767.0);
    assert_eq!(j["dtype"], "i16");
}

#[test]
fn ingest_export_round_trip_is_exact() {
    let dir = tempfile::tempdir().unwrap();
    let store = dir.path().join("w.tiles");
    let tif = dir.path().join("w.tif");
    ok(orogen()
        .arg("ingest")
        .arg(data("whitebox_DEM.tif"))
        .args(["--store-tile", "64", "-q", "-o"])
        .arg(&store));
    ok(orogen()
        .arg("export")
        .arg(&store)
        .args(["-q", "-o"])
        .arg(&tif));
    let a = ok(orogen()
        .args(["info", "--json", "--stats"])
        .arg(data("whitebox_DEM.tif")));
    let b = ok(orogen().args(["info", "--json", "--stats"]).arg(&tif));
    let ja: serde_json::Value = serde_json::from_str(&a[..a.rfind('}').unwrap() + 1]).unwrap();
    let jb: serde_json::Value = serde_json::from_str(&b[..b.rfind('}').unwrap() + 1]).unwrap();
    for k in ["width", "height", "dtype", "transform", "nodata", "stats"] {
        assert_eq!(ja[k], jb[k], "{k}");
    }
}

#[test]
fn bad_inputs_give_one_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("nope.tif");
    let e = fails(orogen().arg("info").arg(&missing));
    assert!(e.contains("nope.tif"), "{e}");

    let garbage = dir.path().join("garbage.tif");
    std::fs::write(&garbage, b"this is not a tiff at all").unwrap();
    let e = fails(
        orogen()
            .arg("slope")
            .arg(&garbage)
            .arg("-o")
            .arg(dir.path().join("s.tif")),
    );
    assert!(e.contains("garbage.tif"), "{e}");
    assert!(!dir.path().join("s.tif").exists(), "no output on failure");

    let truncated = dir.path().join("trunc.tif");
    let bytes = std::fs::read(data("bigtujunga_crop.tif")).unwrap();
    std::fs::write(&truncated, &bytes[..bytes.len() / 2]).unwrap();
    let out = dir.path().join("t.tif");
    let e = fails(
        orogen()
            .arg("slope")
            .arg(&truncated)
            .args(["-q", "-o"])
            .arg(&out),
    );
    assert!(e.contains("trunc.tif"), "{e}");
    assert!(!out.exists(), "a failed run left {out:?} behind");

    let e = fails(orogen().arg("info").arg(dir.path().join("x.xyz")));
    assert!(e.contains("x.xyz"));
    let e = fails(
        orogen()
            .arg("slope")
            .arg(data("whitebox_DEM.tif"))
            .args(["-o", "out.jpg"]),
    );
    assert!(e.contains("out.jpg") && e.contains(".tif"), "{e}");
    let e = fails(
        orogen()
            .arg("slope")
            .arg(data("whitebox_DEM.tif"))
            .args(["--memory", "12 parsecs", "-o"])
            .arg(dir.path().join("m.tif")),
    );
    assert!(e.contains("--memory"), "{e}");
}

#[test]
fn all_nan_and_missing_georef_are_handled() {
    let dir = tempfile::tempdir().unwrap();
    // An ESRI ASCII grid of nodata only: no georeferencing issue, all-nodata slope.
    let asc = dir.path().join("nan.asc");
    let mut s = String::from(
        "ncols 4\nnrows 3\nxllcorner 0\nyllcorner 0\ncellsize 10\nNODATA_value -9999\n",
    );
    for _ in 0..3 {
        s.push_str("-9999 -9999 -9999 -9999\n");
    }
    std::fs::write(&asc, s).unwrap();
    let out = dir.path().join("nan_slope.tif");
    ok(orogen().arg("slope").arg(&asc).args(["-q", "-o"]).arg(&out));
    let j = ok(orogen().args(["info", "--json", "--stats"]).arg(&out));
    let j: serde_json::Value = serde_json::from_str(&j[..j.rfind('}').unwrap() + 1]).unwrap();
    assert_eq!(j["stats"]["count"], 0, "all cells nodata: {j}");

    // A PNG heightmap has no georeferencing: a warning, then pixel coordinates.
    let png = dir.path().join("h.png");
    ok(orogen()
        .arg("export")
        .arg(data("bigtujunga_crop.tif"))
        .args(["-q", "-o"])
        .arg(&png));
    let out = dir.path().join("h_slope.tif");
    let o = ok(orogen().arg("slope").arg(&png).args(["-q", "-o"]).arg(&out));
    assert!(
        o.contains("warning") && o.contains("no georeferencing"),
        "{o}"
    );
}

#[test]
fn hydro_chain_is_identical_for_any_tile_size_and_equals_in_memory() {
    use orogen::io::{open_raster, OpenOptions};
    use orogen::raster::{read_window, Window};
    let dir = tempfile::tempdir().unwrap();
    let dem = data("bigtujunga_crop.tif");
    let mut outs = Vec::new();
    for tile in ["37", "4096"] {
        let f = dir.path().join(format!("fill{tile}.tif"));
        let d = dir.path().join(format!("d8{tile}.tif"));
        let a = dir.path().join(format!("acc{tile}.tif"));
        ok(orogen()
            .arg("fill")
            .arg(&dem)
            .args(["-q", "--tile", tile, "-o"])
            .arg(&f));
        ok(orogen()
            .arg("flow")
            .arg(&f)
            .args(["-q", "--tile", tile, "-o"])
            .arg(&d));
        ok(orogen()
            .arg("accumulate")
            .arg(&d)
            .args(["-q", "--tile", tile, "-o"])
            .arg(&a));
        outs.push([f, d, a].map(|p| std::fs::read(p).unwrap()));
    }
    assert!(outs[0] == outs[1], "tiled hydrology differs from untiled");
    // The filled GeoTIFF equals the library's in-memory Priority-Flood.
    let src = open_raster(&dem, &OpenOptions::default()).unwrap();
    let (w, h) = (src.info().width, src.info().height);
    let grid = read_window::<f32>(src.as_ref(), Window::full(w, h)).unwrap();
    let want = orogen::hydro::fill(&grid).unwrap();
    let got = open_raster(&dir.path().join("fill37.tif"), &OpenOptions::default()).unwrap();
    let got = read_window::<f32>(got.as_ref(), Window::full(w, h)).unwrap();
    assert!(got
        .data()
        .iter()
        .zip(want.data())
        .all(|(a, b)| a == b || (a.is_nan() && b.is_nan())));
    // Accumulation: every valid cell counted once at the outlets; the total is
    // at least the cell count (each cell counts itself).
    let acc = open_raster(&dir.path().join("acc37.tif"), &OpenOptions::default()).unwrap();
    let acc = read_window::<f64>(acc.as_ref(), Window::full(w, h)).unwrap();
    assert!(acc.data().iter().all(|&v| v >= 1.0));
    let e = fails(
        orogen()
            .arg("accumulate")
            .arg(&dem)
            .args(["-o"])
            .arg(dir.path().join("x.tif")),
    );
    assert!(e.contains("D8"), "{e}");
}

#[test]
fn peaks_writes_a_tree_that_loads_back() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("peaks");
    ok(orogen()
        .arg("peaks")
        .arg(data("bigtujunga_crop.tif"))
        .args(["-q", "--min-prominence", "50", "-o"])
        .arg(&out));
    let csv = std::fs::read_to_string(out.join("peaks.csv")).unwrap();
    let rows: Vec<&str> = csv.lines().skip(1).collect();
    assert!(!rows.is_empty());
    let tree = orogen::oro::DivideTree::load_json(&out.join("divide_tree.json")).unwrap();
    assert_eq!(tree.peaks.len(), rows.len());
    // Every kept peak has prominence >= 50; the highest is the DEM's maximum.
    assert!(tree.peaks.iter().all(|p| p.prominence >= 50.0));
    let e = fails(
        orogen()
            .arg("peaks")
            .arg(data("bigtujunga_crop.tif"))
            .args(["--edge", "moon", "-o"])
            .arg(&out),
    );
    assert!(e.contains("--edge"), "{e}");
}

#[test]
fn errors_are_said_once_and_name_the_fix() {
    let e = fails(orogen().args(["info", "/no/such/file.tif"]));
    assert_eq!(e.matches("os error").count(), 1, "{e}");
    assert_eq!(e.trim_end().lines().count(), 1, "one line: {e}");
    let e = fails(
        orogen()
            .arg("slope")
            .arg(data("whitebox_DEM.tif"))
            .args(["-o", "/no/such/folder/s.tif"]),
    );
    assert!(
        e.contains("/no/such/folder") && e.contains("does not exist"),
        "{e}"
    );
}

#[test]
fn dinf_and_mfd_accumulation_from_the_cli() {
    use orogen::io::{open_raster, OpenOptions};
    use orogen::raster::{read_window, Window};
    let dir = tempfile::tempdir().unwrap();
    let filled = dir.path().join("f.tif");
    ok(orogen()
        .arg("fill")
        .arg(data("bigtujunga_crop.tif"))
        .args(["-q", "-o"])
        .arg(&filled));
    for m in ["dinf", "quinn", "holmgren", "freeman"] {
        let a = dir.path().join(format!("{m}.tif"));
        ok(orogen()
            .arg("accumulate")
            .arg(&filled)
            .args(["--method", m, "-q", "-o"])
            .arg(&a));
        let src = open_raster(&a, &OpenOptions::default()).unwrap();
        let g = read_window::<f64>(src.as_ref(), Window::full(301, 203)).unwrap();
        // Every cell counts itself; nothing exceeds the number of cells.
        assert!(
            g.data()
                .iter()
                .all(|&v| (1.0..=61103.0 + 1e-6).contains(&v)),
            "{m}"
        );
        let again = dir.path().join(format!("{m}2.tif"));
        ok(orogen()
            .arg("accumulate")
            .arg(&filled)
            .args(["--method", m, "--threads", "1", "-q", "-o"])
            .arg(&again));
        assert_eq!(
            std::fs::read(&a).unwrap(),
            std::fs::read(&again).unwrap(),
            "{m} not deterministic"
        );
    }
    let e = fails(
        orogen()
            .arg("accumulate")
            .arg(&filled)
            .args(["--method", "d16", "-o"])
            .arg(dir.path().join("x.tif")),
    );
    assert!(e.contains("dinf") && e.contains("quinn"), "{e}");
}

#[test]
fn peaks_line_parents_fill_the_dem_columns_and_refuse_tiled() {
    let tmp = tempfile::tempdir().unwrap();
    let dem = data("bigtujunga_crop.tif");
    let out = tmp.path().join("lp");
    ok(orogen()
        .args([
            "peaks",
            "--min-prominence",
            "20",
            "--line-parents",
            "-q",
            "-o",
        ])
        .arg(&out)
        .arg(&dem));
    let csv = std::fs::read_to_string(out.join("peaks.csv")).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let col = header.iter().position(|h| *h == "line_parent").unwrap();
    let rel = header.iter().position(|h| *h == "relevance").unwrap();
    let rows: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    assert!(rows.len() > 2);
    // Every peak but the highest has a line parent and a relevance.
    assert!(rows[1..]
        .iter()
        .all(|r| !r[col].is_empty() && !r[rel].is_empty()));
    // Without the flag the files are the tiled run's bytes; with --tiled it is refused.
    let e = fails(
        orogen()
            .args(["peaks", "--line-parents", "--tiled", "-q", "-o"])
            .arg(tmp.path().join("t"))
            .arg(&dem),
    );
    assert!(e.contains("--line-parents needs the whole DEM"), "{e}");
}

/// A reader that closes the pipe early (`orogen metric list | head -1`) ends
/// orogen quietly, as it ends other Unix tools: no panic message, no exit
/// code 101. The pipe is closed before orogen writes, so every write fails.
#[test]
fn closed_stdout_ends_quietly() {
    use std::process::Stdio;
    let mut child = orogen()
        .args(["metric", "list"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("panicked"), "{err}");
    assert_ne!(out.status.code(), Some(101), "{err}");
    #[cfg(unix)]
    {
        use std::os::unix::process::ExitStatusExt;
        // Ended by SIGPIPE, or (if it wrote nothing at all) a clean exit.
        assert!(
            out.status.signal() == Some(13) || out.status.success(),
            "{:?}",
            out.status
        );
    }
}

/// `--band N` reads band N of a multi-band file (here pixel-interleaved,
/// values as GDAL read them), says which band of how many it read, and a
/// band past the last is one clear error; a job takes `band = N` too.
#[test]
fn band_option_reads_the_band_asked_for() {
    let dir = tempfile::tempdir().unwrap();
    let src = data("gdal/bands/i16_3band_pixel_strip_lzw_p2.tif");
    let reference = std::fs::read(data("gdal/bands/i16_3band_pixel_strip_lzw_p2.b3.bin")).unwrap();
    let want: Vec<f32> = reference
        .chunks_exact(2)
        .map(|c| i16::from_le_bytes([c[0], c[1]]) as f32)
        .collect();
    let out = dir.path().join("b3.tif");
    let s = ok(orogen()
        .arg("export")
        .arg(&src)
        .args(["--band", "3", "-o"])
        .arg(&out));
    assert!(s.contains("has 3 bands; band 3 is read"), "{s}");
    assert_eq!(common::cli::read_f32(&out).data(), &want[..]);
    let e = fails(
        orogen()
            .arg("slope")
            .arg(&src)
            .args(["--band", "4", "-o"])
            .arg(dir.path().join("x.tif")),
    );
    assert!(
        e.contains("i16_3band_pixel_strip_lzw_p2.tif") && e.contains("--band 1 to 3"),
        "{e}"
    );
    assert!(!dir.path().join("x.tif").exists());
    // The same from a job.
    let job = dir.path().join("job.toml");
    let from_job = dir.path().join("job_b3.tif");
    std::fs::write(
        &job,
        format!(
            "output_dir = {:?}\n[inputs]\ndem = {:?}\n[[step]]\nname = \"b3\"\nrun = \"export\"\ninput = \"dem\"\noutput = \"job_b3.tif\"\nargs = {{ band = 3 }}\n",
            dir.path().display().to_string(),
            src.display().to_string()
        ),
    )
    .unwrap();
    ok(orogen().arg("run").arg(&job).arg("-q"));
    assert_eq!(common::cli::read_f32(&from_job).data(), &want[..]);
}

#[test]
fn absurd_run_settings_are_clamped_or_refused() {
    let dir = tempfile::tempdir().unwrap();
    let dem = data("bigtujunga_crop.tif");
    // 100 000 threads: clamped to the cores, the same bytes as one thread
    let (a, b) = (dir.path().join("a.tif"), dir.path().join("b.tif"));
    ok(orogen()
        .arg("slope")
        .arg(&dem)
        .args(["--threads", "100000", "--tile", "37", "-q", "-o"])
        .arg(&a));
    ok(orogen()
        .arg("slope")
        .arg(&dem)
        .args(["--threads", "1", "--tile", "37", "-q", "-o"])
        .arg(&b));
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    // a work tile of 0 cells: one clear error, no output
    let c = dir.path().join("c.tif");
    let e = fails(
        orogen()
            .arg("slope")
            .arg(&dem)
            .args(["--tile", "0", "-q", "-o"])
            .arg(&c),
    );
    assert!(e.contains("--tile 0") && e.lines().count() == 1, "{e}");
    assert!(!c.exists());
    // a whole-file output too large to buffer: refused before allocating
    let huge = dir.path().join("huge.tif");
    let e = fails(
        orogen()
            .args(["synth", "noise", "--size", "10000000x10000000", "-q", "-o"])
            .arg(&huge),
    );
    assert!(
        e.contains("huge.tif") && e.contains("tile store") && e.lines().count() == 1,
        "{e}"
    );
    assert!(std::fs::read_dir(dir.path()).unwrap().all(|f| !f
        .unwrap()
        .file_name()
        .to_string_lossy()
        .contains("huge")));
}
