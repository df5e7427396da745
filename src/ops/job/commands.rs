//! The commands a job may run ([`COMMANDS`]: every `orogen` command but
//! `run` and `help`, a group's methods as `"synth noise"`), and the
//! turning of a step's `args` table into the operation's options: the command's `ops::<cmd>::<Cmd>Options` (serde, unknown keys
//! refused), the run settings ([`RunOptions`]: memory, threads, tile,
//! quiet, engine), the output format ([`FormatOptions`]) and the input
//! reading options ([`InputOptions`]: band, PNG scaling), each key checked with one message naming the
//! key, what the command accepts and the nearest accepted name.

use super::plan::Planned;
use super::{steps, synth_steps};
use crate::error::{Error, Result};
use crate::ops::note::Notify;
use crate::ops::parse::{FormatOptions, InputOptions, RunOptions};
use serde::de::DeserializeOwned;
use std::collections::BTreeMap;

/// One command a job may name.
#[derive(Clone, Copy)]
pub struct Command {
    /// The command as a step names it (`"fill"`, `"synth noise"`).
    pub name: &'static str,
    /// Builds a step's typed options and its run from the step's keys.
    pub build: fn(&StepCall<'_>) -> Result<TypedStep>,
    /// Takes the run settings (`memory`, `threads`, `tile`, `quiet`,
    /// `engine`), as its CLI command does: the job's settings are passed to
    /// it and its keys accepted.
    pub settings: bool,
}

const fn typed(name: &'static str, build: fn(&StepCall<'_>) -> Result<TypedStep>) -> Command {
    Command {
        name,
        build,
        settings: true,
    }
}

/// A command without run settings (its CLI command has none).
const fn unset(name: &'static str, build: fn(&StepCall<'_>) -> Result<TypedStep>) -> Command {
    Command {
        name,
        build,
        settings: false,
    }
}

/// Every command a job may run, in the CLI's order.
pub const COMMANDS: &[Command] = &[
    typed("info", steps::info),
    typed("ingest", steps::ingest),
    typed("export", steps::export),
    typed("slope", steps::slope),
    typed("aspect", steps::aspect),
    typed("hillshade", steps::hillshade),
    typed("metric", steps::metric),
    typed("peaks", steps::peaks),
    typed("orostats", steps::orostats),
    unset("classify train", steps::classify_train),
    unset("classify predict", steps::classify_predict),
    unset("classify evaluate", steps::classify_evaluate),
    typed("ridges", steps::ridges),
    typed("fill-nodata", steps::fill_nodata),
    typed("fill", steps::fill),
    typed("flow", steps::flow),
    typed("breach", steps::breach),
    typed("fill-epsilon", steps::fill_epsilon),
    typed("watersheds", steps::watersheds),
    typed("accumulate", steps::accumulate),
    typed("basins", steps::basins),
    typed("streams", steps::streams),
    typed("hydro-index", steps::hydro_index),
    typed("render", steps::render),
    typed("tiles", steps::tiles),
    unset("view", steps::view),
    typed("viewshed", steps::viewshed),
    typed("erode", steps::erode),
    typed("synth noise", synth_steps::synth_noise),
    typed("synth optimise", synth_steps::synth_optimise),
    typed("synth rivers", synth_steps::synth_rivers),
    typed("synth tectonic", synth_steps::synth_tectonic),
    unset("synth profile", synth_steps::synth_profile),
    unset("synth divide-tree", synth_steps::synth_divide_tree),
    typed("synth from-tree", synth_steps::synth_from_tree),
    typed("synth orometric", synth_steps::synth_orometric),
    typed("compare", steps::compare),
    typed("demo", steps::demo),
];

/// The registry entry of `name` (words separated by one space).
pub fn command(name: &str) -> Option<&'static Command> {
    COMMANDS.iter().find(|c| c.name == name)
}

/// A step as its command's builder sees it.
pub struct StepCall<'a> {
    /// The planned step (inputs, output, resolved `args` with `_` keys).
    pub step: &'a Planned,
    /// `--quiet` for every step (the job's `quiet`).
    pub quiet: bool,
    /// Told of the step's progress (its engine settings' observer).
    pub observer: Option<crate::exec::Observer>,
}

/// A step turned into its operation's typed options, ready to run.
pub struct TypedStep {
    /// The operation's options as TOML (what `orogen run --dry-run` shows).
    pub options: String,
    run: Box<dyn Fn(Notify<'_>) -> Result<()> + Send + Sync>,
}

impl TypedStep {
    /// A step showing `options` and running `run` with them.
    pub fn new<O: serde::Serialize + Send + Sync + 'static>(
        options: O,
        run: impl Fn(&O, Notify<'_>) -> Result<()> + Send + Sync + 'static,
    ) -> Self {
        TypedStep {
            options: toml::to_string(&options).unwrap_or_default(),
            run: Box::new(move |notify| run(&options, notify)),
        }
    }

    /// Run the operation.
    pub fn run(&self, notify: Notify<'_>) -> Result<()> {
        (self.run)(notify)
    }
}

/// The typed step of `s` (a step of a registered command: the planner
/// checked its name).
pub fn typed_step(s: &Planned, quiet: bool) -> Result<TypedStep> {
    match command(&s.command) {
        Some(c) => (c.build)(&StepCall {
            step: s,
            quiet,
            observer: None,
        }),
        None => Err(step_error(s, format!("unknown command `{}`", s.command))),
    }
}

/// True unless `command` is registered without run settings.
pub fn takes_settings(command: &str) -> bool {
    self::command(command).is_none_or(|c| c.settings)
}

/// True if `name` is a command of the registry or a group of them.
pub fn has(name: &str) -> bool {
    COMMANDS
        .iter()
        .any(|c| c.name == name || c.name.split(' ').next() == Some(name))
}

/// The names of every command of the registry.
pub fn names() -> Vec<String> {
    COMMANDS.iter().map(|c| c.name.to_string()).collect()
}

/// The methods of the command group `command` (`synth` -> `noise`, ...);
/// empty for a command that is no group.
pub fn methods(command: &str) -> Vec<String> {
    let prefix = format!("{command} ");
    COMMANDS
        .iter()
        .filter_map(|c| c.name.strip_prefix(&prefix))
        .map(str::to_string)
        .collect()
}

/// The names of a serde struct's fields (a derived `Deserialize` hands
/// them to `deserialize_struct`; this deserializer keeps them and stops).
pub fn field_names<T: DeserializeOwned>() -> &'static [&'static str] {
    struct Capture(&'static [&'static str]);
    impl<'de> serde::Deserializer<'de> for &mut Capture {
        type Error = serde::de::value::Error;
        fn deserialize_any<V: serde::de::Visitor<'de>>(
            self,
            _v: V,
        ) -> std::result::Result<V::Value, Self::Error> {
            Err(serde::de::Error::custom("not a struct"))
        }
        fn deserialize_struct<V: serde::de::Visitor<'de>>(
            self,
            _name: &'static str,
            fields: &'static [&'static str],
            _v: V,
        ) -> std::result::Result<V::Value, Self::Error> {
            self.0 = fields;
            Err(serde::de::Error::custom("fields captured"))
        }
        serde::forward_to_deserialize_any! {
            bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string
            bytes byte_buf option unit unit_struct newtype_struct seq tuple
            tuple_struct map enum identifier ignored_any
        }
    }
    let mut c = Capture(&[]);
    let _ = T::deserialize(&mut c);
    c.0
}

/// Edit distance of two keys (Levenshtein), for "did you mean".
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut prev = row[0];
        row[0] = i + 1;
        for (j, &cb) in b.iter().enumerate() {
            let cur = row[j + 1];
            row[j + 1] = (prev + usize::from(ca != cb)).min(row[j] + 1).min(cur + 1);
            prev = cur;
        }
    }
    row[b.len()]
}

/// The accepted key nearest to `key`, if near enough to be a typo.
pub fn nearest<'a>(key: &str, accepted: &[&'a str]) -> Option<&'a str> {
    accepted
        .iter()
        .map(|a| (edit_distance(key, a), *a))
        .filter(|(d, a)| *d <= (a.len() / 3).max(2))
        .min_by_key(|(d, _)| *d)
        .map(|(_, a)| a)
}

/// A step's error: names the step.
pub fn step_error(s: &Planned, msg: impl std::fmt::Display) -> Error {
    Error::invalid(format!("step {:?}: {msg}", s.name))
}

/// Which groups of shared keys a command takes besides its own options.
#[derive(Clone, Copy)]
pub struct Takes {
    /// The output format keys (it writes rasters).
    pub format: bool,
    /// The input reading keys (`band`, `png_scale`, `png_offset`: it reads a raster input).
    pub input: bool,
}

/// A step's keys, typed: the command's options `O`, the run settings, the
/// output format and the input reading options.
pub struct Typed<O> {
    pub options: O,
    pub run: RunOptions,
    pub format: FormatOptions,
    pub input: InputOptions,
}

/// Deserialize `table` into `T`; on error, find the key whose value is
/// refused and name it with what was expected.
fn from_table<T: DeserializeOwned>(s: &Planned, table: &toml::Table) -> Result<T> {
    match T::deserialize(toml::Value::Table(table.clone())) {
        Ok(v) => Ok(v),
        Err(whole) => {
            for (k, v) in table {
                let mut one = toml::Table::new();
                one.insert(k.clone(), v.clone());
                if let Err(e) = T::deserialize(toml::Value::Table(one)) {
                    // The first line: toml adds "in `key`" on the next.
                    let msg = e.to_string();
                    let msg = msg.lines().next().unwrap_or("");
                    return Err(step_error(
                        s,
                        format!("`{}` option {k} = {v}: {msg}", s.command),
                    ));
                }
            }
            Err(step_error(
                s,
                format!("`{}`: {}", s.command, whole.to_string().trim_end()),
            ))
        }
    }
}

/// Split the step's keys over the command's options `O` and the shared
/// groups, refusing an unknown key (listing the accepted ones and the
/// nearest) and a value of the wrong kind (naming the key).
pub fn typed_keys<O: DeserializeOwned>(call: &StepCall<'_>, takes: Takes) -> Result<Typed<O>> {
    typed_keys_with(call, takes, vec![])
}

/// [`typed_keys`], with `set` fields of `O` given by the job rather than by
/// the step's keys (an operation whose options hold its output path: a
/// step's `args` may not set those).
pub fn typed_keys_with<O: DeserializeOwned>(
    call: &StepCall<'_>,
    takes: Takes,
    set: Vec<(&'static str, toml::Value)>,
) -> Result<Typed<O>> {
    typed_keys_named(call, takes, set, field_names::<O>())
}

/// [`typed_keys_with`] for options whose keys are `all_own` (a struct with
/// flattened parts, whose field names serde does not list).
pub fn typed_keys_named<O: DeserializeOwned>(
    call: &StepCall<'_>,
    takes: Takes,
    set: Vec<(&'static str, toml::Value)>,
    all_own: &[&'static str],
) -> Result<Typed<O>> {
    let s = call.step;
    let own_vec: Vec<&'static str> = all_own
        .iter()
        .copied()
        .filter(|f| !set.iter().any(|(k, _)| k == f))
        .collect();
    let own = own_vec.as_slice();
    let run_keys = if takes_settings(&s.command) {
        field_names::<RunOptions>()
    } else {
        &[]
    };
    let format_keys = if takes.format {
        field_names::<FormatOptions>()
    } else {
        &[]
    };
    let input_keys = if takes.input {
        field_names::<InputOptions>()
    } else {
        &[]
    };
    let mut tables: [toml::Table; 4] = Default::default();
    for (k, v) in &s.args {
        // Keys are in `_` form; a struct may name its fields in kebab case.
        let found = [own, run_keys, format_keys, input_keys]
            .iter()
            .enumerate()
            .find_map(|(g, keys)| {
                keys.iter()
                    .find(|f| f.replace('-', "_") == *k)
                    .map(|f| (g, *f))
            });
        match found {
            Some((g, field)) => {
                tables[g].insert(field.to_string(), v.clone());
            }
            None => {
                let accepted: Vec<String> = [own, format_keys, input_keys, run_keys]
                    .concat()
                    .iter()
                    .map(|f| f.replace('-', "_"))
                    .collect();
                let accepted: Vec<&str> = accepted.iter().map(String::as_str).collect();
                let hint = nearest(k, &accepted)
                    .map(|n| format!(" (did you mean {n}?)"))
                    .unwrap_or_default();
                return Err(step_error(
                    s,
                    format!(
                        "`{}` has no option --{}{hint}; it accepts: {}",
                        s.command,
                        k.replace('_', "-"),
                        accepted.join(", ")
                    ),
                ));
            }
        }
    }
    let [mut o, r, f, p] = tables;
    for (k, v) in set {
        o.insert(k.to_string(), v);
    }
    let mut run: RunOptions = from_table(s, &r)?;
    run.quiet |= call.quiet;
    run.observer = call.observer.clone();
    crate::ops::parse::bytes(&run.memory).map_err(|e| step_error(s, e))?;
    let format: FormatOptions = from_table(s, &f)?;
    format.output_options().map_err(|e| step_error(s, e))?;
    Ok(Typed {
        options: from_table(s, &o)?,
        run,
        format,
        input: from_table(s, &p)?,
    })
}

/// The step's one input, refused (naming the step) when it has none or
/// several.
pub fn one_input(s: &Planned) -> Result<std::path::PathBuf> {
    match s.inputs.as_slice() {
        [p] => Ok(p.clone()),
        [] => Err(step_error(
            s,
            format!(
                "`{}` needs an input: input = \"NAME\" (an input or an earlier step)",
                s.command
            ),
        )),
        _ => Err(step_error(
            s,
            format!("`{}` takes one input, not {}", s.command, s.inputs.len()),
        )),
    }
}

/// The step's output, refused (naming the step) when it has none.
pub fn output(s: &Planned) -> Result<std::path::PathBuf> {
    s.output.clone().ok_or_else(|| {
        step_error(
            s,
            format!("`{}` needs an output: output = \"FILE\"", s.command),
        )
    })
}

/// Join arrays of strings with commas (the list form of a comma-separated
/// option such as `metric`).
pub fn join_lists(
    args: &BTreeMap<String, toml::Value>,
    key: &str,
) -> BTreeMap<String, toml::Value> {
    let mut a = args.clone();
    if let Some(toml::Value::Array(items)) = a.get(key) {
        let parts: Vec<String> = items
            .iter()
            .map(|v| match v {
                toml::Value::String(t) => t.clone(),
                other => other.to_string(),
            })
            .collect();
        a.insert(key.to_string(), toml::Value::String(parts.join(",")));
    }
    a
}
