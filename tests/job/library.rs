//! A job run from the library (`orogen::ops::job`, no CLI): the same bytes
//! as calling the operations directly, and each mistake refused in
//! `prepare`, before anything is written.

use orogen::ops::job::{self, JobOptions};
use orogen::ops::parse::{Compress, FormatOptions, RunOptions};
use orogen::ops::{accumulate, fill, flow, slope, Target};
use std::path::{Path, PathBuf};

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

#[test]
fn a_job_from_the_library_equals_the_operations_called_directly() {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("job.toml");
    std::fs::write(
        &path,
        format!(
            r#"memory = "128MiB"
threads = 2
output_dir = "out"
inputs = {{ dem = "{}" }}
step = [
    {{ name = "acc", run = "accumulate", input = "d8", output = "acc.tif" }},
    {{ name = "filled", run = "fill", input = "dem", output = "filled.tif", args = {{ compress = "zstd", tile = 100 }} }},
    {{ name = "d8", run = "flow", input = "filled", output = "d8.tif" }},
    {{ name = "slope", run = "slope", input = "dem", output = "slope.tif", args = {{ units = "percent", z-factor = 2 }} }},
]
"#,
            dem().display()
        ),
    )
    .unwrap();
    let opts = quiet();
    let j = job::prepare(&path, &opts).unwrap();
    let mut notes = vec![];
    let done = job::run(&j, &opts, &mut |n| notes.push(n)).unwrap();
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
    let open = |p: &Path| orogen::io::open_raster(p, &Default::default()).unwrap();
    let zstd = FormatOptions {
        compress: Compress::Zstd,
        ..Default::default()
    };
    let d = open(&dem());
    fill::run(
        d.as_ref(),
        &Default::default(),
        &target("filled.tif", zstd, Some(100)),
        &cfg,
    )
    .unwrap();
    let f = open(&hand.join("filled.tif"));
    flow::run(
        f.as_ref(),
        &Default::default(),
        &target("d8.tif", Default::default(), None),
        &cfg,
    )
    .unwrap();
    let d8 = open(&hand.join("d8.tif"));
    accumulate::run(
        d8.as_ref(),
        &Default::default(),
        &target("acc.tif", Default::default(), None),
        &cfg,
    )
    .unwrap();
    let s = slope::SlopeOptions {
        units: orogen::metrics::SlopeUnits::Percent,
        z_factor: 2.0,
        ..Default::default()
    };
    slope::run(
        d.as_ref(),
        &s,
        &target("slope.tif", Default::default(), None),
        &cfg,
    )
    .unwrap();
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
    let path = tmp.path().join("job.toml");
    std::fs::write(
        &path,
        format!(
            r#"output_dir = "out"
inputs = {{ dem = "{}" }}
step = [
    {{ name = "r", run = "ridges", input = "dem", output = "ridges", args = {{ min-prominence = 20, edge = "unknown", no_ppa = true }} }},
    {{ name = "v", run = "viewshed", input = "dem", output = "vis.tif", args = {{ at = ["10,12", "30,8"], pixel = true, radius = "40c", fuzzy = "100,200" }} }},
]
"#,
            dem().display()
        ),
    )
    .unwrap();
    let opts = quiet();
    let j = job::prepare(&path, &opts).unwrap();
    job::run(&j, &opts, &mut |_| {}).unwrap();
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
    let path = tmp.path().join("job.toml");
    std::fs::write(
        &path,
        format!(
            r#"output_dir = "out"
inputs = {{ dem = "{}" }}
step = [
    {{ name = "e", run = "erode", input = "dem", output = "eroded.tif", args = {{ model = "thermal", steps = 3, talus = 30, set = "rate=0.4", tile = 64 }} }},
]
"#,
            dem().display()
        ),
    )
    .unwrap();
    let opts = quiet();
    let j = job::prepare(&path, &opts).unwrap();
    job::run(&j, &opts, &mut |_| {}).unwrap();
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
    let path = tmp.path().join("job.toml");
    std::fs::write(
        &path,
        format!(
            r#"output_dir = "out"
inputs = {{ dem = "{}" }}
step = [
    {{ name = "p", run = "synth profile", input = "dem", output = "p.json", args = {{ min_prominence = 10 }} }},
    {{ name = "t", run = "synth divide-tree", output = "t.json", args = {{ profile = "@p", size = "64", cell = 30, seed = 2 }} }},
    {{ name = "f", run = "synth from-tree", input = "t", output = "f.tif", args = {{ terrain = "tents" }} }},
]
"#,
            dem().display()
        ),
    )
    .unwrap();
    let opts = quiet();
    let j = job::prepare(&path, &opts).unwrap();
    job::run(&j, &opts, &mut |_| {}).unwrap();
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

#[test]
fn each_mistake_is_refused_in_prepare_naming_step_and_key() {
    let d = dem().display().to_string();
    let step = |run: &str, input: &str, args: &str| {
        format!(
            "output_dir = \"out\"\n[inputs]\ndem = \"{d}\"\nlost = \"no-such.tif\"\n[[step]]\nname = \"s\"\nrun = \"{run}\"\n{input}\noutput = \"x.csv\"\n{args}\n"
        )
    };
    let cases = [
        (
            "unknown key",
            step("slope", "input = \"dem\"", "args = { zfactor = 2 }"),
            vec![
                "step \"s\"",
                "`slope` has no option --zfactor (did you mean z_factor?)",
                "it accepts: units, z_factor, compute_edges, compress",
            ],
        ),
        (
            "bad value",
            step(
                "orostats",
                "input = \"dem\"",
                "args = { radius = \"ten km\" }",
            ),
            vec![
                "step \"s\"",
                "`orostats` option radius = \"ten km\"",
                "expected a distance like 10km or 500m",
            ],
        ),
        (
            "bad choice",
            step("slope", "input = \"dem\"", "args = { units = \"radians\" }"),
            vec!["option units = \"radians\"", "degrees", "percent"],
        ),
        (
            "missing input file",
            step("fill", "input = \"lost\"", ""),
            vec![
                "step \"s\"",
                "no-such.tif does not exist (and no step writes it)",
            ],
        ),
        (
            "no input",
            step("fill", "", ""),
            vec!["step \"s\"", "`fill` needs an input"],
        ),
        (
            "bad pair",
            step("viewshed", "input = \"dem\"", "args = { at = \"ten,20\" }"),
            vec![
                "step \"s\"",
                "`viewshed` option at = \"ten,20\"",
                "expected two numbers separated by a comma",
            ],
        ),
        (
            "no model",
            step("erode", "input = \"dem\"", "args = { steps = 3 }"),
            vec!["step \"s\"", "`erode` needs its model"],
        ),
        (
            "interactive",
            step("view", "input = \"dem\"", ""),
            vec!["step \"s\"", "`view` starts an interactive map server"],
        ),
        (
            "required option",
            step("synth optimise", "", "args = { guide = \"g.tif\" }"),
            vec!["step \"s\"", "`synth optimise` needs source"],
        ),
    ];
    for (what, text, want) in cases {
        let tmp = tempfile::tempdir().unwrap();
        let path = tmp.path().join("bad.toml");
        std::fs::write(&path, &text).unwrap();
        let err = match job::prepare(&path, &quiet()) {
            Ok(_) => panic!("{what}: accepted"),
            Err(e) => e.to_string(),
        };
        assert!(err.contains("bad.toml"), "{what}: {err}");
        for w in want {
            assert!(err.contains(w), "{what}: no {w:?} in: {err}");
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
