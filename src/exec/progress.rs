//! Progress of engine runs: bars on stderr ([`super::EngineConfig::progress`]),
//! indicatif's with the `progress` feature, else nothing is drawn (the same
//! calls, no output), so steps and drivers never name the feature; and an
//! [`Observer`] ([`super::EngineConfig::observer`]) told of every unit done,
//! which may ask the run to stop (the Python package's callback and its
//! KeyboardInterrupt).

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

#[cfg(feature = "progress")]
use std::io::IsTerminal;

/// Told of a run's progress: `(run name, units done, units in all)`, from
/// the thread that finishes each unit (a tile, a round). Returns `false` to
/// ask the run to stop (it then fails with [`crate::Error::InvalidArgument`]
/// "cancelled").
#[derive(Clone)]
pub struct Observer(pub Arc<ObserverFn>);

/// The callback an [`Observer`] holds.
pub type ObserverFn = dyn Fn(&str, u64, u64) -> bool + Send + Sync;

/// Two observers are equal when they are the same callback.
impl PartialEq for Observer {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0)
    }
}

impl std::fmt::Debug for Observer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Observer")
    }
}

/// An observer with its run's name and count.
#[derive(Debug, Clone)]
struct Watch {
    observer: Observer,
    name: Arc<str>,
    done: Arc<AtomicU64>,
    len: u64,
}

/// A progress bar, or nothing (hidden, or a build without `progress`),
/// and the run's observer if it has one.
#[derive(Debug, Clone)]
pub struct Progress {
    #[cfg(feature = "progress")]
    bar: indicatif::ProgressBar,
    watch: Option<Watch>,
}

impl Progress {
    /// A bar of `len` units drawn on stderr (indicatif's default style).
    pub fn new(len: u64) -> Progress {
        #[cfg(feature = "progress")]
        {
            Progress {
                bar: indicatif::ProgressBar::new(len),
                watch: None,
            }
        }
        #[cfg(not(feature = "progress"))]
        {
            let _ = len;
            Progress { watch: None }
        }
    }

    /// The progress of a run of `len` units named `name` under `cfg`: a
    /// bar of tiles (see [`Progress::tiles`]) when `cfg.progress`, and
    /// `cfg.observer` told of each unit.
    pub fn of_run(name: &str, len: usize, cfg: &super::EngineConfig) -> Progress {
        Progress::tiles(name, len, cfg.progress).observed(name, len as u64, cfg)
    }

    /// This progress, with `cfg.observer` (if any) told of each of the
    /// `len` units of the run `name`.
    pub fn observed(mut self, name: &str, len: u64, cfg: &super::EngineConfig) -> Progress {
        self.watch = cfg.observer.clone().map(|observer| Watch {
            observer,
            name: name.into(),
            done: Arc::new(AtomicU64::new(0)),
            len,
        });
        self
    }

    /// A bar of `len` tiles named `name`, with elapsed time and ETA; hidden
    /// unless `show` and stderr is a terminal.
    pub fn tiles(name: &str, len: usize, show: bool) -> Progress {
        #[cfg(feature = "progress")]
        {
            use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
            if !show || !std::io::stderr().is_terminal() {
                return Progress::hidden();
            }
            let bar = ProgressBar::with_draw_target(Some(len as u64), ProgressDrawTarget::stderr());
            if let Ok(style) = ProgressStyle::with_template(
                "{msg} [{elapsed_precise}] {wide_bar} {pos}/{len} tiles, ETA {eta}",
            ) {
                bar.set_style(style);
            }
            bar.set_message(name.to_string());
            Progress { bar, watch: None }
        }
        #[cfg(not(feature = "progress"))]
        {
            let _ = (name, len, show);
            Progress { watch: None }
        }
    }

    /// A bar that draws nothing.
    pub fn hidden() -> Progress {
        #[cfg(feature = "progress")]
        {
            Progress {
                bar: indicatif::ProgressBar::hidden(),
                watch: None,
            }
        }
        #[cfg(not(feature = "progress"))]
        {
            Progress { watch: None }
        }
    }

    /// Set the message shown before the bar.
    pub fn set_message(&self, msg: impl Into<String>) {
        #[cfg(feature = "progress")]
        self.bar.set_message(msg.into());
        #[cfg(not(feature = "progress"))]
        let _ = msg.into();
    }

    /// Advance by `n` units; `false` when the observer asks the run to
    /// stop.
    pub fn inc(&self, n: u64) -> bool {
        #[cfg(feature = "progress")]
        self.bar.inc(n);
        match &self.watch {
            Some(w) => {
                let done = w.done.fetch_add(n, Ordering::AcqRel) + n;
                (w.observer.0)(&w.name, done, w.len)
            }
            None => true,
        }
    }

    /// Remove the bar (the run finished).
    pub fn finish_and_clear(&self) {
        #[cfg(feature = "progress")]
        self.bar.finish_and_clear();
    }

    /// Leave the bar where it stopped (the run failed).
    pub fn abandon(&self) {
        #[cfg(feature = "progress")]
        self.bar.abandon();
    }
}
