//! Named crash points for the crash-anywhere harness (`tools/crash_harness.py`,
//! issue 12). Writers call [`point`] at the moments where an interruption is
//! most dangerous (a tile's temporary file written but not renamed, a tile
//! renamed but not journalled, a manifest renamed but the journal not yet
//! removed, a GeoTIFF complete under its temporary name, ...).
//!
//! Off unless the environment asks for it, and then read once per process:
//! - `OROGEN_CRASH_AT=PATTERN:N` aborts the process (`abort()`: no destructor,
//!   no cleanup, like SIGKILL) at the N-th (1-based) point whose name matches
//!   PATTERN: an exact name such as `store.tile.tmp`, or a prefix ending in
//!   `*` (`store.*`, `*` for every point).
//! - `OROGEN_CRASH_ACTION=pause` (with `OROGEN_CRASH_SIGNAL=PREFIX`) pauses
//!   there instead: the process creates `PREFIX.paused` and waits until
//!   `PREFIX.resume` exists, so a test can act on a half-written output (a
//!   second writer, a reader, a truncated input) at a known moment.
//! - `OROGEN_CRASH_LOG=FILE` appends the name of every point reached, one a
//!   line (the harness counts them in an uninterrupted run to pick N).
//!
//! Cost when off: one initialised `OnceLock` read per call; the calls sit
//! next to file renames and fsyncs, never in cell loops.

use std::io::Write;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, OnceLock};

struct Config {
    /// Pattern and hit number from `OROGEN_CRASH_AT`.
    at: Option<(String, u64)>,
    /// Hits of the pattern so far.
    hits: AtomicU64,
    /// Log of points reached.
    log: Option<Mutex<std::fs::File>>,
    /// Pause (signal file prefix) instead of aborting.
    pause: Option<std::path::PathBuf>,
}

fn config() -> Option<&'static Config> {
    static CFG: OnceLock<Option<Config>> = OnceLock::new();
    CFG.get_or_init(|| {
        let at = std::env::var("OROGEN_CRASH_AT").ok().and_then(|s| {
            let (p, n) = s.rsplit_once(':')?;
            Some((p.to_string(), n.trim().parse::<u64>().ok()?))
        });
        let log = std::env::var_os("OROGEN_CRASH_LOG").and_then(|p| {
            std::fs::OpenOptions::new()
                .create(true)
                .append(true)
                .open(p)
                .ok()
                .map(Mutex::new)
        });
        let pause = (std::env::var("OROGEN_CRASH_ACTION").as_deref() == Ok("pause"))
            .then(|| std::env::var_os("OROGEN_CRASH_SIGNAL").map(std::path::PathBuf::from))
            .flatten();
        (at.is_some() || log.is_some()).then_some(Config {
            at,
            hits: AtomicU64::new(0),
            log,
            pause,
        })
    })
    .as_ref()
}

/// True if `name` matches `pattern` (exact, or prefix before a final `*`).
fn matches(pattern: &str, name: &str) -> bool {
    match pattern.strip_suffix('*') {
        Some(prefix) => name.starts_with(prefix),
        None => pattern == name,
    }
}

/// Crash point `kind.stage` (e.g. `store.tile` + `tmp`): logs it and aborts
/// the process if `OROGEN_CRASH_AT` selects this hit; does nothing otherwise.
pub fn point(kind: &str, stage: &str) {
    let Some(cfg) = config() else {
        return;
    };
    let name = format!("{kind}.{stage}");
    if let Some(log) = &cfg.log {
        if let Ok(mut f) = log.lock() {
            let _ = writeln!(f, "{name}");
        }
    }
    if let Some((pattern, n)) = &cfg.at {
        if matches(pattern, &name) && cfg.hits.fetch_add(1, Ordering::SeqCst) + 1 == *n {
            match &cfg.pause {
                Some(prefix) => pause(prefix),
                None => std::process::abort(),
            }
        }
    }
}

/// Create `PREFIX.paused`, then wait (polling) until `PREFIX.resume` exists.
fn pause(prefix: &std::path::Path) {
    let with = |ext: &str| {
        let mut p = prefix.as_os_str().to_owned();
        p.push(ext);
        std::path::PathBuf::from(p)
    };
    let _ = std::fs::write(with(".paused"), std::process::id().to_string());
    let resume = with(".resume");
    while !resume.exists() {
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
}

#[cfg(test)]
mod tests {
    use super::matches;

    #[test]
    fn patterns() {
        assert!(matches("*", "store.tile.tmp"));
        assert!(matches("store.*", "store.tile.tmp"));
        assert!(!matches("store.*", "tiff.tmp"));
        assert!(matches("tiff.tmp", "tiff.tmp"));
        assert!(!matches("tiff.tmp", "tiff.tmp2"));
        assert!(!matches("tiff", "tiff.tmp"));
    }
}
