//! Scratch folders: intermediate tile stores and spilled states of a run,
//! kept in a folder that is removed when the run ends — by [`ScratchDir::remove`]
//! (which reports a failure) or, on any early return or panic, when the
//! value is dropped (best effort). A folder is only ever removed by the
//! process that owns it: under MPI the ranks share a filesystem, and only
//! the rank that created a shared folder removes it ([`ScratchDir::owned`]).

use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

/// The name of a hidden scratch folder beside `output`:
/// `.{file name}.{suffix}` in `output`'s folder (`fallback` stands for a
/// missing file name), e.g. `out/.dem.tif.erosion-scratch` for
/// `out/dem.tif`.
pub fn hidden_beside(output: &Path, suffix: &str, fallback: &str) -> PathBuf {
    let name = output
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| fallback.into());
    output.with_file_name(format!(".{name}.{suffix}"))
}

/// A scratch folder removed when the run ends (see the module doc). The
/// folder is not created here: the writers that fill it create it (tile
/// stores, spill files), or [`ScratchDir::create`] does.
#[derive(Debug)]
pub struct ScratchDir {
    path: PathBuf,
    /// Whether this process removes the folder (false: another rank does).
    owner: bool,
    /// Set once removed or kept: nothing left to do on drop.
    done: bool,
}

impl ScratchDir {
    /// A scratch folder at `path`, removed by this process.
    pub fn new(path: impl Into<PathBuf>) -> ScratchDir {
        ScratchDir {
            path: path.into(),
            owner: true,
            done: false,
        }
    }

    /// The hidden folder [`hidden_beside`] `output`, removed by this process.
    pub fn beside(output: &Path, suffix: &str, fallback: &str) -> ScratchDir {
        ScratchDir::new(hidden_beside(output, suffix, fallback))
    }

    /// The same folder, removed by this process only if `owner` (e.g. only
    /// on MPI rank 0, which created the shared store).
    pub fn owned(mut self, owner: bool) -> ScratchDir {
        self.owner = owner;
        self
    }

    /// Create the folder (and its parents) now.
    pub fn create(self) -> Result<ScratchDir> {
        std::fs::create_dir_all(&self.path).map_err(|e| Error::io(&self.path, e))?;
        Ok(self)
    }

    /// The folder's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Remove the folder now (if this process owns it). A folder that does
    /// not exist (never filled, or already gone) is no error; any other
    /// failure is returned, naming the folder.
    pub fn remove(mut self) -> Result<()> {
        self.done = true;
        if !self.owner {
            return Ok(());
        }
        match std::fs::remove_dir_all(&self.path) {
            Ok(()) => Ok(()),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
            Err(e) => Err(Error::io(&self.path, e)),
        }
    }

    /// Leave the folder in place (for inspection) and return its path.
    pub fn keep(mut self) -> PathBuf {
        self.done = true;
        std::mem::take(&mut self.path)
    }
}

impl Drop for ScratchDir {
    fn drop(&mut self) {
        if !self.done && self.owner {
            let _ = std::fs::remove_dir_all(&self.path);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hidden_names_sit_beside_the_output() {
        assert_eq!(
            hidden_beside(Path::new("out/dem.tif"), "erosion-scratch", "x"),
            PathBuf::from("out/.dem.tif.erosion-scratch")
        );
        assert_eq!(
            hidden_beside(Path::new("dem.tiles"), "d8-tmp.tiles", "x"),
            PathBuf::from(".dem.tiles.d8-tmp.tiles")
        );
        // No file name: the fallback names it.
        assert_eq!(
            hidden_beside(Path::new("/"), "sp-scratch", "erosion"),
            PathBuf::from("/.erosion.sp-scratch")
        );
    }

    #[test]
    fn removed_on_drop_and_by_remove() {
        let d = tempfile::tempdir().unwrap();
        let out = d.path().join("a.tif");
        let s = ScratchDir::beside(&out, "t", "a").create().unwrap();
        let p = s.path().to_path_buf();
        assert_eq!(p, d.path().join(".a.tif.t"));
        std::fs::write(p.join("tile"), b"1").unwrap();
        drop(s);
        assert!(!p.exists());
        // remove: the folder goes, a missing folder is fine.
        let s = ScratchDir::new(&p).create().unwrap();
        std::fs::create_dir_all(p.join("sub")).unwrap();
        s.remove().unwrap();
        assert!(!p.exists());
        ScratchDir::new(&p).remove().unwrap();
        // Dropped without having been created: nothing happens.
        drop(ScratchDir::new(d.path().join("never")));
        assert!(d.path().exists());
    }

    #[test]
    fn kept_and_foreign_folders_stay() {
        let d = tempfile::tempdir().unwrap();
        let s = ScratchDir::new(d.path().join("k")).create().unwrap();
        let p = s.keep();
        assert!(p.is_dir());
        let s = ScratchDir::new(&p).owned(false);
        drop(s);
        assert!(p.is_dir(), "a folder another rank owns is left alone");
        ScratchDir::new(&p).owned(false).remove().unwrap();
        assert!(p.is_dir());
        ScratchDir::new(&p).remove().unwrap();
        assert!(!p.exists());
    }

    #[test]
    fn remove_reports_what_it_cannot_remove() {
        // A file where the folder should be: remove_dir_all fails (not
        // NotFound), and the error names the path.
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("f");
        std::fs::write(&p, b"x").unwrap();
        let e = ScratchDir::new(&p).remove().unwrap_err().to_string();
        assert!(e.starts_with(&p.display().to_string()), "{e}");
    }
}
