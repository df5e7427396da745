//! `Stats`: a small global step (map/reduce, no apply output) computing
//! count, min, max, sum and a fixed-bin histogram of a raster. It exercises
//! the global-step machinery and serves `orogen info --stats`.

use super::GlobalStep;
use crate::error::{Error, Result};
use crate::raster::{TileId, TileLayout, TileView};
use serde::{Deserialize, Serialize};

/// Statistics with a histogram of `bins` equal bins over `[lo, hi]`; bin `i`
/// holds `lo + i w <= v < lo + (i+1) w` (`w = (hi - lo) / bins`), the last bin
/// also holds `v == hi`. Nodata (NaN) cells are counted apart; infinite
/// values count as below/above the range and are left out of min, max and
/// sum, so summaries stay finite (and JSON-serialisable).
#[derive(Debug, Clone, PartialEq)]
pub struct Stats {
    lo: f64,
    hi: f64,
    bins: usize,
}

/// Per-tile summary and, combined, the result.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StatsSummary {
    /// Finite valid cells.
    pub count: u64,
    /// Nodata cells.
    pub nodata: u64,
    /// Smallest finite value (None if there is none).
    pub min: Option<f64>,
    /// Largest finite value.
    pub max: Option<f64>,
    /// Sum of finite values (summed in row-major order per tile, then in
    /// tile id order: independent of threads, not of the tile size).
    pub sum: f64,
    /// Values below `lo` (including -inf).
    pub below: u64,
    /// Values above `hi` (including +inf).
    pub above: u64,
    /// Histogram counts.
    pub hist: Vec<u64>,
}

impl StatsSummary {
    fn empty(bins: usize) -> Self {
        StatsSummary {
            count: 0,
            nodata: 0,
            min: None,
            max: None,
            sum: 0.0,
            below: 0,
            above: 0,
            hist: vec![0; bins],
        }
    }

    /// Mean of the finite values.
    pub fn mean(&self) -> Option<f64> {
        (self.count > 0).then(|| self.sum / self.count as f64)
    }

    fn merge(&mut self, o: &StatsSummary) {
        self.count += o.count;
        self.nodata += o.nodata;
        self.min = match (self.min, o.min) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        };
        self.max = match (self.max, o.max) {
            (Some(a), Some(b)) => Some(a.max(b)),
            (a, b) => a.or(b),
        };
        self.sum += o.sum;
        self.below += o.below;
        self.above += o.above;
        for (h, x) in self.hist.iter_mut().zip(&o.hist) {
            *h += x;
        }
    }
}

impl Stats {
    /// Histogram of `bins` bins (1..=1_000_000) over `[lo, hi]` (finite, lo < hi).
    pub fn new(lo: f64, hi: f64, bins: usize) -> Result<Stats> {
        if !(lo.is_finite() && hi.is_finite() && lo < hi) {
            return Err(Error::invalid(format!(
                "histogram range [{lo}, {hi}] must be finite with lo < hi"
            )));
        }
        if bins == 0 || bins > 1_000_000 {
            return Err(Error::invalid(format!(
                "histogram bins {bins} outside 1..=1000000"
            )));
        }
        Ok(Stats { lo, hi, bins })
    }
}

impl GlobalStep for Stats {
    type In = f64;
    type Out = f64;
    type Summary = StatsSummary;
    type Solution = StatsSummary;
    type Slice = ();

    fn name(&self) -> String {
        "stats".into()
    }
    fn params(&self) -> serde_json::Value {
        serde_json::json!({"lo": self.lo, "hi": self.hi, "bins": self.bins})
    }
    fn outputs(&self) -> Vec<crate::exec::output::OutputSpec> {
        Vec::new()
    }

    fn map(&self, inputs: &[TileView<f64>]) -> Result<StatsSummary> {
        let mut s = StatsSummary::empty(self.bins);
        let Some(view) = inputs.first() else {
            return Err(Error::invalid("stats needs one input"));
        };
        let (n, range) = (self.bins as f64, self.hi - self.lo);
        let (mut min, mut max) = (f64::INFINITY, f64::NEG_INFINITY);
        for &v in view.core_grid().data() {
            if v.is_nan() {
                s.nodata += 1;
                continue;
            }
            if v < self.lo {
                s.below += 1;
            } else if v > self.hi {
                s.above += 1;
            } else {
                let i = (((v - self.lo) * n / range).floor() as usize).min(self.bins - 1);
                s.hist[i] += 1;
            }
            if v.is_finite() {
                s.count += 1;
                s.sum += v;
                min = min.min(v);
                max = max.max(v);
            }
        }
        if s.count > 0 {
            s.min = Some(min);
            s.max = Some(max);
        }
        Ok(s)
    }

    fn reduce(&self, _layout: &TileLayout, summaries: Vec<StatsSummary>) -> Result<StatsSummary> {
        let mut total = StatsSummary::empty(self.bins);
        for s in &summaries {
            total.merge(s);
        }
        Ok(total)
    }

    fn slice(&self, _solution: &StatsSummary, _id: TileId) {}

    fn apply(
        &self,
        _inputs: &[TileView<f64>],
        _slice: &(),
        _out: &mut [crate::raster::Grid<f64>],
    ) -> Result<()> {
        Ok(())
    }
}
