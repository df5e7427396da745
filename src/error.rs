//! Typed library errors. Every error that concerns a file names it; the message
//! says what is wrong and, where there is one, what to do about it.

use std::path::{Path, PathBuf};

/// The library's error type.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// An operating-system I/O error on a named file (with what to do for
    /// a full disk or a read-only folder).
    #[error("{}: {err}{}", path.display(), io_hint(err))]
    Io {
        path: PathBuf,
        // Not a `source`: the message already includes it, and error chains
        // printed by the CLI would repeat it.
        err: std::io::Error,
    },
    /// A file whose content is corrupt, truncated or inconsistent.
    #[error("{}: {msg}", path.display())]
    Corrupt { path: PathBuf, msg: String },
    /// A valid file using a variant orogen does not read (e.g. JPEG compression).
    #[error("{}: unsupported: {msg}", path.display())]
    Unsupported { path: PathBuf, msg: String },
    /// A declared size beyond what orogen will allocate or the file can hold.
    #[error("{}: {msg}", path.display())]
    TooLarge { path: PathBuf, msg: String },
    /// A bad parameter or combination of parameters (not tied to a file).
    #[error("{0}")]
    InvalidArgument(String),
    /// A run that needs more memory than the budget (`--memory`) allows;
    /// the message says how much and what to change.
    #[error("{0}")]
    OverBudget(String),
    /// A tile store problem (missing, locked, inconsistent manifest, torn tile).
    #[error("{}: {msg}", path.display())]
    Store { path: PathBuf, msg: String },
    /// An error while processing one tile of a step (added by the engine).
    #[error("{step}, tile {id}: {inner}")]
    Tile {
        step: String,
        id: usize,
        // Not a `source`: the message already includes it (no repetition in
        // the CLI's error chain).
        inner: Box<Error>,
    },
}

/// The fix for the I/O errors a user can fix (issue 12: "one clear error
/// naming the file and the fix"); empty for the others.
fn io_hint(e: &std::io::Error) -> &'static str {
    match e.kind() {
        std::io::ErrorKind::StorageFull | std::io::ErrorKind::QuotaExceeded => {
            "; free disk space (or choose another output folder) and rerun: outputs are only renamed into place when complete, and tile stores keep their finished tiles"
        }
        std::io::ErrorKind::ReadOnlyFilesystem => {
            "; the folder is read-only: choose a writable output folder (or remount it read-write) and rerun"
        }
        std::io::ErrorKind::PermissionDenied => {
            "; check the permissions of the file and its folder"
        }
        _ => "",
    }
}

/// Result alias used throughout the library.
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// I/O error on `path`.
    pub fn io(path: impl AsRef<Path>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.as_ref().to_path_buf(),
            err: source,
        }
    }
    /// Corrupt or truncated content in `path`.
    pub fn corrupt(path: impl AsRef<Path>, msg: impl Into<String>) -> Self {
        Error::Corrupt {
            path: path.as_ref().to_path_buf(),
            msg: msg.into(),
        }
    }
    /// Unsupported variant in `path`.
    pub fn unsupported(path: impl AsRef<Path>, msg: impl Into<String>) -> Self {
        Error::Unsupported {
            path: path.as_ref().to_path_buf(),
            msg: msg.into(),
        }
    }
    /// Declared size too large in `path`.
    pub fn too_large(path: impl AsRef<Path>, msg: impl Into<String>) -> Self {
        Error::TooLarge {
            path: path.as_ref().to_path_buf(),
            msg: msg.into(),
        }
    }
    /// Tile-store error in `path`.
    pub fn store(path: impl AsRef<Path>, msg: impl Into<String>) -> Self {
        Error::Store {
            path: path.as_ref().to_path_buf(),
            msg: msg.into(),
        }
    }
    /// `source` raised while step `step` processed tile `id`. An error
    /// that names its file (unreadable block, full disk, torn store tile)
    /// is returned as it is: the file and what is wrong with it are the
    /// message, and the engine's step and tile would only hide them.
    pub fn tile(step: impl Into<String>, id: usize, source: Error) -> Self {
        match source {
            Error::Io { .. }
            | Error::Corrupt { .. }
            | Error::Unsupported { .. }
            | Error::TooLarge { .. }
            | Error::Store { .. }
            | Error::Tile { .. } => source,
            Error::InvalidArgument(_) | Error::OverBudget(_) => Error::Tile {
                step: step.into(),
                id,
                inner: Box::new(source),
            },
        }
    }
    /// Over the memory budget.
    pub fn over_budget(msg: impl Into<String>) -> Self {
        Error::OverBudget(msg.into())
    }
    /// Invalid argument.
    pub fn invalid(msg: impl Into<String>) -> Self {
        Error::InvalidArgument(msg.into())
    }
}

/// Extension to attach a path to `std::io::Result`.
pub trait IoContext<T> {
    /// Map an I/O error to [`Error::Io`] naming `path`.
    fn at(self, path: impl AsRef<Path>) -> Result<T>;
}

impl<T> IoContext<T> for std::io::Result<T> {
    fn at(self, path: impl AsRef<Path>) -> Result<T> {
        self.map_err(|e| Error::io(path, e))
    }
}
