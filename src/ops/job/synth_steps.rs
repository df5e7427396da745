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

/// The keys of options with flattened parts (whose field names serde does
/// not list): `parts` in order, joined once into `keys`.
fn keys_once(
    keys: &'static OnceLock<Vec<&'static str>>,
    parts: &[&[&'static str]],
) -> &'static [&'static str] {
    keys.get_or_init(|| parts.concat())
}

/// A synthesis method (`synth noise`, `synth rivers`, `synth tectonic`):
/// no input; the output path is part of its options, whose keys are
/// `keys`.
fn synth_step<O>(
    call: &StepCall<'_>,
    keys: &[&'static str],
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
    let t = typed_keys_named::<O>(
        call,
        WRITES,
        vec![("output", toml::Value::String(path.display().to_string()))],
        keys,
    )?;
    check(&t.options).map_err(|e| step_error(s, e))?;
    let oo = t.format.output_options()?;
    let run = t.run;
    Ok(TypedStep::new(t.options, move |opts, notify| {
        let cfg = engine_config(&run)?;
        op(opts, &oo, &cfg, &mut quiet_filter(run.quiet, notify))
    }))
}

/// The keys of [`ops::synth::noise::NoiseOptions`].
fn noise_keys() -> &'static [&'static str] {
    static KEYS: OnceLock<Vec<&str>> = OnceLock::new();
    let noise = field_names::<crate::synth::Noise>();
    keys_once(&KEYS, &[&["size", "cell"], noise, &["output", "tile"]])
}

/// The keys of [`ops::synth::rivers::RiversOptions`].
fn rivers_keys() -> &'static [&'static str] {
    static KEYS: OnceLock<Vec<&str>> = OnceLock::new();
    let own = [
        "size",
        "cell",
        "origin",
        "coast",
        "map-units",
        "land-wavelength",
        "land-threshold",
    ];
    let river = field_names::<crate::synth::rivers::RiverParams>();
    let last = ["network", "preview", "output", "tile"];
    keys_once(&KEYS, &[&own, river, &last])
}

/// The keys of [`ops::synth::tectonic::TectonicOptions`].
fn tectonic_keys() -> &'static [&'static str] {
    static KEYS: OnceLock<Vec<&str>> = OnceLock::new();
    let own = [
        "map",
        "map-units",
        "size",
        "cell",
        "origin",
        "margin",
        "seed",
        "wavelength",
        "octaves",
    ];
    let folds = field_names::<crate::synth::tectonic::TectonicParams>();
    let last = [
        "intermediates",
        "preview",
        "erode-steps",
        "erode-seed",
        "output",
        "tile",
    ];
    keys_once(&KEYS, &[&own, folds, &last])
}

pub(super) fn synth_noise(call: &StepCall<'_>) -> Result<TypedStep> {
    synth_step(
        call,
        noise_keys(),
        |o: &ops::synth::noise::NoiseOptions| ops::synth::parse_size(&o.size).map(|_| ()),
        ops::synth::noise::run,
    )
}

pub(super) fn synth_rivers(call: &StepCall<'_>) -> Result<TypedStep> {
    synth_step(call, rivers_keys(), unchecked, ops::synth::rivers::run)
}

pub(super) fn synth_tectonic(call: &StepCall<'_>) -> Result<TypedStep> {
    synth_step(call, tectonic_keys(), unchecked, ops::synth::tectonic::run)
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
    let png = t.input.open_options();
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
    let none: &'static [&'static str] = &[];
    let part = |on: bool, names: &'static [&'static str]| if on { names } else { none };
    keys_once(
        keys,
        &[
            extra,
            part(tree, field_names::<oro::TreeSynthOptions>()),
            part(terrain, field_names::<oro::TerrainSynthOptions>()),
        ],
    )
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

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeSet;

    /// The keys options serialize to (every field but the skipped ones).
    fn serialized_keys<O: Serialize + Default>() -> BTreeSet<String> {
        match serde_json::to_value(O::default()).unwrap() {
            serde_json::Value::Object(m) => m.keys().cloned().collect(),
            other => panic!("not a table: {other}"),
        }
    }

    fn listed(keys: &[&str]) -> BTreeSet<String> {
        let set: BTreeSet<String> = keys.iter().map(|k| k.to_string()).collect();
        assert_eq!(set.len(), keys.len(), "a key listed twice: {keys:?}");
        set
    }

    #[test]
    fn synthesis_key_lists_are_the_options_fields() {
        use ops::synth::{noise::NoiseOptions, rivers::RiversOptions, tectonic::TectonicOptions};
        assert_eq!(listed(noise_keys()), serialized_keys::<NoiseOptions>());
        assert_eq!(listed(rivers_keys()), serialized_keys::<RiversOptions>());
        assert_eq!(
            listed(tectonic_keys()),
            serialized_keys::<TectonicOptions>()
        );
        assert!(noise_keys().contains(&"ridge-offset"));
        assert!(rivers_keys().contains(&"channel-slope") && !rivers_keys().contains(&"mask"));
        assert!(tectonic_keys().contains(&"noise-share") && !tectonic_keys().contains(&"fbm"));
    }

    #[test]
    fn flat_keys_fill_both_parts_and_unknown_keys_are_refused() {
        use ops::synth::noise::NoiseOptions;
        let o: NoiseOptions =
            toml::from_str("size = \"64x32\"\noctaves = 3\ngain = 1\nkind = \"ridged\"").unwrap();
        assert_eq!(o.size, "64x32");
        assert_eq!(o.noise.octaves, 3);
        assert_eq!(o.noise.gain, 1.0);
        assert_eq!(o.noise.kind, crate::synth::NoiseKind::Ridged);
        assert_eq!(o.noise.seed, 42);
        assert_eq!(o.cell, 30.0);
        let e = toml::from_str::<NoiseOptions>("octavs = 3").unwrap_err();
        assert!(e.to_string().contains("octavs"), "{e}");
        let t: ops::synth::tectonic::TectonicOptions =
            toml::from_str("t1 = 0.5\noctaves = 4\nerode-steps = 2").unwrap();
        assert_eq!((t.folds.t1, t.octaves, t.erode_steps), (0.5, 4, 2));
        assert_eq!(t.folds.sea_depth, 60.0);
        assert!(toml::from_str::<ops::synth::tectonic::TectonicOptions>("sea-depth = 1").is_err());
    }
}
