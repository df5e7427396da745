//! The typed commands of a job: each builder turns a step into its
//! operation's options (checked here, in `prepare`) and a closure running
//! `ops::<cmd>::run`, doing what the command does (open the input with its
//! georeference warning, write the target, note what was written).

use super::commands::{
    join_lists, one_input, output, step_error, typed_keys, typed_keys_with, StepCall, Takes,
    TypedStep,
};
use crate::error::Result;
use crate::exec::EngineConfig;
use crate::ops::note::{open_input, warn_georef, Note, Notify};
use crate::ops::parse::RunOptions;
use crate::ops::{self, Target};
use crate::raster::RasterSource;
use serde::de::DeserializeOwned;
use serde::Serialize;

/// Reads a raster, writes rasters.
pub(super) const RASTER: Takes = Takes {
    format: true,
    input: true,
};
/// Reads a raster, writes files of its own.
pub(super) const FILES: Takes = Takes {
    format: false,
    input: true,
};
/// Reads no raster of its own, writes rasters.
pub(super) const WRITES: Takes = Takes {
    format: true,
    input: false,
};
/// Neither.
pub(super) const NEITHER: Takes = Takes {
    format: false,
    input: false,
};

/// The options of a command that has none of its own (`ingest`, `export`).
#[derive(Debug, Clone, Default, PartialEq, Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub(super) struct NoOptions {}

/// What a one-input raster operation runs once its input is open.
type RasterOp<O> =
    fn(&dyn RasterSource, &O, &Target, &EngineConfig, &RunOptions, Notify<'_>) -> Result<()>;

pub(super) fn engine_config(run: &RunOptions) -> Result<EngineConfig> {
    use std::io::IsTerminal;
    run.engine_config(std::io::stderr().is_terminal())
}

/// A command reading one raster and writing one target: its options `O`
/// checked by `check`, then `op` run on the opened input.
fn raster_step<O>(
    call: &StepCall<'_>,
    check: fn(&O) -> Result<()>,
    op: RasterOp<O>,
) -> Result<TypedStep>
where
    O: DeserializeOwned + Serialize + Send + Sync + 'static,
{
    let s = call.step;
    let t = typed_keys::<O>(call, RASTER)?;
    check(&t.options).map_err(|e| step_error(s, e))?;
    let input = one_input(s)?;
    let path = output(s)?;
    let target = Target {
        path: path.clone(),
        options: t.format.output_options()?,
        tile: t.run.tile,
    };
    let (run, png, opts) = (t.run, t.input.open_options(), t.options);
    Ok(TypedStep::new(opts, move |opts, notify| {
        let cfg = engine_config(&run)?;
        let src = open_input(&input, &png, notify)?;
        op(src.as_ref(), opts, &target, &cfg, &run, notify)?;
        notify(Note::Wrote(path.clone()));
        Ok(())
    }))
}

pub(super) fn unchecked<O>(_: &O) -> Result<()> {
    Ok(())
}

/// Builders of the commands whose operation is
/// `ops::<cmd>::run(input, options, target, engine)` as it is.
macro_rules! plain_raster_steps {
    ($($name:ident => $run:path),* $(,)?) => {$(
        pub(super) fn $name(call: &StepCall<'_>) -> Result<TypedStep> {
            raster_step(call, unchecked, |src, o, t, cfg, _, _| $run(src, o, t, cfg))
        }
    )*};
}

plain_raster_steps! {
    fill_nodata => ops::fill_nodata::run,
    fill => ops::fill::run,
    fill_epsilon => ops::fill_epsilon::run,
    watersheds => ops::watersheds::run,
    flow => ops::flow::run,
    slope => ops::slope::run,
    aspect => ops::aspect::run,
}

pub(super) fn hillshade(call: &StepCall<'_>) -> Result<TypedStep> {
    raster_step(
        call,
        ops::hillshade::HillshadeOptions::validate,
        |src, o, t, cfg, _, _| ops::hillshade::run(src, o, t, cfg),
    )
}

pub(super) fn accumulate(call: &StepCall<'_>) -> Result<TypedStep> {
    raster_step(call, unchecked, |src, o, t, cfg, run, notify| {
        let outcome = ops::accumulate::run(src, o, t, cfg)?;
        if !run.quiet && outcome.rounds > 0 {
            notify(Note::Info(format!(
                "accumulate: {} rounds over tiles to the exact fixed point",
                outcome.rounds
            )));
        }
        Ok(())
    })
}

pub(super) fn export(call: &StepCall<'_>) -> Result<TypedStep> {
    raster_step::<NoOptions>(call, unchecked, |src, _, t, cfg, _, notify| {
        ops::convert::run(src, t, cfg, notify)
    })
}

/// `ingest`: one or more inputs (one mosaic) into the output.
pub(super) fn ingest(call: &StepCall<'_>) -> Result<TypedStep> {
    let s = call.step;
    let t = typed_keys::<NoOptions>(call, RASTER)?;
    if s.inputs.is_empty() {
        one_input(s)?;
    }
    let inputs = s.inputs.clone();
    let path = output(s)?;
    let target = Target {
        path: path.clone(),
        options: t.format.output_options()?,
        tile: t.run.tile,
    };
    let (run, png) = (t.run, t.input.open_options());
    Ok(TypedStep::new(t.options, move |_, notify| {
        let src = crate::io::open_inputs(&inputs, &png)?;
        warn_georef(src.as_ref(), notify);
        ops::convert::run(src.as_ref(), &target, &engine_config(&run)?, notify)?;
        notify(Note::Wrote(path.clone()));
        Ok(())
    }))
}

/// `metric`: the metrics (a comma-separated string or a list) into the
/// output folder, one file each.
pub(super) fn metric(call: &StepCall<'_>) -> Result<TypedStep> {
    let mut joined = call.step.clone();
    joined.args = join_lists(&joined.args, "metric");
    let call = StepCall {
        step: &joined,
        quiet: call.quiet,
        observer: call.observer.clone(),
    };
    let s = call.step;
    let t = typed_keys::<ops::metric::MetricOptions>(&call, RASTER)?;
    if t.options.metric.is_empty() {
        return Err(step_error(
            s,
            "`metric` needs its metrics: args = { metric = [\"slope\", ...] } (see `orogen metric list`)",
        ));
    }
    t.options.specs().map_err(|e| step_error(s, e))?;
    let input = one_input(s)?;
    let dir = output(s)?;
    let oo = t.format.output_options()?;
    let (run, png, opts) = (t.run, t.input.open_options(), t.options);
    Ok(TypedStep::new(opts, move |opts, notify| {
        let cfg = engine_config(&run)?;
        let src = open_input(&input, &png, notify)?;
        for p in ops::metric::run(src.as_ref(), &dir, opts, &oo, run.tile, &cfg)? {
            notify(Note::Wrote(p));
        }
        Ok(())
    }))
}

pub(super) fn breach(call: &StepCall<'_>) -> Result<TypedStep> {
    raster_step(
        call,
        |o: &ops::breach::BreachOptions| o.resolve().map(|_| ()),
        |src, o, t, cfg, _, _| ops::breach::run(src, o, t, cfg),
    )
}

/// A command reading one raster and writing files of its own (no raster
/// format keys): its options checked by `check`, then `op` run with the
/// output path.
fn files_step<O>(
    call: &StepCall<'_>,
    check: fn(&O, &std::path::Path) -> Result<()>,
    op: fn(&dyn RasterSource, &std::path::Path, &O, &EngineConfig, Notify<'_>) -> Result<()>,
) -> Result<TypedStep>
where
    O: DeserializeOwned + Serialize + Send + Sync + 'static,
{
    let s = call.step;
    let t = typed_keys::<O>(call, FILES)?;
    let input = one_input(s)?;
    let path = output(s)?;
    check(&t.options, &path).map_err(|e| step_error(s, e))?;
    let (run, png) = (t.run, t.input.open_options());
    Ok(TypedStep::new(t.options, move |opts, notify| {
        let cfg = engine_config(&run)?;
        let src = open_input(&input, &png, notify)?;
        op(
            src.as_ref(),
            &path,
            opts,
            &cfg,
            &mut quiet_filter(run.quiet, notify),
        )
    }))
}

pub(super) fn peaks(call: &StepCall<'_>) -> Result<TypedStep> {
    files_step(
        call,
        |o: &ops::peaks::PeaksOptions, _| o.validate(),
        |src, dir, o, cfg, notify| ops::peaks::run_noted(src, dir, o, cfg, notify).map(|_| ()),
    )
}

pub(super) fn orostats(call: &StepCall<'_>) -> Result<TypedStep> {
    files_step(
        call,
        |o: &ops::orostats::OrostatsOptions, out| {
            o.stats_options()?;
            ops::orostats::check_output(out)
        },
        |src, out, o, cfg, notify| ops::orostats::run_noted(src, out, o, cfg, notify).map(|_| ()),
    )
}

/// `ridges`: one input into the output folder (ridges.geojson and its
/// rasters, in the output format).
pub(super) fn ridges(call: &StepCall<'_>) -> Result<TypedStep> {
    let s = call.step;
    let t = typed_keys::<ops::ridges::RidgesOptions>(call, RASTER)?;
    t.options.validate().map_err(|e| step_error(s, e))?;
    let input = one_input(s)?;
    let dir = output(s)?;
    let oo = t.format.output_options()?;
    let (run, png) = (t.run, t.input.open_options());
    Ok(TypedStep::new(t.options, move |opts, notify| {
        let cfg = engine_config(&run)?;
        let src = open_input(&input, &png, notify)?;
        let mut notify = quiet_filter(run.quiet, notify);
        ops::ridges::run_noted(src.as_ref(), &dir, opts, &oo, &cfg, &mut notify).map(|_| ())
    }))
}

pub(super) fn viewshed(call: &StepCall<'_>) -> Result<TypedStep> {
    raster_step(
        call,
        ops::viewshed::ViewshedOptions::validate,
        |src, o, t, cfg, _, _| ops::viewshed::run(src, o, t, cfg),
    )
}

pub(super) fn render(call: &StepCall<'_>) -> Result<TypedStep> {
    files_step(
        call,
        |_: &ops::render::RenderOptions, _| Ok(()),
        |src, out, o, _, notify| {
            ops::render::run(src, out, o)?;
            notify(Note::Wrote(out.to_path_buf()));
            Ok(())
        },
    )
}

/// `info`: the report of one input on standard output (no output file).
pub(super) fn info(call: &StepCall<'_>) -> Result<TypedStep> {
    let s = call.step;
    let t = typed_keys::<ops::info::InfoOptions>(call, FILES)?;
    let input = one_input(s)?;
    if s.output.is_some() {
        return Err(step_error(s, "`info` writes no file: leave out output"));
    }
    let (run, png) = (t.run, t.input.open_options());
    Ok(TypedStep::new(t.options, move |opts, notify| {
        let cfg = engine_config(&run)?;
        let src = open_input(&input, &png, notify)?;
        let d = ops::info::run(src.as_ref(), opts, &cfg)?;
        notify(Note::Print(ops::info::report_text(&d, opts)?));
        Ok(())
    }))
}

#[cfg(feature = "learn")]
pub(super) use classify::{classify_evaluate, classify_predict, classify_train};

/// The `classify` steps (the `learn` feature: smartcore's random forest).
#[cfg(feature = "learn")]
mod classify {
    use super::*;

    /// The step's inputs as feature files, refused when there are none.
    fn feature_inputs(
        s: &crate::ops::job::Planned,
        from: usize,
    ) -> Result<Vec<std::path::PathBuf>> {
        match s.inputs.get(from..) {
            Some(f) if !f.is_empty() => Ok(f.to_vec()),
            _ => Err(step_error(
                s,
                format!(
                    "`{}` needs feature files: input = [{}\"a.csv\", ...]",
                    s.command,
                    if from == 1 { "\"model\", " } else { "" }
                ),
            )),
        }
    }

    pub(in crate::ops::job) fn classify_train(call: &StepCall<'_>) -> Result<TypedStep> {
        let s = call.step;
        let t = typed_keys::<ops::classify::ForestOptions>(call, NEITHER)?;
        let features = feature_inputs(s, 0)?;
        let model = output(s)?;
        Ok(TypedStep::new(t.options, move |opts, notify| {
            ops::classify::train_noted(&features, opts, &model, notify).map(|_| ())
        }))
    }

    pub(in crate::ops::job) fn classify_predict(call: &StepCall<'_>) -> Result<TypedStep> {
        let s = call.step;
        let t = typed_keys::<NoOptions>(call, NEITHER)?;
        let features = feature_inputs(s, 1)?;
        let model = s.inputs[0].clone();
        let out = s.output.clone();
        Ok(TypedStep::new(t.options, move |_, notify| {
            ops::classify::predict_noted(&model, &features, out.as_deref(), notify)
        }))
    }

    /// The keys of `classify evaluate`: [`ops::classify::EvaluateOptions`]
    /// with its forest's fields at the top (a flattened serde struct cannot
    /// refuse unknown keys).
    #[derive(Debug, Clone, Serialize, serde::Deserialize)]
    #[serde(default, deny_unknown_fields)]
    struct EvaluateKeys {
        trees: u16,
        seed: u64,
        mtry: Option<usize>,
        max_depth: Option<u16>,
        repeats: usize,
        test_fraction: f64,
    }

    impl Default for EvaluateKeys {
        fn default() -> Self {
            let e = ops::classify::EvaluateOptions::default();
            EvaluateKeys {
                trees: e.forest.trees,
                seed: e.forest.seed,
                mtry: e.forest.mtry,
                max_depth: e.forest.max_depth,
                repeats: e.repeats,
                test_fraction: e.test_fraction,
            }
        }
    }

    pub(in crate::ops::job) fn classify_evaluate(call: &StepCall<'_>) -> Result<TypedStep> {
        let s = call.step;
        let k = typed_keys::<EvaluateKeys>(call, NEITHER)?.options;
        let features = feature_inputs(s, 0)?;
        let out = s.output.clone();
        let opts = ops::classify::EvaluateOptions {
            forest: ops::classify::ForestOptions {
                trees: k.trees,
                seed: k.seed,
                mtry: k.mtry,
                max_depth: k.max_depth,
            },
            repeats: k.repeats,
            test_fraction: k.test_fraction,
        };
        Ok(TypedStep::new(opts, move |opts, notify| {
            ops::classify::evaluate_noted(&features, opts, out.as_deref(), notify).map(|_| ())
        }))
    }
}

#[cfg(not(feature = "learn"))]
pub(super) use no_classify::{classify_evaluate, classify_predict, classify_train};

/// The `classify` steps of a build without the `learn` feature: each
/// refuses with a message saying how to get them.
#[cfg(not(feature = "learn"))]
mod no_classify {
    use super::*;

    fn refuse(call: &StepCall<'_>) -> Result<TypedStep> {
        Err(step_error(
            call.step,
            format!(
                "`{}` needs the random-forest classifier, which this build of orogen \
                 leaves out: build with `--features learn` (on by default)",
                call.step.command
            ),
        ))
    }
    pub(in crate::ops::job) fn classify_train(call: &StepCall<'_>) -> Result<TypedStep> {
        refuse(call)
    }
    pub(in crate::ops::job) fn classify_predict(call: &StepCall<'_>) -> Result<TypedStep> {
        refuse(call)
    }
    pub(in crate::ops::job) fn classify_evaluate(call: &StepCall<'_>) -> Result<TypedStep> {
        refuse(call)
    }
}

/// `demo`: no input; into the step's output folder (the CLI's default,
/// `orogen-demo`, without one).
pub(super) fn demo(call: &StepCall<'_>) -> Result<TypedStep> {
    let s = call.step;
    if !s.inputs.is_empty() {
        return Err(step_error(s, "`demo` takes no input"));
    }
    let t = typed_keys::<ops::demo::DemoOptions>(call, NEITHER)?;
    let dir = s.output.clone().unwrap_or_else(|| "orogen-demo".into());
    let run = t.run;
    Ok(TypedStep::new(t.options, move |opts, notify| {
        let files = ops::demo::run(&dir, opts, &engine_config(&run)?)?;
        notify(Note::Print(ops::demo::listing(&dir, opts, &files)));
        Ok(())
    }))
}

/// `view` serves an interactive map until stopped: never a job's step.
pub(super) fn view(call: &StepCall<'_>) -> Result<TypedStep> {
    Err(step_error(
        call.step,
        "`view` starts an interactive map server that runs until stopped, so a job cannot run it; run `orogen view` on the step's output yourself",
    ))
}

/// `erode`: one input into the output (both, and the work tile, part of
/// its options); `set` a `"KEY=VALUE"` or a list of them, `levels` a list
/// of numbers or `"100,50,30"`, `base_level` a list or `"north,south"`.
pub(super) fn erode(call: &StepCall<'_>) -> Result<TypedStep> {
    let s = call.step;
    let mut step = s.clone();
    step.args = join_lists(&step.args, "base_level");
    if let Some(toml::Value::String(t)) = step.args.get("set") {
        let one = toml::Value::Array(vec![toml::Value::String(t.clone())]);
        step.args.insert("set".into(), one);
    }
    if let Some(toml::Value::String(t)) = step.args.get("levels") {
        let mut list = vec![];
        for v in t.split(',') {
            match v.trim().parse::<f64>() {
                Ok(x) => list.push(toml::Value::Float(x)),
                Err(_) => {
                    return Err(step_error(
                        s,
                        format!(
                        "`erode` option levels = {t:?}: expected cell sizes such as \"100,50,30\""
                    ),
                    ))
                }
            }
        }
        step.args.insert("levels".into(), toml::Value::Array(list));
    }
    if !step.args.contains_key("model") {
        return Err(step_error(
            s,
            "`erode` needs its model: model = \"hydraulic\" (or thermal, diffusion, stream-power)",
        ));
    }
    let path = output(s)?;
    let mut set = vec![
        (
            "input",
            toml::Value::String(one_input(s)?.display().to_string()),
        ),
        ("output", toml::Value::String(path.display().to_string())),
    ];
    if let Some(t) = step.args.get("tile") {
        set.push(("tile", t.clone()));
    }
    let call = StepCall {
        step: &step,
        quiet: call.quiet,
        observer: call.observer.clone(),
    };
    let t = typed_keys_with::<ops::erode::ErodeOptions>(&call, RASTER, set)?;
    t.options.validate().map_err(|e| step_error(s, e))?;
    let oo = t.format.output_options()?;
    let (run, png) = (t.run, t.input.open_options());
    Ok(TypedStep::new(t.options, move |opts, notify| {
        let cfg = engine_config(&run)?;
        ops::erode::run(opts, &png, &oo, &cfg, &mut quiet_filter(run.quiet, notify))
    }))
}

/// A command reading D8 directions (no PNG keys) and writing a target.
fn dirs_step<O>(
    call: &StepCall<'_>,
    check: fn(&O) -> Result<()>,
    op: fn(&dyn RasterSource, &O, &Target, &EngineConfig, &RunOptions, Notify<'_>) -> Result<()>,
) -> Result<TypedStep>
where
    O: DeserializeOwned + Serialize + Send + Sync + 'static,
{
    let s = call.step;
    let t = typed_keys::<O>(call, WRITES)?;
    check(&t.options).map_err(|e| step_error(s, e))?;
    let input = one_input(s)?;
    let target = Target {
        path: output(s)?,
        options: t.format.output_options()?,
        tile: t.run.tile,
    };
    let run = t.run;
    Ok(TypedStep::new(t.options, move |opts, notify| {
        let cfg = engine_config(&run)?;
        let dirs = crate::io::open_raster(&input, &Default::default())?;
        op(dirs.as_ref(), opts, &target, &cfg, &run, notify)
    }))
}

pub(super) fn basins(call: &StepCall<'_>) -> Result<TypedStep> {
    dirs_step(call, unchecked, |dirs, o, t, cfg, _, notify| {
        let labels = ops::basins::write_labels(dirs, o, t, cfg)?;
        if let Some(w) = labels.warning(o) {
            notify(Note::Warning(w.to_string()));
        }
        notify(Note::Wrote(t.path.clone()));
        for f in ops::basins::write_metrics(dirs, o, &labels, cfg)? {
            notify(Note::Wrote(f));
        }
        Ok(())
    })
}

pub(super) fn streams(call: &StepCall<'_>) -> Result<TypedStep> {
    dirs_step(
        call,
        |o: &ops::streams::StreamsOptions| o.rule().map(|_| ()),
        |dirs, o, t, cfg, run, notify| {
            // The format options apply to the stream raster only.
            let mut t = t.clone();
            if o.raster.is_none() {
                t.options = Default::default();
            }
            let net = ops::streams::run(dirs, o, &t, cfg)?;
            for w in &net.warnings {
                notify(Note::Warning(w.clone()));
            }
            for f in &net.files {
                notify(Note::Wrote(f.clone()));
            }
            if !run.quiet {
                notify(Note::Info(format!(
                    "{} links, {} nodes, highest Strahler order {}",
                    net.links, net.nodes, net.max_order
                )));
            }
            Ok(())
        },
    )
}

/// Notes of a step, summaries (`Info`) left out when it is quiet.
pub(super) fn quiet_filter<'a>(quiet: bool, notify: Notify<'a>) -> impl FnMut(Note) + 'a {
    move |n| match n {
        Note::Info(_) if quiet => {}
        n => notify(n),
    }
}

/// `compare`: two inputs (terrain a, terrain b) into the output folder.
pub(super) fn compare(call: &StepCall<'_>) -> Result<TypedStep> {
    let s = call.step;
    let t = typed_keys::<ops::compare::CompareOptions>(call, NEITHER)?;
    t.options.validate().map_err(|e| step_error(s, e))?;
    let [a, b] = match s.inputs.as_slice() {
        [a, b] => [a.clone(), b.clone()],
        v => {
            return Err(step_error(
                s,
                format!(
                    "`compare` takes two inputs, input = [\"a\", \"b\"], not {}",
                    v.len()
                ),
            ))
        }
    };
    let dir = output(s)?;
    let run = t.run;
    Ok(TypedStep::new(t.options, move |opts, notify| {
        let cfg = engine_config(&run)?;
        let mut notify = quiet_filter(run.quiet, notify);
        ops::compare::run_noted(&a, &b, &dir, opts, &cfg, &mut notify).map(|_| ())
    }))
}

/// `hydro-index`: no positional input (the rasters are options: `dem`,
/// `acc`, `dirs`, `streams`, often `"@step"` references) into the output.
pub(super) fn hydro_index(call: &StepCall<'_>) -> Result<TypedStep> {
    let s = call.step;
    if !s.inputs.is_empty() {
        return Err(step_error(
            s,
            "`hydro-index` takes its rasters as options (dem = \"@name\", acc, dirs, streams), not as input",
        ));
    }
    let t = typed_keys::<ops::hydro_index::HydroIndexOptions>(call, WRITES)?;
    if t.options.index.is_empty() {
        return Err(step_error(
            s,
            "`hydro-index` needs index = \"twi\" (or spi, sti, ls, hand, dtw, branch-length)",
        ));
    }
    let path = output(s)?;
    let target = Target {
        path: path.clone(),
        options: t.format.output_options()?,
        tile: t.run.tile,
    };
    let run = t.run;
    Ok(TypedStep::new(t.options, move |opts, notify| {
        ops::hydro_index::run(opts, &target, &engine_config(&run)?)?;
        notify(Note::Wrote(path.clone()));
        Ok(())
    }))
}

/// `tiles`: one input into a web-map pyramid (the step's output: a z/x/y
/// folder, `.mbtiles` or `.pmtiles`).
#[cfg(feature = "archives")]
pub(super) fn tiles(call: &StepCall<'_>) -> Result<TypedStep> {
    let s = call.step;
    let t = typed_keys::<ops::tiles::TilesOptions>(call, FILES)?;
    t.options.pyramid_options().map_err(|e| step_error(s, e))?;
    let input = one_input(s)?;
    let outputs = vec![output(s)?];
    let (run, png) = (t.run, t.input.open_options());
    Ok(TypedStep::new(t.options, move |opts, notify| {
        let src = open_input(&input, &png, notify)?;
        let info = ops::tiles::run(src.as_ref(), &outputs, opts, &engine_config(&run)?)?;
        notify(Note::Message(ops::tiles::summary(&info)));
        for o in &outputs {
            notify(Note::Wrote(o.clone()));
        }
        Ok(())
    }))
}

/// `tiles` in a build without the `archives` feature.
#[cfg(not(feature = "archives"))]
pub(super) fn tiles(call: &StepCall<'_>) -> Result<TypedStep> {
    Err(step_error(
        call.step,
        "`tiles` needs orogen built with the `archives` feature",
    ))
}
