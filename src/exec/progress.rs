//! Progress bars on stderr for engine runs ([`super::EngineConfig::progress`]):
//! indicatif's with the `progress` feature, else nothing is drawn (the same
//! calls, no output), so steps and drivers never name the feature.

#[cfg(feature = "progress")]
use std::io::IsTerminal;

/// A progress bar, or nothing (hidden, or a build without `progress`).
#[derive(Debug, Clone)]
pub struct Progress {
    #[cfg(feature = "progress")]
    bar: indicatif::ProgressBar,
}

impl Progress {
    /// A bar of `len` units drawn on stderr (indicatif's default style).
    pub fn new(len: u64) -> Progress {
        #[cfg(feature = "progress")]
        {
            Progress {
                bar: indicatif::ProgressBar::new(len),
            }
        }
        #[cfg(not(feature = "progress"))]
        {
            let _ = len;
            Progress {}
        }
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
            Progress { bar }
        }
        #[cfg(not(feature = "progress"))]
        {
            let _ = (name, len, show);
            Progress {}
        }
    }

    /// A bar that draws nothing.
    pub fn hidden() -> Progress {
        #[cfg(feature = "progress")]
        {
            Progress {
                bar: indicatif::ProgressBar::hidden(),
            }
        }
        #[cfg(not(feature = "progress"))]
        {
            Progress {}
        }
    }

    /// Set the message shown before the bar.
    pub fn set_message(&self, msg: impl Into<String>) {
        #[cfg(feature = "progress")]
        self.bar.set_message(msg.into());
        #[cfg(not(feature = "progress"))]
        let _ = msg.into();
    }

    /// Advance by `n` units.
    pub fn inc(&self, n: u64) {
        #[cfg(feature = "progress")]
        self.bar.inc(n);
        #[cfg(not(feature = "progress"))]
        let _ = n;
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
