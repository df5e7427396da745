//! `orogen erode` from the command line: outputs and previews, bytes
//! independent of tile size, exchange period and state backend, parameters
//! from a TOML file, clear errors for bad parameters.

use crate::common::cli::{fails_args as fails, ok_args as ok, s};
use std::path::{Path, PathBuf};

/// `erode DEM --model MODEL EXTRA -o OUT`.
fn erode<'a>(dem: &'a Path, model: &'a str, extra: &[&'a str], out: &'a Path) -> Vec<&'a str> {
    let mut v = vec!["erode", s(dem), "--model", model];
    v.extend_from_slice(extra);
    v.extend_from_slice(&["-o", s(out)]);
    v
}

fn dem(dir: &Path) -> PathBuf {
    let p = dir.join("dem.tif");
    ok(&[
        "synth",
        "noise",
        "--size",
        "61x47",
        "--wavelength",
        "24",
        "--octaves",
        "5",
        "--cell",
        "10",
        "-q",
        "-o",
        p.to_str().unwrap(),
    ]);
    p
}

#[test]
fn hydraulic_writes_outputs_and_previews_independent_of_tiling() {
    let dir = tempfile::tempdir().unwrap();
    let d = dem(dir.path());
    let a = dir.path().join("a.tif");
    let b = dir.path().join("b.tif");
    let c = dir.path().join("c.tif");
    let water = dir.path().join("w.tif");
    let pv = dir.path().join("pv");
    // 25 hydraulic steps with rain, tiled as `tiling`.
    let rain = |tiling: &[&str], out: &Path| {
        let mut args = vec!["erode", s(&d), "--model", "hydraulic", "--steps", "25"];
        args.extend_from_slice(tiling);
        args.extend_from_slice(&["-q", "--set", "rain=0.05", "-o", s(out)]);
        ok(&args);
    };
    rain(
        &["--tile", "64", "--water", s(&water), "--preview", s(&pv)],
        &a,
    );
    rain(&["--tile", "7", "--exchange", "3"], &b);
    let scratch = dir.path().join("scratch");
    std::fs::create_dir_all(&scratch).unwrap();
    rain(
        &[
            "--tile",
            "13",
            "--exchange",
            "1",
            "--threads",
            "1",
            "--scratch",
            s(&scratch),
        ],
        &c,
    );
    let (ba, bb, bc) = (
        std::fs::read(&a).unwrap(),
        std::fs::read(&b).unwrap(),
        std::fs::read(&c).unwrap(),
    );
    assert_eq!(ba, bb, "tile 64 and tile 7 differ");
    assert_eq!(ba, bc, "memory and scratch-folder states differ");
    assert_ne!(ba, std::fs::read(&d).unwrap());
    assert!(water.exists());
    for f in ["before.png", "after.png"] {
        let bytes = std::fs::read(pv.join(f)).unwrap();
        assert_eq!(&bytes[1..4], b"PNG", "{f} is not a PNG");
    }
    assert!(
        std::fs::read_dir(&scratch).unwrap().next().is_none(),
        "the scratch folder was not cleaned"
    );
}

#[test]
fn params_file_gives_model_tables_and_steps() {
    let dir = tempfile::tempdir().unwrap();
    let d = dem(dir.path());
    let toml = dir.path().join("p.toml");
    std::fs::write(
        &toml,
        "steps = 6\nexchange = 2\n[thermal]\ntalus = 20.0\nrate = 0.3\n[diffusion]\ndiffusivity = 5.0\ndt = 2.0\n",
    )
    .unwrap();
    let a = dir.path().join("t1.tif");
    let b = dir.path().join("t2.tif");
    ok(&erode(&d, "thermal", &["--params", s(&toml), "-q"], &a));
    // Flags override the file; the same values give the same bytes.
    ok(&erode(
        &d,
        "thermal",
        &[
            "--params",
            s(&toml),
            "--steps",
            "6",
            "--talus",
            "20",
            "--tile",
            "9",
            "-q",
        ],
        &b,
    ));
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    // The example parameter file of the repository is valid.
    let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/erosion-hydraulic.toml");
    let h = dir.path().join("h.tif");
    ok(&erode(
        &d,
        "hydraulic",
        &["--params", s(&example), "--steps", "3", "-q"],
        &h,
    ));
    let c = dir.path().join("d.tif");
    ok(&erode(
        &d,
        "diffusion",
        &["--params", s(&toml), "--tile", "16", "-q"],
        &c,
    ));
    assert_ne!(std::fs::read(&c).unwrap(), std::fs::read(&d).unwrap());
}

#[test]
fn bad_parameters_give_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let d = dem(dir.path());
    let o = dir.path().join("o.tif");
    let base = |extra: &[&str]| -> String {
        let mut v = vec!["erode", s(&d), "-q", "-o", s(&o)];
        v.extend_from_slice(extra);
        fails(&v)
    };
    let e = base(&["--model", "hydraulic", "--steps", "0"]);
    assert!(e.contains("steps = 0"), "{e}");
    let e = base(&[
        "--model",
        "hydraulic",
        "--steps",
        "5",
        "--set",
        "capacity=-1",
    ]);
    assert!(e.contains("capacity") && e.contains("between"), "{e}");
    let e = base(&["--model", "thermal", "--steps", "5", "--talus", "90"]);
    assert!(e.contains("talus") && e.contains("90"), "{e}");
    let e = base(&["--model", "hydraulic", "--steps", "5", "--talus", "30"]);
    assert!(e.contains("--talus does not apply"), "{e}");
    let e = base(&[
        "--model",
        "diffusion",
        "--steps",
        "5",
        "--diffusivity",
        "-1",
    ]);
    assert!(e.contains("diffusivity"), "{e}");
    let e = base(&["--model", "thermal"]);
    assert!(e.contains("--steps"), "{e}");
    let toml = dir.path().join("bad.toml");
    std::fs::write(&toml, "[hydraulic]\nrainn = 0.1\n").unwrap();
    let e = base(&["--model", "hydraulic", "--steps", "5", "--params", s(&toml)]);
    assert!(e.contains("rainn") && e.contains("rain_probability"), "{e}");
    std::fs::write(&toml, "stepz = 3\n").unwrap();
    let e = base(&["--model", "hydraulic", "--steps", "5", "--params", s(&toml)]);
    assert!(e.contains("stepz") && e.contains("exchange"), "{e}");
    assert!(!o.exists(), "a failed run left an output");
}
