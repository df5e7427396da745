//! A job run from the library (`orogen::ops::job`, no CLI): the same bytes
//! as calling the operations directly, and each mistake refused in
//! `prepare`, before anything is written.

use orogen::exec::EngineConfig;
use orogen::ops::job::{self, JobOptions};
use orogen::ops::parse::{Compress, FormatOptions, RunOptions};
use orogen::ops::{accumulate, fill, flow, slope, Target};
use orogen::raster::RasterSource;
use std::path::{Path, PathBuf};

use crate::common::cli::data;
use crate::common::job::job_fixture;

fn dem() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/bigtujunga_crop.tif")
}

fn quiet() -> JobOptions {
    JobOptions {
        quiet: true,
        no_report: true,
        ..Default::default()
    }
}

/// Runs the job file `tests/data/jobs/NAME` (its input `dem` the test DEM)
/// in `dir` from the library, quietly and without a report.
fn run_job(dir: &Path, name: &str, notify: orogen::ops::note::Notify<'_>) -> job::JobReport {
    let path = dir.join("job.toml");
    let text = job_fixture(name, &[("DEM", &dem().display().to_string())]);
    std::fs::write(&path, text).unwrap();
    let j = job::prepare(&path, &quiet()).unwrap();
    job::run(&j, &quiet(), notify).unwrap()
}

/// The one-raster operation `op` (source, options, target, engine) called
/// directly on the raster at `input`, as a caller of the library does.
fn call<O, T>(
    op: fn(&dyn RasterSource, &O, &Target, &EngineConfig) -> orogen::Result<T>,
    input: &Path,
    opts: &O,
    target: Target,
    cfg: &EngineConfig,
) {
    let src = orogen::io::open_raster(input, &Default::default()).unwrap();
    op(src.as_ref(), opts, &target, cfg).unwrap();
}

#[test]
fn a_job_from_the_library_equals_the_operations_called_directly() {
    let tmp = tempfile::tempdir().unwrap();
    let mut notes = vec![];
    let done = run_job(tmp.path(), "inline_pipeline.toml", &mut |n| notes.push(n));
    assert_eq!(done.outcomes.len(), 4);
    // The same operations called directly.
    let hand = tmp.path().join("hand");
    std::fs::create_dir_all(&hand).unwrap();
    let run = RunOptions {
        threads: 2,
        memory: "128MiB".into(),
        quiet: true,
        ..Default::default()
    };
    let cfg = run.engine_config(false).unwrap();
    let target = |name: &str, f: FormatOptions, tile| Target {
        path: hand.join(name),
        options: f.output_options().unwrap(),
        tile,
    };
    let plain = |name: &str| target(name, FormatOptions::default(), None);
    let zstd = FormatOptions {
        compress: Compress::Zstd,
        ..Default::default()
    };
    let s = slope::SlopeOptions {
        units: orogen::metrics::SlopeUnits::Percent,
        z_factor: 2.0,
        ..Default::default()
    };
    call(
        fill::run,
        &dem(),
        &Default::default(),
        target("filled.tif", zstd, Some(100)),
        &cfg,
    );
    call(
        flow::run,
        &hand.join("filled.tif"),
        &Default::default(),
        plain("d8.tif"),
        &cfg,
    );
    call(
        accumulate::run,
        &hand.join("d8.tif"),
        &Default::default(),
        plain("acc.tif"),
        &cfg,
    );
    call(slope::run, &dem(), &s, plain("slope.tif"), &cfg);
    for name in ["filled.tif", "d8.tif", "acc.tif", "slope.tif"] {
        let a = std::fs::read(tmp.path().join("out").join(name)).unwrap();
        let b = std::fs::read(hand.join(name)).unwrap();
        assert!(
            a == b,
            "{name}: the job's bytes differ from the operation's"
        );
    }
    let wrote: Vec<_> = notes
        .iter()
        .filter_map(|n| match n {
            orogen::ops::note::Note::Wrote(p) => p.file_name(),
            _ => None,
        })
        .collect();
    assert_eq!(wrote, ["filled.tif", "d8.tif", "acc.tif", "slope.tif"]);
}

#[test]
fn ridges_and_viewshed_steps_equal_their_operations() {
    use orogen::ops::{ridges, viewshed};
    let tmp = tempfile::tempdir().unwrap();
    run_job(tmp.path(), "ridges_viewshed.toml", &mut |_| {});
    let hand = tmp.path().join("hand");
    let cfg = RunOptions::default().engine_config(false).unwrap();
    let d = orogen::io::open_raster(&dem(), &Default::default()).unwrap();
    let r = ridges::RidgesOptions {
        min_prominence: 20.0,
        edge: orogen::oro::EdgeConvention::Unknown,
        no_ppa: true,
        ..Default::default()
    };
    let done = ridges::run(d.as_ref(), &hand, &r, &Default::default(), &cfg).unwrap();
    let v = viewshed::ViewshedOptions {
        at: vec![(10.0, 12.0), (30.0, 8.0)],
        pixel: true,
        radius: "40c".into(),
        fuzzy: Some((100.0, 200.0)),
        ..Default::default()
    };
    let target = Target {
        path: hand.join("vis.tif"),
        options: Default::default(),
        tile: None,
    };
    viewshed::run(d.as_ref(), &v, &target, &cfg).unwrap();
    let mut names: Vec<PathBuf> = done
        .files
        .iter()
        .map(|f| Path::new("ridges").join(f.file_name().unwrap()))
        .collect();
    names.push("vis.tif".into());
    for name in names {
        let a = std::fs::read(tmp.path().join("out").join(&name)).unwrap();
        let b = std::fs::read(hand.join(name.strip_prefix("ridges").unwrap_or(&name))).unwrap();
        assert!(a == b, "{}: the job's bytes differ", name.display());
    }
}

#[test]
fn an_erode_step_equals_the_operation() {
    use orogen::ops::erode::{self, ErodeOptions, Model};
    let tmp = tempfile::tempdir().unwrap();
    run_job(tmp.path(), "erode_thermal.toml", &mut |_| {});
    let hand = tmp.path().join("hand.tif");
    let e = ErodeOptions {
        input: dem(),
        model: Model::Thermal,
        steps: Some(3),
        talus: Some(30.0),
        set: vec!["rate=0.4".into()],
        output: hand.clone(),
        tile: Some(64),
        ..Default::default()
    };
    let run = RunOptions {
        tile: Some(64),
        ..Default::default()
    };
    let cfg = run.engine_config(false).unwrap();
    erode::run(
        &e,
        &Default::default(),
        &Default::default(),
        &cfg,
        &mut |_| {},
    )
    .unwrap();
    let a = std::fs::read(tmp.path().join("out/eroded.tif")).unwrap();
    assert!(a == std::fs::read(&hand).unwrap(), "the job's bytes differ");
}

#[test]
fn orometric_synthesis_steps_equal_the_operations() {
    use orogen::ops::synth::orometric as oro;
    let tmp = tempfile::tempdir().unwrap();
    run_job(tmp.path(), "orometric_synthesis.toml", &mut |_| {});
    let hand = tmp.path().join("hand");
    std::fs::create_dir_all(&hand).unwrap();
    let cfg = RunOptions::default().engine_config(false).unwrap();
    let p = oro::ProfileOptions {
        input: dem(),
        min_prominence: 10.0,
        output: hand.join("p.json"),
        ..Default::default()
    };
    oro::run_profile(&p, &Default::default(), &mut |_| {}).unwrap();
    let t = oro::DivideTreeOptions {
        tree: oro::TreeSynthOptions {
            profile: hand.join("p.json"),
            size: "64".into(),
            cell: 30.0,
            seed: 2,
            ..Default::default()
        },
        output: hand.join("t.json"),
        geojson: None,
    };
    oro::run_divide_tree(&t, &mut |_| {}).unwrap();
    let f = oro::FromTreeOptions {
        tree: hand.join("t.json"),
        terrain: oro::TerrainSynthOptions {
            terrain: oro::TerrainKind::Tents,
            ..Default::default()
        },
        output: hand.join("f.tif"),
        ..Default::default()
    };
    oro::run_from_tree(&f, &Default::default(), &cfg, &mut |_| {}).unwrap();
    for name in ["p.json", "t.json", "f.tif"] {
        let a = std::fs::read(tmp.path().join("out").join(name)).unwrap();
        let b = std::fs::read(hand.join(name)).unwrap();
        assert!(a == b, "{name}: the job's bytes differ");
    }
}

/// The cases of `tests/data/jobs/prepare_mistakes.toml`.
#[derive(serde::Deserialize)]
struct Mistakes {
    case: Vec<Mistake>,
}

/// One step `s` that `prepare` must refuse, and the texts of its error.
#[derive(serde::Deserialize)]
struct Mistake {
    what: String,
    run: String,
    input: Option<String>,
    args: Option<String>,
    want: Vec<String>,
}

#[test]
fn each_mistake_is_refused_in_prepare_naming_step_and_key() {
    let d = dem().display().to_string();
    let table = std::fs::read_to_string(data("jobs/prepare_mistakes.toml")).unwrap();
    let cases = toml::from_str::<Mistakes>(&table).unwrap().case;
    assert_eq!(cases.len(), 9, "a case of the table is lost");
    for Mistake {
        what,
        run,
        input,
        args,
        want,
    } in cases
    {
        let input = input
            .map(|i| format!("input = \"{i}\""))
            .unwrap_or_default();
        let args = args.map(|a| format!("args = {a}")).unwrap_or_default();
        let text = format!(
            "output_dir = \"out\"\n[inputs]\ndem = \"{d}\"\nlost = \"no-such.tif\"\n[[step]]\nname = \"s\"\nrun = \"{run}\"\n{input}\noutput = \"x.csv\"\n{args}\n"
        );
        let tmp = tempfile::tempdir().unwrap();
        let path = tmp.path().join("bad.toml");
        std::fs::write(&path, &text).unwrap();
        let err = match job::prepare(&path, &quiet()) {
            Ok(_) => panic!("{what}: accepted"),
            Err(e) => e.to_string(),
        };
        assert!(err.contains("bad.toml"), "{what}: {err}");
        for w in want {
            assert!(err.contains(&w), "{what}: no {w:?} in: {err}");
        }
        // Nothing was written: not even the output folder.
        assert!(!tmp.path().join("out").exists(), "{what}");
    }
}

#[test]
fn run_settings_go_only_to_commands_that_take_them() {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("job.toml");
    let job = |train_args: &str| {
        format!(
            "memory = \"256MiB\"\noutput_dir = \"out\"\ninputs = {{ dem = \"{}\" }}\nstep = [\n    {{ name = \"f\", run = \"fill\", input = \"dem\", output = \"f.tif\" }},\n    {{ name = \"m\", run = \"classify train\", input = \"dem\", output = \"m.json\"{train_args} }},\n]\n",
            dem().display()
        )
    };
    std::fs::write(&path, job("")).unwrap();
    let j = job::prepare(&path, &quiet()).unwrap();
    let argv = |name: &str| {
        j.steps
            .iter()
            .find(|s| s.name == name)
            .unwrap()
            .argv
            .clone()
    };
    assert!(argv("f").contains(&"--memory".to_string()));
    assert!(
        !argv("m").contains(&"--memory".to_string()),
        "{:?}",
        argv("m")
    );
    // `classify train` has no run settings: a step may not set them.
    std::fs::write(&path, job(", args = { threads = 2 }")).unwrap();
    let err = job::prepare(&path, &quiet()).unwrap_err().to_string();
    assert!(
        err.contains("`classify train` has no option --threads"),
        "{err}"
    );
}
