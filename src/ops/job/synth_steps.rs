//! The typed synthesis commands of a job (`synth noise`, `rivers`,
//! `tectonic`, `optimise`, `profile`, `divide-tree`, `from-tree`,
//! `orometric`): no raster input of their own, the output path part of
//! their options.

use super::commands::{
    field_names, one_input, output, step_error, typed_keys_named, typed_keys_with, StepCall,
    TypedStep,
};
use super::steps::{engine_config, quiet_filter, unchecked, FILES, NEITHER, WRITES};
use crate::error::Result;
use crate::exec::EngineConfig;
use crate::ops;
use crate::ops::note::Notify;
use serde::de::DeserializeOwned;
use serde::Serialize;
use std::sync::OnceLock;

/// What a synthesis method runs: options holding their output path.
type SynthOp<O> = fn(&O, &crate::io::OutputOptions, &EngineConfig, Notify<'_>) -> Result<()>;

/// A synthesis method (`synth noise`, `synth rivers`, `synth tectonic`):
/// no input; the output path is part of its options.
fn synth_step<O>(
    call: &StepCall<'_>,
    check: fn(&O) -> Result<()>,
    op: SynthOp<O>,
) -> Result<TypedStep>
where
    O: DeserializeOwned + Serialize + Send + Sync + 'static,
{
    let s = call.step;
    if !s.inputs.is_empty() {
        return Err(step_error(s, format!("`{}` takes no input", s.command)));
    }
    let path = output(s)?;
    let t = typed_keys_with::<O>(
        call,
        WRITES,
        vec![("output", toml::Value::String(path.display().to_string()))],
    )?;
    check(&t.options).map_err(|e| step_error(s, e))?;
    let oo = t.format.output_options()?;
    let run = t.run;
    Ok(TypedStep::new(t.options, move |opts, notify| {
        let cfg = engine_config(&run)?;
        op(opts, &oo, &cfg, &mut quiet_filter(run.quiet, notify))
    }))
}

pub(super) fn synth_noise(call: &StepCall<'_>) -> Result<TypedStep> {
    synth_step(
        call,
        |o: &ops::synth::noise::NoiseOptions| ops::synth::parse_size(&o.size).map(|_| ()),
        ops::synth::noise::run,
    )
}

pub(super) fn synth_rivers(call: &StepCall<'_>) -> Result<TypedStep> {
    synth_step(call, unchecked, ops::synth::rivers::run)
}

pub(super) fn synth_tectonic(call: &StepCall<'_>) -> Result<TypedStep> {
    synth_step(call, unchecked, ops::synth::tectonic::run)
}

fn path_value(p: &std::path::Path) -> toml::Value {
    toml::Value::String(p.display().to_string())
}

/// `synth profile`: one input (a DEM to measure or a profile to edit)
/// into the output profile.
pub(super) fn synth_profile(call: &StepCall<'_>) -> Result<TypedStep> {
    use ops::synth::orometric as oro;
    let s = call.step;
    let set = vec![
        ("input", path_value(&one_input(s)?)),
        ("output", path_value(&output(s)?)),
    ];
    let t = typed_keys_with::<oro::ProfileOptions>(call, FILES, set)?;
    let png = t.png.open_options();
    Ok(TypedStep::new(t.options, move |opts, notify| {
        oro::run_profile(opts, &png, notify)
    }))
}

/// The keys of a synthesis from a divide tree, made once into `keys`: the
/// tree synthesis options (when `tree`), the terrain options (when
/// `terrain`) and `extra`.
fn oro_keys(
    keys: &'static OnceLock<Vec<&'static str>>,
    tree: bool,
    terrain: bool,
    extra: &[&'static str],
) -> &'static [&'static str] {
    use ops::synth::orometric as oro;
    keys.get_or_init(|| {
        let mut v: Vec<&'static str> = extra.to_vec();
        if tree {
            v.extend(field_names::<oro::TreeSynthOptions>());
        }
        if terrain {
            v.extend(field_names::<oro::TerrainSynthOptions>());
        }
        v
    })
}

/// `synth divide-tree`: no input; the tree (.json) into the output.
pub(super) fn synth_divide_tree(call: &StepCall<'_>) -> Result<TypedStep> {
    use ops::synth::orometric as oro;
    let s = call.step;
    if !s.inputs.is_empty() {
        return Err(step_error(
            s,
            "`synth divide-tree` takes no input (its profile is an option: profile = \"@name\")",
        ));
    }
    let set = vec![("output", path_value(&output(s)?))];
    static KEYS: OnceLock<Vec<&str>> = OnceLock::new();
    let keys = oro_keys(&KEYS, true, false, &["output", "geojson"]);
    let t = typed_keys_named::<oro::DivideTreeOptions>(call, NEITHER, set, keys)?;
    Ok(TypedStep::new(t.options, move |opts, notify| {
        oro::run_divide_tree(opts, notify)
    }))
}

/// `synth from-tree`: the tree (.json) as input, the terrain into the
/// output.
pub(super) fn synth_from_tree(call: &StepCall<'_>) -> Result<TypedStep> {
    use ops::synth::orometric as oro;
    let s = call.step;
    let mut set = vec![
        ("tree", path_value(&one_input(s)?)),
        ("output", path_value(&output(s)?)),
    ];
    if let Some(t) = s.args.get("tile") {
        set.push(("tile", t.clone()));
    }
    static KEYS: OnceLock<Vec<&str>> = OnceLock::new();
    let keys = oro_keys(
        &KEYS,
        false,
        true,
        &["tree", "edits", "edited-tree", "output", "tile"],
    );
    let t = typed_keys_named::<oro::FromTreeOptions>(call, WRITES, set, keys)?;
    let oo = t.format.output_options()?;
    let run = t.run;
    Ok(TypedStep::new(t.options, move |opts, notify| {
        let cfg = engine_config(&run)?;
        oro::run_from_tree(opts, &oo, &cfg, &mut quiet_filter(run.quiet, notify))
    }))
}

/// `synth orometric`: no input (its profile is an option); profile ->
/// divide tree -> terrain into the output.
pub(super) fn synth_orometric(call: &StepCall<'_>) -> Result<TypedStep> {
    use ops::synth::orometric as oro;
    let s = call.step;
    if !s.inputs.is_empty() {
        return Err(step_error(
            s,
            "`synth orometric` takes no input (its profile is an option: profile = \"@name\")",
        ));
    }
    let mut set = vec![("output", path_value(&output(s)?))];
    if let Some(t) = s.args.get("tile") {
        set.push(("tile", t.clone()));
    }
    static KEYS: OnceLock<Vec<&str>> = OnceLock::new();
    let keys = oro_keys(&KEYS, true, true, &["tree-out", "output", "tile"]);
    let t = typed_keys_named::<oro::OrometricOptions>(call, WRITES, set, keys)?;
    let oo = t.format.output_options()?;
    let run = t.run;
    Ok(TypedStep::new(t.options, move |opts, notify| {
        let cfg = engine_config(&run)?;
        oro::run_orometric(opts, &oo, &cfg, &mut quiet_filter(run.quiet, notify))
    }))
}

/// `synth optimise`: no positional input (the exemplar and the guide are
/// options: `source`, `guide`, often `"@name"`); into the output.
pub(super) fn synth_optimise(call: &StepCall<'_>) -> Result<TypedStep> {
    let s = call.step;
    if !s.inputs.is_empty() {
        return Err(step_error(
            s,
            "`synth optimise` takes its rasters as options (source = \"@name\", guide), not as input",
        ));
    }
    for key in ["source", "guide"] {
        if !s.args.contains_key(key) {
            return Err(step_error(
                s,
                format!("`synth optimise` needs {key} = \"FILE\" (or \"@name\")"),
            ));
        }
    }
    if s.args.contains_key("falloff") && s.args.get("uniform") == Some(&toml::Value::Boolean(true))
    {
        return Err(step_error(
            s,
            "`synth optimise`: uniform = true and falloff exclude each other",
        ));
    }
    let mut set = vec![("output", path_value(&output(s)?))];
    if let Some(t) = s.args.get("tile") {
        set.push(("tile", t.clone()));
    }
    let t = typed_keys_with::<ops::synth::optimise::OptimiseOptions>(call, WRITES, set)?;
    let oo = t.format.output_options()?;
    let run = t.run;
    Ok(TypedStep::new(t.options, move |opts, notify| {
        let cfg = engine_config(&run)?;
        ops::synth::optimise::run(opts, &oo, &cfg, &mut quiet_filter(run.quiet, notify))
    }))
}
