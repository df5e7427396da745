//! `orogen run job.toml`: batch jobs (see `orogen::job` for the file format).

use anyhow::{anyhow, Context, Result};
use clap::{Args, CommandFactory, Parser};
use orogen::job::{self, CommandTable, StepRecord};
use orogen::report::{self, Status, StepOutcome};
use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `orogen run`.
#[derive(Args, Clone)]
pub struct RunArgs {
    /// The job file (TOML).
    pub job: PathBuf,
    /// Memory budget for every step (overrides the job file's `memory`).
    #[arg(long)]
    pub memory: Option<String>,
    /// Worker threads for every step (overrides the job file's `threads`).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Also write step events as JSON lines to this file.
    #[arg(long)]
    pub log: Option<PathBuf>,
    /// Do not write report.html.
    #[arg(long)]
    pub no_report: bool,
    /// Check the job file and print the steps' command lines without running them.
    #[arg(long)]
    pub dry_run: bool,
    /// No progress bars.
    #[arg(long, short)]
    pub quiet: bool,
    /// Engine for every step (overrides the job file's `engine`): local or mpi.
    #[arg(long, value_enum)]
    pub engine: Option<crate::EngineArg>,
}

/// The CLI's commands, as a job sees them. A command is a path of
/// subcommand names separated by spaces (`synth noise`).
struct ClapTable(clap::Command);

impl ClapTable {
    fn find(&self, path: &str) -> Option<&clap::Command> {
        let mut c = &self.0;
        for w in path.split_whitespace() {
            c = c.find_subcommand(w)?;
        }
        (!std::ptr::eq(c, &self.0)).then_some(c)
    }
}

impl CommandTable for ClapTable {
    fn has(&self, name: &str) -> bool {
        self.find(name).is_some()
    }
    fn names(&self) -> Vec<String> {
        let mut out = vec![];
        for c in self.0.get_subcommands() {
            let n = c.get_name();
            if n == "run" || n == "help" {
                continue;
            }
            let methods: Vec<&str> = c
                .get_subcommands()
                .map(|m| m.get_name())
                .filter(|m| *m != "help")
                .collect();
            if methods.is_empty() {
                out.push(n.to_string());
            } else {
                out.extend(methods.iter().map(|m| format!("{n} {m}")));
            }
        }
        out
    }
    fn accepts(&self, command: &str, opt: &str) -> bool {
        self.find(command).is_some_and(|c| {
            c.get_arguments().any(|a| {
                a.get_long() == Some(opt) || a.get_short().is_some_and(|s| opt == s.to_string())
            })
        })
    }
    fn methods(&self, command: &str) -> Vec<String> {
        self.find(command).map_or(vec![], |c| {
            c.get_subcommands()
                .map(|m| m.get_name().to_string())
                .filter(|m| m != "help")
                .collect()
        })
    }
}

/// Commands whose raster outputs are elevations (previewed with hillshade).
const ELEVATION_COMMANDS: [&str; 8] = [
    "fill", "breach", "export", "ingest", "demo", "synth", "erode", "convert",
];

/// Files named by a step's option values (not its inputs or `-o` output)
/// that exist and were modified since `since`: what options such as
/// `--metrics x.csv` or `--profile p.json` made the step write.
fn written_by_options(s: &job::Planned, since: std::time::SystemTime) -> Vec<PathBuf> {
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

pub fn run(a: RunArgs) -> Result<()> {
    let table = ClapTable(crate::Cli::command());
    let job = job::load(&a.job, &table, a.memory.as_deref(), a.threads)?;
    let argv_of = |s: &job::Planned| {
        let mut v = vec!["orogen".to_string()];
        v.extend(s.argv.iter().cloned());
        if a.quiet && table.accepts(&s.command, "quiet") {
            v.push("--quiet".into());
        }
        v
    };
    // Every step's command line is checked before anything runs.
    for s in &job.steps {
        if let Err(e) = crate::Cli::try_parse_from(argv_of(s)) {
            let msg = e.render().to_string();
            let first = msg
                .lines()
                .next()
                .unwrap_or("")
                .trim_start_matches("error: ");
            return Err(anyhow!(
                "{}: step {:?}: {first}\n  command: orogen {}",
                a.job.display(),
                s.name,
                s.argv.join(" ")
            ));
        }
    }
    if a.dry_run {
        for (i, s) in job.steps.iter().enumerate() {
            println!(
                "[{}/{}] {}: orogen {}",
                i + 1,
                job.steps.len(),
                s.name,
                s.argv.join(" ")
            );
        }
        return Ok(());
    }
    if let Some(e) = a.engine {
        e.select()?;
    }
    // Under MPI every rank runs the job; rank 0 alone keeps its books (state,
    // log, report), as it alone writes the outputs.
    let lead = orogen::exec::rank().0 == 0;
    std::fs::create_dir_all(&job.output_dir)
        .with_context(|| format!("creating the output folder {}", job.output_dir.display()))?;
    let log_path = a.log.clone().or(job.log.clone());
    let mut log = match &log_path {
        Some(p) if lead => Some(
            std::fs::OpenOptions::new()
                .create(true)
                .append(true)
                .open(p)
                .with_context(|| format!("opening the log {}", p.display()))?,
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
        })
        .collect();
    let mut failure = None;
    for (i, s) in job.steps.iter().enumerate() {
        if job.is_done(&state, i) {
            eprintln!(
                "[{}/{n}] {}: done in an earlier run, skipped",
                i + 1,
                s.name
            );
            outcomes[i].status = Status::Skipped;
            log_line(
                &mut log,
                serde_json::json!({"event": "skipped", "step": s.name}),
            );
            continue;
        }
        eprintln!("[{}/{n}] {}: orogen {}", i + 1, s.name, s.argv.join(" "));
        log_line(
            &mut log,
            serde_json::json!({"event": "start", "step": s.name, "command": s.argv}),
        );
        let fingerprint = job.fingerprint(i);
        job::reset_peak_rss();
        let t0 = Instant::now();
        // File times come from a coarse kernel clock: allow a margin.
        let started = std::time::SystemTime::now() - std::time::Duration::from_secs(2);
        let cli = crate::Cli::try_parse_from(argv_of(s))?;
        let result = crate::run(cli);
        let seconds = t0.elapsed().as_secs_f64();
        let peak = job::peak_rss();
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
                let msg = format!("{e:#}");
                outcomes[i].status = Status::Failed(msg.clone());
                log_line(
                    &mut log,
                    serde_json::json!({"event": "failed", "step": s.name, "error": msg}),
                );
                failure = Some(e.context(format!(
                    "{}: step {:?} (orogen {}) failed; fix it and rerun the job to continue from this step",
                    a.job.display(),
                    s.name,
                    s.argv.join(" ")
                )));
                break;
            }
        }
    }
    if lead && job.report && !a.no_report {
        let path = job.output_dir.join("report.html");
        let title = format!("orogen job {}", a.job.display());
        match report::write_report(&title, &outcomes, &path) {
            Ok(()) => crate::wrote(&path),
            Err(e) => eprintln!("warning: report not written: {e}"),
        }
    }
    match failure {
        Some(e) => Err(e),
        None => Ok(()),
    }
}
