//! The memory-fit rule: a run that holds a working set in memory (a whole
//! raster at so many bytes per cell, one tile with its halo, two copies of
//! erosion states…) compares what it needs with the `--memory` budget
//! (`EngineConfig::memory_budget`) before it allocates anything, and either
//! chooses another way to run (tile by tile, spilled to disk) or refuses with
//! an error that says how much it needs and what to change.
//!
//! Sizes saturate: a working set too large for `u64` never fits.

use crate::error::Error;
use crate::raster::RasterInfo;
use std::path::Path;

const GIB: u64 = 1 << 30;

/// What a run needs against the budget it has; see the module doc.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MemoryFit {
    /// Bytes the run needs.
    pub need: u64,
    /// Bytes it may use.
    pub budget: u64,
    /// The raster's size in cells, when the need is per cell of a raster.
    pub cells: Option<(usize, usize)>,
}

impl MemoryFit {
    /// A whole `width` x `height` raster at `bytes_per_cell`.
    pub fn cells(width: usize, height: usize, bytes_per_cell: u64, budget: u64) -> MemoryFit {
        MemoryFit {
            need: (width as u64)
                .saturating_mul(height as u64)
                .saturating_mul(bytes_per_cell),
            budget,
            cells: Some((width, height)),
        }
    }

    /// The whole raster `info` describes at `bytes_per_cell`.
    pub fn raster(info: &RasterInfo, bytes_per_cell: u64, budget: u64) -> MemoryFit {
        MemoryFit::cells(info.width, info.height, bytes_per_cell, budget)
    }

    /// `need` bytes, however they are counted.
    pub fn bytes(need: u64, budget: u64) -> MemoryFit {
        MemoryFit {
            need,
            budget,
            cells: None,
        }
    }

    /// Whether the need fits the budget (`need <= budget`).
    pub fn fits(&self) -> bool {
        self.need <= self.budget
    }

    /// The need in GiB (for messages).
    pub fn need_gib(&self) -> f64 {
        self.need as f64 / GIB as f64
    }

    /// The need in whole MiB, rounded down (for messages).
    pub fn need_mib(&self) -> u64 {
        self.need >> 20
    }

    /// The budget in whole MiB, rounded down (for messages).
    pub fn budget_mib(&self) -> u64 {
        self.budget >> 20
    }

    /// The smallest whole number of GiB holding the need: the `--memory`
    /// value to suggest.
    pub fn suggested_gib(&self) -> u64 {
        self.need.div_ceil(GIB)
    }

    /// `Ok` when the need fits, else the error `refuse` builds from `self`.
    pub fn check(&self, refuse: impl FnOnce(&MemoryFit) -> Error) -> Result<(), Error> {
        if self.fits() {
            Ok(())
        } else {
            Err(refuse(self))
        }
    }

    /// The usual refusal of a whole-raster in-memory step: `"{subject}:
    /// {what} runs in memory and needs about {X.X} GiB for {W}x{H} cells;
    /// raise --memory (e.g. --memory {N}GiB){more}"`, where `more` adds the
    /// step's other ways out (e.g. `" or use --method least-cost"`); without
    /// cells (a [`MemoryFit::bytes`] need), `for {W}x{H} cells` is left out.
    pub fn runs_in_memory_error(&self, subject: &Path, what: &str, more: &str) -> Error {
        let cells = match self.cells {
            Some((w, h)) => format!(" for {w}x{h} cells"),
            None => String::new(),
        };
        Error::over_budget(format!(
            "{}: {what} runs in memory and needs about {:.1} GiB{cells}; raise --memory (e.g. --memory {}GiB){more}",
            subject.display(),
            self.need_gib(),
            self.suggested_gib()
        ))
    }

    /// `Ok` when the need fits, else [`MemoryFit::runs_in_memory_error`].
    pub fn check_in_memory(&self, subject: &Path, what: &str, more: &str) -> Result<(), Error> {
        self.check(|f| f.runs_in_memory_error(subject, what, more))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fits_up_to_the_budget() {
        let f = MemoryFit::cells(1000, 500, 28, 14_000_000);
        assert_eq!(f.need, 14_000_000);
        assert!(f.fits());
        assert!(!MemoryFit::cells(1000, 500, 28, 13_999_999).fits());
        assert!(MemoryFit::bytes(0, 0).fits());
        // Saturating: an absurd raster never fits, nothing overflows.
        let huge = MemoryFit::cells(usize::MAX, usize::MAX, 64, u64::MAX - 1);
        assert_eq!(huge.need, u64::MAX);
        assert!(!huge.fits());
    }

    #[test]
    fn sizes_for_messages() {
        let f = MemoryFit::bytes(3 * GIB + 1, 512 << 20);
        assert_eq!(f.suggested_gib(), 4);
        assert_eq!(f.need_mib(), 3072);
        assert_eq!(f.budget_mib(), 512);
        assert_eq!(format!("{:.1}", f.need_gib()), "3.0");
        assert_eq!(MemoryFit::bytes(GIB, 0).suggested_gib(), 1);
    }

    #[test]
    fn check_builds_the_error_only_when_it_does_not_fit() {
        let ok = MemoryFit::bytes(10, 10);
        assert!(ok.check(|_| panic!("fits")).is_ok());
        let e = MemoryFit::bytes(11 << 20, 10 << 20)
            .check(|f| Error::invalid(format!("{} MiB > {} MiB", f.need_mib(), f.budget_mib())))
            .unwrap_err();
        assert_eq!(e.to_string(), "11 MiB > 10 MiB");
    }

    #[test]
    fn the_in_memory_refusal_names_the_fix() {
        let f = MemoryFit::cells(600, 600, 64 << 10, 16 << 20);
        let e = f.runs_in_memory_error(Path::new("big.tif"), "this step", "");
        assert_eq!(
            e.to_string(),
            "big.tif: this step runs in memory and needs about 22.0 GiB for 600x600 cells; raise --memory (e.g. --memory 22GiB)"
        );
        let e = MemoryFit::bytes(GIB / 2, 0).runs_in_memory_error(
            Path::new("d.tif"),
            "--erode",
            " or drop --erode",
        );
        assert_eq!(
            e.to_string(),
            "d.tif: --erode runs in memory and needs about 0.5 GiB; raise --memory (e.g. --memory 1GiB) or drop --erode"
        );
    }
}
