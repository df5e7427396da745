//! The job file: schema (`JobFile`, `StepSpec`), checks against the
//! commands a job may run (`super::COMMANDS`), dependency order, command lines,
//! fingerprints and the resume state (see `ops::job` for the format).

use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Largest job file (and job state file) read, in bytes.
pub const MAX_JOB_BYTES: u64 = 16 << 20;

/// A job file as written.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JobFile {
    /// Memory budget for every step, e.g. "512MiB".
    pub memory: Option<String>,
    /// Worker threads (0 = all cores).
    pub threads: Option<usize>,
    /// Work-tile size passed to every step that takes `--tile`.
    pub tile: Option<usize>,
    /// Engine passed to every step that takes `--engine`: "local" or "mpi"
    /// (`mpirun -n 4 orogen run job.toml`).
    pub engine: Option<String>,
    /// Folder for outputs, relative to the job file (default: the job file's folder).
    pub output_dir: Option<PathBuf>,
    /// JSON-lines log of step events, relative to `output_dir`.
    pub log: Option<PathBuf>,
    /// Write `report.html` into `output_dir` (default true).
    pub report: Option<bool>,
    /// Named input files, relative to the job file.
    #[serde(default)]
    pub inputs: BTreeMap<String, PathBuf>,
    /// The steps, in any order consistent with their dependencies.
    #[serde(default, rename = "step")]
    pub steps: Vec<StepSpec>,
}

/// One `[[step]]` as written.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StepSpec {
    /// Name other steps use to refer to this step's output.
    pub name: String,
    /// The orogen command (`fill`, `slope`, `metric`, …); a command of a
    /// group with its method after a space (`synth noise`).
    pub run: String,
    /// Positional input(s): names of inputs or earlier steps.
    #[serde(default)]
    pub input: OneOrMany,
    /// Output path (file or folder), relative to `output_dir`.
    pub output: Option<PathBuf>,
    /// The command's options (long names without `--`).
    #[serde(default)]
    pub args: BTreeMap<String, toml::Value>,
}

/// A name or a list of names.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(untagged)]
pub enum OneOrMany {
    #[default]
    None,
    One(String),
    Many(Vec<String>),
}

impl OneOrMany {
    fn names(&self) -> Vec<String> {
        match self {
            OneOrMany::None => vec![],
            OneOrMany::One(s) => vec![s.clone()],
            OneOrMany::Many(v) => v.clone(),
        }
    }
}

/// A checked step, ready to run.
#[derive(Debug, Clone, PartialEq)]
pub struct Planned {
    pub name: String,
    pub command: String,
    /// Command line after the program name: command, inputs, `-o`, options.
    pub argv: Vec<String>,
    pub inputs: Vec<PathBuf>,
    pub output: Option<PathBuf>,
    /// The step's `args` with keys in `_` form, `"@name"` values replaced
    /// by the paths they name, and the job's `memory`, `threads`, `tile`
    /// and `engine` where the step does not set them: what a typed command
    /// builds its options from (see `commands`).
    pub args: BTreeMap<String, toml::Value>,
    /// Indices (into [`Job::steps`]) of the steps this one needs.
    pub deps: Vec<usize>,
}

/// A checked job: steps in run order.
#[derive(Debug, Clone)]
pub struct Job {
    pub path: PathBuf,
    pub output_dir: PathBuf,
    pub log: Option<PathBuf>,
    pub report: bool,
    pub steps: Vec<Planned>,
}

fn bad(path: &Path, msg: impl Into<String>) -> Error {
    Error::invalid(format!("{}: {}", path.display(), msg.into()))
}

/// Parse and check the job file at `path` against the commands of the registry
/// ([`super::COMMANDS`]).
/// `memory`/`threads` override the file's values. Every mistake (unknown
/// key, unknown command or option, missing input, duplicate name, cycle)
/// is one error naming the step.
pub fn load(path: &Path, memory: Option<&str>, threads: Option<usize>) -> Result<Job> {
    let len = std::fs::metadata(path)
        .map_err(|e| Error::io(path, e))?
        .len();
    if len > MAX_JOB_BYTES {
        return Err(Error::too_large(
            path,
            format!(
                "a job file of {len} bytes (the limit is {} MiB); a job lists steps, not data",
                MAX_JOB_BYTES >> 20
            ),
        ));
    }
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let file: JobFile = toml::from_str(&text).map_err(|e| bad(path, e.to_string().trim_end()))?;
    plan(path, file, memory, threads)
}

/// Check a parsed job file (see [`load`]).
pub fn plan(
    path: &Path,
    file: JobFile,
    memory: Option<&str>,
    threads: Option<usize>,
) -> Result<Job> {
    let base = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."))
        .to_path_buf();
    let output_dir = match &file.output_dir {
        Some(d) if d != Path::new(".") => base.join(d),
        _ => base.clone(),
    };
    if file.steps.is_empty() {
        return Err(bad(path, "the job has no [[step]]; add at least one"));
    }
    // Names: inputs and steps share one namespace. Ordered maps, not hash
    // maps: a hash map's per-process random seed made the fuzzer's coverage
    // of this parser differ from run to run (docs/RELIABILITY.md).
    let mut paths: BTreeMap<String, PathBuf> = BTreeMap::new();
    for (k, v) in &file.inputs {
        check_name(path, k)?;
        paths.insert(k.clone(), base.join(v));
    }
    let mut step_of: BTreeMap<String, usize> = BTreeMap::new();
    for (i, s) in file.steps.iter().enumerate() {
        check_name(path, &s.name)?;
        if paths.contains_key(&s.name) || step_of.contains_key(&s.name) {
            return Err(bad(
                path,
                format!(
                    "step name {:?} is used twice (inputs and steps share names)",
                    s.name
                ),
            ));
        }
        step_of.insert(s.name.clone(), i);
        if let Some(o) = &s.output {
            paths.insert(s.name.clone(), output_dir.join(o));
        }
    }
    let known = |k: &str| -> String {
        let mut v: Vec<&String> = paths.keys().collect();
        v.sort();
        format!(
            "{k:?} is neither an input nor a step with an output (known: {})",
            v.iter().map(|s| s.as_str()).collect::<Vec<_>>().join(", ")
        )
    };
    let memory = memory.map(str::to_string).or(file.memory.clone());
    let threads = threads.or(file.threads);
    let mut planned = Vec::with_capacity(file.steps.len());
    for s in &file.steps {
        let at = |m: String| bad(path, format!("step {:?}: {m}", s.name));
        let words: Vec<&str> = s.run.split_whitespace().collect();
        let command = words.join(" ");
        let top = words.first().copied().unwrap_or("");
        if top == "run" || !super::commands::has(top) {
            return Err(at(format!(
                "unknown command {:?}; a step may run: {}",
                s.run,
                super::commands::names().join(", ")
            )));
        }
        // Walk down a command group: every word but the last must be a group
        // that has the next word as a method, and the last must not be a group.
        for k in 1..=words.len() {
            let path = words[..k].join(" ");
            let methods = super::commands::methods(&path);
            match (words.get(k), methods.is_empty()) {
                (None, true) => {}
                (None, false) => {
                    return Err(at(format!(
                        "`{path}` is a group of commands: name the method, e.g. run = \"{path} {}\" (methods: {})",
                        methods[0],
                        methods.join(", ")
                    )))
                }
                (Some(w), _) if methods.iter().any(|m| m == w) => {}
                (Some(w), true) => {
                    return Err(at(format!(
                        "`{path}` takes no method, but the step names {w:?} after it; write run = \"{path}\""
                    )))
                }
                (Some(w), false) => {
                    return Err(at(format!(
                        "unknown method {w:?} of `{path}`; methods: {}",
                        methods.join(", ")
                    )))
                }
            }
        }
        let mut deps = vec![];
        let mut inputs = vec![];
        for n in s.input.names() {
            let p = paths.get(&n).ok_or_else(|| at(known(&n)))?;
            if let Some(&d) = step_of.get(&n) {
                deps.push(d);
            }
            inputs.push(p.clone());
        }
        let mut argv: Vec<String> = words.iter().map(|w| w.to_string()).collect();
        argv.extend(inputs.iter().map(|p| p.display().to_string()));
        let output = s.output.as_ref().map(|o| output_dir.join(o));
        if let Some(o) = &output {
            argv.push("-o".into());
            argv.push(o.display().to_string());
        }
        let mut args = BTreeMap::new();
        for (k, v) in &s.args {
            let key = k.replace('_', "-");
            let v = &rebased(&words.join(" "), k, v, &base, &output_dir);
            let mut value = |v: &toml::Value| -> Result<Option<String>> {
                Ok(match v {
                    toml::Value::String(t) => match t.strip_prefix('@') {
                        Some(n) => {
                            let p = paths.get(n).ok_or_else(|| at(known(n)))?;
                            if let Some(&d) = step_of.get(n) {
                                deps.push(d);
                            }
                            Some(p.display().to_string())
                        }
                        None => Some(t.clone()),
                    },
                    toml::Value::Integer(i) => Some(i.to_string()),
                    toml::Value::Float(f) => Some(f.to_string()),
                    toml::Value::Boolean(_) => None,
                    other => {
                        return Err(at(format!(
                            "option {k}: a {} is not a valid value (use a string, number, boolean or array of them)",
                            other.type_str()
                        )))
                    }
                })
            };
            // The typed value: `@name` strings become the paths they name.
            let resolved = |v: &toml::Value, p: Option<String>| match v {
                toml::Value::String(t) if t.starts_with('@') => {
                    toml::Value::String(p.unwrap_or_default())
                }
                v => v.clone(),
            };
            let typed = match v {
                toml::Value::Boolean(true) => {
                    argv.push(format!("--{key}"));
                    v.clone()
                }
                toml::Value::Boolean(false) => v.clone(),
                toml::Value::Array(items) => {
                    let mut parts = vec![];
                    let mut list = vec![];
                    for it in items {
                        match value(it)? {
                            Some(p) => {
                                list.push(resolved(it, Some(p.clone())));
                                parts.push(p);
                            }
                            None => {
                                return Err(at(format!("option {k}: booleans cannot be listed")))
                            }
                        }
                    }
                    argv.push(format!("--{key}"));
                    argv.push(parts.join(","));
                    toml::Value::Array(list)
                }
                v => {
                    let p = value(v)?.unwrap_or_default();
                    argv.push(format!("--{key}"));
                    argv.push(p.clone());
                    resolved(v, Some(p))
                }
            };
            args.insert(k.replace('-', "_"), typed);
        }
        for (opt, val) in [
            ("memory", memory.clone().map(toml::Value::String)),
            ("threads", threads.map(|t| toml::Value::Integer(t as i64))),
            ("tile", file.tile.map(|t| toml::Value::Integer(t as i64))),
            ("engine", file.engine.clone().map(toml::Value::String)),
        ] {
            if let Some(v) = val {
                if super::commands::takes_settings(&command) && !s.args.contains_key(opt) {
                    argv.push(format!("--{opt}"));
                    argv.push(match &v {
                        toml::Value::String(t) => t.clone(),
                        v => v.to_string(),
                    });
                    args.insert(opt.to_string(), v);
                }
            }
        }
        deps.sort_unstable();
        deps.dedup();
        planned.push(Planned {
            name: s.name.clone(),
            command,
            argv,
            inputs,
            output,
            args,
            deps,
        });
    }
    let order = topo_order(path, &planned)?;
    // Renumber dependencies for the new order.
    let mut pos = vec![0; planned.len()];
    for (new, &old) in order.iter().enumerate() {
        pos[old] = new;
    }
    let steps = order
        .iter()
        .map(|&i| {
            let mut p = planned[i].clone();
            p.deps = p.deps.iter().map(|&d| pos[d]).collect();
            p
        })
        .collect();
    Ok(Job {
        path: path.to_path_buf(),
        log: file.log.map(|l| output_dir.join(l)),
        output_dir,
        report: file.report.unwrap_or(true),
        steps,
    })
}

fn check_name(path: &Path, n: &str) -> Result<()> {
    if n.is_empty()
        || !n
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
    {
        return Err(bad(
            path,
            format!("name {n:?} must be letters, digits, '_' or '-'"),
        ));
    }
    Ok(())
}

/// Steps in file order as far as dependencies allow (Kahn's algorithm,
/// always taking the first ready step); a cycle is an error naming it.
fn topo_order(path: &Path, steps: &[Planned]) -> Result<Vec<usize>> {
    let n = steps.len();
    let mut done = vec![false; n];
    let mut order = Vec::with_capacity(n);
    while order.len() < n {
        let next = (0..n).find(|&i| !done[i] && steps[i].deps.iter().all(|&d| done[d]));
        match next {
            Some(i) => {
                done[i] = true;
                order.push(i);
            }
            None => {
                // Walk dependencies from a blocked step until one repeats.
                let mut seen = vec![usize::MAX; n];
                let mut at = (0..n).find(|&i| !done[i]).unwrap_or(0);
                let mut chain = vec![];
                while seen[at] == usize::MAX {
                    seen[at] = chain.len();
                    chain.push(at);
                    at = steps[at]
                        .deps
                        .iter()
                        .copied()
                        .find(|&d| !done[d])
                        .unwrap_or(at);
                }
                let cycle: Vec<&str> = chain[seen[at]..]
                    .iter()
                    .chain(std::iter::once(&at))
                    .map(|&i| steps[i].name.as_str())
                    .collect();
                return Err(bad(
                    path,
                    format!(
                        "the steps depend on each other in a cycle: {}",
                        cycle.join(" -> ")
                    ),
                ));
            }
        }
    }
    Ok(order)
}

/// Step options that name files a step writes beside its output, per
/// command: a relative path goes under the job's `output_dir`, like the
/// step's `output`.
const SIDE_OUTPUTS: &[(&str, &[&str])] = &[
    ("basins", &["metrics"]),
    ("streams", &["raster", "stats", "csv", "nodes"]),
    ("orostats", &["profile"]),
    ("erode", &["water", "sediment", "preview", "scratch"]),
    ("synth tectonic", &["intermediates", "preview"]),
    ("synth rivers", &["network", "preview"]),
    ("synth optimise", &["previews"]),
    ("synth divide-tree", &["geojson"]),
    ("synth from-tree", &["edited_tree", "preview"]),
    ("synth orometric", &["tree_out", "preview"]),
];

/// Step options that name files a step reads, per command (`mask`: every
/// command): a relative path is taken from the job file's folder, like the
/// job's `[inputs]`.
const INPUT_PATHS: &[(&str, &[&str])] = &[
    ("fill", &["sinks"]),
    ("flow", &["sinks"]),
    ("accumulate", &["weights"]),
    ("basins", &["points", "acc", "dem"]),
    ("viewshed", &["points"]),
    ("hydro-index", &["dem", "acc", "dirs", "streams"]),
    ("streams", &["dem"]),
    ("erode", &["params", "uplift_map", "fixed_points"]),
    ("synth tectonic", &["map"]),
    ("synth rivers", &["coast"]),
    ("synth optimise", &["source", "guide", "sinks"]),
    (
        "synth divide-tree",
        &[
            "profile",
            "density_map",
            "elevation_map",
            "fixed_peaks",
            "type_map",
            "paste",
        ],
    ),
    ("synth from-tree", &["edits"]),
    (
        "synth orometric",
        &[
            "density_map",
            "elevation_map",
            "fixed_peaks",
            "type_map",
            "paste",
        ],
    ),
];

/// True if `table` lists option `key` (`_` or `-` form) of `command`.
fn listed(table: &[(&str, &[&str])], command: &str, key: &str) -> bool {
    let key = key.replace('-', "_");
    table
        .iter()
        .any(|(c, keys)| *c == command && keys.contains(&key.as_str()))
}

/// True if option `key` of `command` names a file the step reads.
pub(super) fn is_input_path(command: &str, key: &str) -> bool {
    key == "mask" || listed(INPUT_PATHS, command, key)
}

/// `v`, the value of option `key` of a step running `command`, with a
/// relative path rebased: a side output under `output_dir`, an input path
/// under the job file's folder `base` (see [`SIDE_OUTPUTS`],
/// [`INPUT_PATHS`]). `@name` references and absolute paths are kept.
fn rebased(
    command: &str,
    key: &str,
    v: &toml::Value,
    base: &Path,
    output_dir: &Path,
) -> toml::Value {
    let root = if listed(SIDE_OUTPUTS, command, key) {
        output_dir
    } else if is_input_path(command, key) {
        base
    } else {
        return v.clone();
    };
    match v {
        toml::Value::String(t) if !t.starts_with('@') && Path::new(t).is_relative() => {
            toml::Value::String(root.join(t).display().to_string())
        }
        v => v.clone(),
    }
}

/// What the job remembers between runs (`output_dir/.orogen-job.json`).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct State {
    /// Finished steps: name → record.
    pub done: BTreeMap<String, StepRecord>,
}

/// A finished step.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct StepRecord {
    pub fingerprint: String,
    pub seconds: f64,
    pub peak_rss_bytes: u64,
}

impl Job {
    /// Path of the resume state file.
    pub fn state_path(&self) -> PathBuf {
        self.output_dir.join(".orogen-job.json")
    }

    /// The saved state (empty when missing, unreadable or larger than any
    /// state this runner writes: everything reruns).
    pub fn load_state(&self) -> State {
        let p = self.state_path();
        if std::fs::metadata(&p).map_or(true, |m| m.len() > MAX_JOB_BYTES) {
            return State::default();
        }
        std::fs::read_to_string(p)
            .ok()
            .and_then(|t| serde_json::from_str(&t).ok())
            .unwrap_or_default()
    }

    /// Save the state atomically (temporary file + rename).
    pub fn save_state(&self, st: &State) -> Result<()> {
        let p = self.state_path();
        let tmp = p.with_extension("json.tmp");
        let text = serde_json::to_string_pretty(st)
            .map_err(|e| Error::invalid(format!("job state: {e}")))?;
        std::fs::write(&tmp, text).map_err(|e| Error::io(&tmp, e))?;
        crate::store::crash::point("job.state", "tmp");
        std::fs::rename(&tmp, &p).map_err(|e| Error::io(&p, e))
    }

    /// Fingerprint of step `i`: its command line and the size and
    /// modification time of every input (files, or the manifest of a tile
    /// store / the entries of a folder).
    pub fn fingerprint(&self, i: usize) -> String {
        let s = &self.steps[i];
        let mut h = crc32fast::Hasher::new();
        for a in &s.argv {
            h.update(a.as_bytes());
            h.update(&[0]);
        }
        let mut stamp = |p: &Path| {
            if let Ok(m) = std::fs::metadata(p) {
                h.update(&m.len().to_le_bytes());
                if let Ok(t) = m.modified() {
                    if let Ok(d) = t.duration_since(std::time::UNIX_EPOCH) {
                        h.update(&d.as_nanos().to_le_bytes());
                    }
                }
            }
        };
        // Inputs, plus option values naming existing files (`@name` refs).
        let mut roots: Vec<PathBuf> = s.inputs.clone();
        roots.extend(
            s.argv[1..]
                .iter()
                .map(PathBuf::from)
                .filter(|p| p.exists() && !s.inputs.contains(p) && Some(p) != s.output.as_ref()),
        );
        let mut files = vec![];
        for p in roots {
            match std::fs::read_dir(&p) {
                Ok(rd) => {
                    let mut v: Vec<PathBuf> = rd.flatten().map(|e| e.path()).collect();
                    v.sort();
                    files.extend(v);
                }
                Err(_) => files.push(p),
            }
        }
        for f in &files {
            stamp(f);
        }
        format!("{:08x}-{}", h.finalize(), s.argv.len())
    }

    /// True if step `i` finished in an earlier run with the same fingerprint
    /// and its output still exists and is intact: a tile-store output must
    /// open as finished and every tile must match its checksum (a tile torn
    /// by a crash or damaged on disk since makes the step run again, and the
    /// store's writer then recomputes just that tile).
    pub fn is_done(&self, st: &State, i: usize) -> bool {
        let s = &self.steps[i];
        st.done
            .get(&s.name)
            .is_some_and(|r| r.fingerprint == self.fingerprint(i))
            && s.output.as_ref().is_none_or(|o| output_intact(o))
    }
}

/// A step's output is there and, if it is a tile store (or a folder of
/// them, as `metric --format tiles` writes), finished with every tile
/// matching its checksum.
fn output_intact(o: &Path) -> bool {
    let store_ok =
        |p: &Path| crate::store::TileStore::open(p).is_ok_and(|s| s.verify_all().is_ok());
    if o.join(crate::store::MANIFEST).is_file() {
        return store_ok(o);
    }
    match std::fs::read_dir(o) {
        Ok(rd) => rd
            .flatten()
            .map(|e| e.path())
            .filter(|p| p.join(crate::store::MANIFEST).is_file())
            .all(|p| store_ok(&p)),
        Err(_) => o.exists(),
    }
}

/// Peak resident set size of this process so far (Linux `VmHWM`), in bytes.
pub fn peak_rss() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|v| v.parse::<u64>().ok())
        })
        .map(|kb| kb * 1024)
        .unwrap_or(0)
}

/// Reset the peak RSS counter (Linux ≥ 4.0: write 5 to clear_refs), so
/// that [`peak_rss`] measures one step. Returns false where unsupported.
pub fn reset_peak_rss() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}
