//! `orogen run job.toml`: batch jobs (see `orogen::ops::job` for the file
//! format). Typed steps run in the library; the steps of commands not typed
//! yet have their command lines parsed and run by this CLI (`ClapTable`).

use super::erode::printer;
use anyhow::Result;
use clap::{Args, CommandFactory, Parser};
use orogen::ops::job::{self, CommandTable, JobOptions, StepRunner};
use std::path::PathBuf;

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

impl StepRunner for ClapTable {
    fn check(&self, _step: &job::Planned, argv: &[String]) -> orogen::Result<()> {
        crate::Cli::try_parse_from(argv).map(|_| ()).map_err(|e| {
            let msg = e.render().to_string();
            let first = msg
                .lines()
                .next()
                .unwrap_or("")
                .trim_start_matches("error: ")
                .to_string();
            orogen::Error::invalid(first)
        })
    }
    fn run(&self, _step: &job::Planned, argv: &[String]) -> orogen::Result<()> {
        let result = crate::Cli::try_parse_from(argv)
            .map_err(anyhow::Error::from)
            .and_then(crate::run);
        result.map_err(|e| orogen::Error::invalid(format!("{e:#}")))
    }
}

/// Run `orogen run`.
pub fn run(a: RunArgs) -> Result<()> {
    let table = ClapTable(crate::Cli::command());
    let opts = JobOptions {
        memory: a.memory.clone(),
        threads: a.threads,
        log: a.log.clone(),
        no_report: a.no_report,
        quiet: a.quiet,
        engine: a.engine.map(|e| match e {
            crate::EngineArg::Local => orogen::exec::EngineKind::Local,
            crate::EngineArg::Mpi => orogen::exec::EngineKind::Mpi,
        }),
    };
    crate::cli::args::set_quiet(a.quiet);
    let job = job::prepare_with(&a.job, Some(&table), &opts)?;
    if a.dry_run {
        for (i, s) in job.steps.iter().enumerate() {
            println!(
                "[{}/{}] {}: orogen {}",
                i + 1,
                job.steps.len(),
                s.name,
                s.argv.join(" ")
            );
            match job::typed_options(s) {
                Some(Ok(t)) if t.is_empty() => println!("    options: none"),
                Some(Ok(t)) => {
                    println!("    options:");
                    for l in t.lines() {
                        println!("      {l}");
                    }
                }
                Some(Err(e)) => println!("    options: {e}"),
                None => println!("    options: parsed by the command line"),
            }
        }
        return Ok(());
    }
    job::run_with(&job, Some(&table), &opts, &mut printer(false))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use clap::CommandFactory;

    /// The job registry names exactly the CLI's commands (a group's methods
    /// as "group method"), so a new command cannot be forgotten.
    #[test]
    fn the_job_registry_names_every_cli_command() {
        let cli = super::ClapTable(crate::Cli::command());
        let mut from_clap = orogen::ops::job::CommandTable::names(&cli);
        let mut registered: Vec<String> = orogen::ops::job::COMMANDS
            .iter()
            .map(|c| c.name.to_string())
            .collect();
        from_clap.sort();
        registered.sort();
        assert_eq!(registered, from_clap);
    }
}
