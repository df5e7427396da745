//! `orogen run job.toml`: batch jobs (see `orogen::ops::job` for the file
//! format); the steps are typed and run by the library.

use super::erode::printer;
use anyhow::Result;
use clap::Args;
use orogen::ops::job::{self, JobOptions};
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

/// Run `orogen run`.
pub fn run(a: RunArgs) -> Result<()> {
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
    let job = job::prepare(&a.job, &opts)?;
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
                Ok(t) if t.is_empty() => println!("    options: none"),
                Ok(t) => {
                    println!("    options:");
                    for l in t.lines() {
                        println!("      {l}");
                    }
                }
                Err(e) => println!("    options: {e}"),
            }
        }
        return Ok(());
    }
    job::run(&job, &opts, &mut printer(false))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use clap::CommandFactory;

    /// The job registry names exactly the CLI's commands (a group's methods
    /// as "group method"), so a new command cannot be forgotten.
    /// The CLI's commands as a job names them: every subcommand but `run`
    /// and `help`, a group's methods as "group method".
    fn cli_command_names() -> Vec<String> {
        let cli = crate::Cli::command();
        let mut out = vec![];
        for c in cli.get_subcommands() {
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

    /// The job registry names exactly the CLI's commands (a group's methods
    /// as "group method"), so a new command cannot be forgotten.
    #[test]
    fn the_job_registry_names_every_cli_command() {
        let mut from_clap = cli_command_names();
        let mut registered: Vec<String> = orogen::ops::job::COMMANDS
            .iter()
            .map(|c| c.name.to_string())
            .collect();
        from_clap.sort();
        registered.sort();
        assert_eq!(registered, from_clap);
    }
}
