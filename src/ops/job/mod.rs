//! Batch jobs: a TOML file naming inputs, a memory budget, threads and steps
//! (any `orogen` command with its options), checked whole before anything
//! runs, ordered by their dependencies, and resumable.
//!
//! ```toml
//! memory = "1GiB"          # optional: budget passed to every step
//! threads = 0              # optional: 0 = all cores
//! output_dir = "out"       # optional: outputs go here (relative to this file)
//! engine = "local"         # optional: "mpi" under mpirun (orogen built with --features mpi)
//!
//! [inputs]
//! dem = "../shared/data/srtm3_S33W071.tif"   # relative to this file
//!
//! [[step]]
//! name = "filled"          # later steps refer to this step's output by name
//! run = "fill"             # the orogen command
//! input = "dem"            # an input or an earlier step (a list for several)
//! output = "filled.tif"    # relative to output_dir
//! args = { compress = "zstd", cog = true }   # the command's long options
//! ```
//!
//! Commands of a group (`orogen synth noise`) are named with their method,
//! separated by a space: `run = "synth noise"`; `run = "synth"` alone is an
//! error listing the methods.
//!
//! Option values: a typed command's keys are the fields of its
//! `ops::<cmd>::<Cmd>Options` (the CLI's long options, `_` or `-`), the run
//! settings (`memory`, `threads`, `tile`, `quiet`, `engine`), and for commands
//! writing rasters the output format (`compress`, `cog`, `block`, ...), each
//! read with its type: numbers as numbers, `true`/`false`, choices and
//! distances as text (`units = "percent"`, `radius = "10km"`), a list where
//! the CLI takes a comma-separated one (`metric = ["slope",
//! "tpi:radius=500m"]`). A string `"@name"` is the path of the input or step
//! called `name` (an extra dependency). Paths in `args`: a file the step
//! writes beside its output (`raster`, `stats`, `preview`, `geojson`,
//! `edited_tree`, ... of `plan::SIDE_OUTPUTS`) goes under `output_dir`; a
//! file it reads (`sinks`, `weights`, `mask`, `points`, ... of
//! `plan::INPUT_PATHS`) is taken from this file's folder, like `[inputs]`,
//! and must exist (or be written by a step) before the first step runs;
//! absolute paths are kept. The equivalent command line of a
//! step (strings and numbers as `--key value`, `true` as a flag, arrays
//! joined with commas) is what the log and report show.
//!
//! Resume: after each step the job records, in `output_dir/.orogen-job.json`,
//! a fingerprint of the step's command line and of its input files (size and
//! modification time). A rerun skips the steps whose fingerprint is unchanged
//! and whose outputs exist; a step killed half-way runs again, and the tile
//! stores it writes resume from their finished tiles. GeoTIFF outputs are
//! renamed into place only when complete, so a killed job never leaves a
//! partial file that looks finished.

//!
//! Running a job is a library call: [`prepare`] reads and checks the file
//! and turns every step into its operation's typed options (the registry
//! [`COMMANDS`]: the step's `args` become `ops::<cmd>::<Cmd>Options`, the
//! run settings and the output format), refusing an unknown key (with the
//! accepted keys and the nearest one), a value of the wrong kind or a
//! missing input before anything runs; [`run`] runs the steps in order by
//! calling `ops` directly, skipping those done in an earlier run, keeps the
//! resume state and the JSON-lines log, and writes `report.html`.
//!
//! `view` is in the registry but refused by [`prepare`]: it serves an
//! interactive map until stopped, which a batch step cannot be.
//!
//! Each step also has its equivalent command line ([`Planned::argv`]): the
//! log, the report and `orogen run --dry-run` show it (the dry run with the
//! step's typed options as TOML), and the resume fingerprint is taken from
//! it, so the fingerprints of earlier runs stay valid.

mod commands;
mod plan;
mod steps;
mod synth_steps;

pub use commands::{command, field_names, nearest, typed_step, Command, TypedStep, COMMANDS};
pub use plan::*;

use crate::error::{Error, Result};
use crate::exec::EngineKind;
use crate::ops::note::{Note, Notify};
use crate::report::{self, Status, StepOutcome};
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Options of `run` (each overrides the job file's value).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct JobOptions {
    /// Memory budget for every step, e.g. "512MiB".
    pub memory: Option<String>,
    /// Worker threads for every step.
    pub threads: Option<usize>,
    /// Also write step events as JSON lines to this file.
    pub log: Option<PathBuf>,
    /// Do not write report.html.
    pub no_report: bool,
    /// No progress bars: `--quiet` for every step that takes it.
    pub quiet: bool,
    /// Engine for every step, made the process's engine before the first step.
    pub engine: Option<EngineKind>,
}

/// What a job run did.
#[derive(Debug, Clone)]
pub struct JobReport {
    /// One outcome per step, in run order.
    pub outcomes: Vec<StepOutcome>,
    /// The report written, if any.
    pub report: Option<PathBuf>,
}

/// Commands whose raster outputs are elevations (previewed with hillshade).
const ELEVATION_COMMANDS: [&str; 9] = [
    "fill-nodata",
    "fill",
    "breach",
    "export",
    "ingest",
    "demo",
    "synth",
    "erode",
    "convert",
];

/// What the raster outputs of a step running `command` hold, for the
/// report's previews (a `metric` step's files are looked up per metric).
fn output_kind(command: &str) -> crate::raster::OutputKind {
    use crate::raster::OutputKind;
    match command {
        "flow" | "watersheds" | "basins" | "streams" => OutputKind::Categorical,
        "aspect" => OutputKind::Angle,
        _ => OutputKind::Continuous,
    }
}

/// Read and check the job file at `path` (see [`load`]) and type every
/// step (see the module doc): an unknown key, a wrong value or a missing
/// input is refused here, before any step runs.
pub fn prepare(path: &Path, opts: &JobOptions) -> Result<Job> {
    let job = load(path, opts.memory.as_deref(), opts.threads)?;
    let produced: Vec<&PathBuf> = job.steps.iter().filter_map(|s| s.output.as_ref()).collect();
    let in_file = |e: Error| Error::invalid(format!("{}: {e}", path.display()));
    for s in &job.steps {
        typed_step(s, opts.quiet).map_err(in_file)?;
        for p in &s.inputs {
            if !p.exists() && !produced.contains(&p) {
                return Err(in_file(commands::step_error(
                    s,
                    format!(
                        "input {} does not exist (and no step writes it)",
                        p.display()
                    ),
                )));
            }
        }
        for (k, v) in &s.args {
            let Some(file) = v.as_str().filter(|_| plan::is_input_path(&s.command, k)) else {
                continue;
            };
            let p = PathBuf::from(file);
            if !p.exists() && !produced.contains(&&p) {
                return Err(in_file(commands::step_error(
                    s,
                    format!(
                        "option {k}: {file} does not exist (and no step writes it); paths in args are relative to the job file's folder"
                    ),
                )));
            }
        }
    }
    Ok(job)
}

/// What `orogen run --dry-run` shows of step `s`: its typed options as
/// TOML (empty for an option-less command).
pub fn typed_options(s: &Planned) -> Result<String> {
    typed_step(s, false).map(|t| t.options)
}

/// Files named by a step's option values (not its inputs or `-o` output)
/// that exist and were modified since `since`: what options such as
/// `--metrics x.csv` or `--profile p.json` made the step write.
fn written_by_options(s: &Planned, since: std::time::SystemTime) -> Vec<PathBuf> {
    let mut out: Vec<PathBuf> = vec![];
    for (k, v) in s.argv.iter().enumerate().skip(1) {
        if !s.argv[k - 1].starts_with("--") || v.starts_with('-') {
            continue;
        }
        let p = PathBuf::from(v);
        if s.inputs.contains(&p) || s.output.as_ref() == Some(&p) || out.contains(&p) {
            continue;
        }
        let fresh = std::fs::metadata(&p)
            .ok()
            .filter(|m| m.is_file())
            .and_then(|m| m.modified().ok())
            .is_some_and(|t| t >= since);
        if fresh {
            out.push(p);
        }
    }
    out
}

fn log_line(log: &mut Option<std::fs::File>, v: serde_json::Value) {
    if let Some(f) = log {
        let _ = writeln!(f, "{v}");
    }
}

/// Run the steps of `job` (from [`prepare`]) by calling `ops`: steps done in an
/// earlier run (same command, same inputs) are skipped, the resume state is
/// saved after each step, and `report.html` is written into the job's
/// output folder (unless the job or `opts` turn it off), also when a step
/// failed. The first failing step ends the run with an error naming it.
pub fn run(job: &Job, opts: &JobOptions, notify: Notify<'_>) -> Result<JobReport> {
    if let Some(e) = opts.engine {
        crate::exec::select_engine(e)?;
    }
    // Under MPI every rank runs the job; rank 0 alone keeps its books (state,
    // log, report), as it alone writes the outputs.
    let lead = crate::exec::rank().0 == 0;
    std::fs::create_dir_all(&job.output_dir).map_err(|e| {
        Error::invalid(format!(
            "creating the output folder {}: {e}",
            job.output_dir.display()
        ))
    })?;
    let log_path = opts.log.clone().or(job.log.clone());
    let mut log = match &log_path {
        Some(p) if lead => Some(
            std::fs::OpenOptions::new()
                .create(true)
                .append(true)
                .open(p)
                .map_err(|e| Error::invalid(format!("opening the log {}: {e}", p.display())))?,
        ),
        _ => None,
    };
    let mut state = job.load_state();
    let n = job.steps.len();
    let mut outcomes: Vec<StepOutcome> = job
        .steps
        .iter()
        .map(|s| StepOutcome {
            name: s.name.clone(),
            command_line: format!("orogen {}", s.argv.join(" ")),
            status: Status::NotRun,
            seconds: 0.0,
            peak_rss_bytes: 0,
            output: s.output.clone(),
            extra_outputs: vec![],
            elevation: ELEVATION_COMMANDS
                .contains(&s.command.split_whitespace().next().unwrap_or("")),
            kind: output_kind(&s.command),
            classes: (s.command == "flow").then_some(crate::report::D8_CLASSES),
        })
        .collect();
    let mut failure = None;
    for (i, s) in job.steps.iter().enumerate() {
        if job.is_done(&state, i) {
            notify(Note::Message(format!(
                "[{}/{n}] {}: done in an earlier run, skipped",
                i + 1,
                s.name
            )));
            outcomes[i].status = Status::Skipped;
            log_line(
                &mut log,
                serde_json::json!({"event": "skipped", "step": s.name}),
            );
            continue;
        }
        notify(Note::Message(format!(
            "[{}/{n}] {}: orogen {}",
            i + 1,
            s.name,
            s.argv.join(" ")
        )));
        log_line(
            &mut log,
            serde_json::json!({"event": "start", "step": s.name, "command": s.argv}),
        );
        let fingerprint = job.fingerprint(i);
        reset_peak_rss();
        let t0 = Instant::now();
        // File times come from a coarse kernel clock: allow a margin.
        let started = std::time::SystemTime::now() - std::time::Duration::from_secs(2);
        let result = typed_step(s, opts.quiet).and_then(|t| t.run(&mut *notify));
        let seconds = t0.elapsed().as_secs_f64();
        let peak = peak_rss();
        outcomes[i].seconds = seconds;
        outcomes[i].peak_rss_bytes = peak;
        match result {
            Ok(()) => {
                outcomes[i].status = Status::Ran;
                outcomes[i].extra_outputs = written_by_options(s, started);
                state.done.insert(
                    s.name.clone(),
                    StepRecord {
                        fingerprint,
                        seconds,
                        peak_rss_bytes: peak,
                    },
                );
                if lead {
                    job.save_state(&state)?;
                }
                log_line(
                    &mut log,
                    serde_json::json!({"event": "done", "step": s.name, "seconds": seconds, "peak_rss_bytes": peak}),
                );
            }
            Err(e) => {
                let msg = e.to_string();
                outcomes[i].status = Status::Failed(msg.clone());
                log_line(
                    &mut log,
                    serde_json::json!({"event": "failed", "step": s.name, "error": msg}),
                );
                failure = Some(Error::invalid(format!(
                    "{}: step {:?} (orogen {}) failed; fix it and rerun the job to continue from this step: {msg}",
                    job.path.display(),
                    s.name,
                    s.argv.join(" ")
                )));
                break;
            }
        }
    }
    let mut written = None;
    if lead && job.report && !opts.no_report {
        let path = job.output_dir.join("report.html");
        let title = format!("orogen job {}", job.path.display());
        match report::write_report(&title, &outcomes, &path) {
            Ok(()) => {
                notify(Note::Wrote(path.clone()));
                written = Some(path);
            }
            Err(e) => notify(Note::Warning(format!("report not written: {e}"))),
        }
    }
    match failure {
        Some(e) => Err(e),
        None => Ok(JobReport {
            outcomes,
            report: written,
        }),
    }
}

/// Run one command of the registry ([`COMMANDS`], e.g. `"basins"` or
/// `"synth tectonic"`) as a job step would: `inputs` are its positional
/// inputs, `output` its `-o`, `args` its options by their long names (as
/// in a step's `args`, `_` or `-`). The keys are typed and checked exactly
/// as [`prepare`] checks a job's, then the operation runs. The library's
/// one door to every operation by name (the Python package's generic
/// functions use it).
pub fn run_command(
    command: &str,
    inputs: &[PathBuf],
    output: Option<&Path>,
    args: BTreeMap<String, toml::Value>,
    observer: Option<crate::exec::Observer>,
    notify: Notify<'_>,
) -> Result<()> {
    if command == "view" {
        return Err(Error::invalid(
            "`view` serves a map until stopped; run it from the command line",
        ));
    }
    let names: Vec<String> = (0..inputs.len()).map(|i| format!("input{i}")).collect();
    let file = JobFile {
        memory: None,
        threads: None,
        tile: None,
        engine: None,
        output_dir: None,
        log: None,
        report: Some(false),
        inputs: names.iter().cloned().zip(inputs.iter().cloned()).collect(),
        steps: vec![StepSpec {
            name: command.replace(' ', "-"),
            run: command.to_string(),
            input: match names.len() {
                0 => OneOrMany::None,
                1 => OneOrMany::One(names[0].clone()),
                _ => OneOrMany::Many(names),
            },
            output: output.map(Path::to_path_buf),
            args,
        }],
    };
    // Relative paths stay relative to the working directory. Messages
    // lose the job's framing (`orogen: step "basins": `): there is no job.
    let step_name = command.replace(' ', "-");
    let unframed = |e: Error| match e {
        Error::InvalidArgument(m) => {
            let m = m.strip_prefix("orogen: ").unwrap_or(&m);
            let m = m
                .strip_prefix(&format!("step {step_name:?}: "))
                .unwrap_or(m);
            Error::InvalidArgument(m.to_string())
        }
        e => e,
    };
    let job = plan(Path::new("orogen"), file, None, None).map_err(unframed)?;
    let step = &job.steps[0];
    let c = commands::command(&step.command)
        .ok_or_else(|| commands::step_error(step, format!("unknown command `{command}`")))
        .map_err(unframed)?;
    let typed = (c.build)(&commands::StepCall {
        step,
        quiet: true,
        observer,
    })
    .map_err(unframed)?;
    typed.run(notify)
}
