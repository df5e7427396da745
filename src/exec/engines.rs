//! The engine chosen as a value: [`EngineKind`] names it (carried in
//! [`EngineConfig::engine`]), [`engine`] builds it, [`Engines`] runs steps
//! on whichever it is. Callers write `exec::engine(cfg)?.run_local(...)` and
//! never consult a process-global flag; the in-process [`LocalEngine`] only
//! runs in this process.

use super::{Engine, EngineConfig, GlobalStep, LocalEngine, LocalStep, Run};
use crate::error::Result;
use serde::{Deserialize, Serialize};

/// Which engine runs the steps (`--engine`, a job's `engine`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum EngineKind {
    /// In-process: tiles on a rayon pool ([`LocalEngine`]).
    #[default]
    Local,
    /// MPI: tiles spread over the ranks of `mpirun` (needs `--features mpi`).
    Mpi,
}

impl EngineKind {
    /// The engine this process was started for: `Mpi` once
    /// [`super::select_engine`] started MPI, else `Local`. What a command
    /// line without `--engine` runs on, so that every step of
    /// `mpirun ... orogen run --engine mpi job.toml` runs on the ranks.
    pub fn current() -> EngineKind {
        if super::distributed() {
            EngineKind::Mpi
        } else {
            EngineKind::Local
        }
    }
}

/// An engine of either kind, chosen by [`EngineConfig::engine`].
#[derive(Debug, Clone)]
pub enum Engines {
    /// In this process.
    Local(LocalEngine),
    /// Over the ranks of `MPI_COMM_WORLD`, each computing as the local
    /// engine of the same configuration.
    #[cfg(feature = "mpi")]
    Mpi(super::mpi::MpiEngine),
}

/// The engine `cfg` names. `EngineKind::Mpi` starts MPI if it is not yet
/// running (once per process) and is an error, naming the feature, in a
/// build without `mpi`.
pub fn engine(cfg: &EngineConfig) -> Result<Engines> {
    let local = LocalEngine::new(cfg.clone());
    match cfg.engine {
        EngineKind::Local => Ok(Engines::Local(local)),
        EngineKind::Mpi => mpi_engine(local),
    }
}

#[cfg(feature = "mpi")]
fn mpi_engine(local: LocalEngine) -> Result<Engines> {
    super::mpi::init()?;
    Ok(Engines::Mpi(super::mpi::MpiEngine::new(local)))
}

#[cfg(not(feature = "mpi"))]
fn mpi_engine(_local: LocalEngine) -> Result<Engines> {
    Err(super::mpi_missing())
}

/// One `Engine` method of [`Engines`]: the same call on the engine inside.
macro_rules! forward {
    ($name:ident, $bound:ident, $ret:ty) => {
        fn $name<S: $bound>(&self, step: &S, run: Run<'_>) -> Result<$ret> {
            match self {
                Engines::Local(e) => e.$name(step, run),
                #[cfg(feature = "mpi")]
                Engines::Mpi(e) => e.$name(step, run),
            }
        }
    };
}

impl Engine for Engines {
    forward!(run_local, LocalStep, ());
    forward!(run_global, GlobalStep, S::Solution);
    forward!(run_global_apply, GlobalStep, ());
}
