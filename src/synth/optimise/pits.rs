//! Pit removal between EM iterations (Scott & Dodgson 2022, §4: the
//! synthesised terrain at each level but the finest is made free of
//! depressions, with the output's border as the only sinks) and depression
//! statistics used to measure its effect.
//!
//! The removal itself is the hydrology module's: flood-order breaching or
//! Lindsay's hybrid ([`crate::hydro::breach_masked`]) and the Priority-Flood
//! fill ([`crate::hydro::fill`]). A sink mask makes chosen cells extra
//! outlets (they are given to the fill as nodata, then restored).

use crate::error::Result;
use crate::hydro::{breach_masked, fill, BreachMethod, BreachOptions};
use crate::raster::Grid;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// How depressions are removed after each E-step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PitRemoval {
    /// Leave the reconstruction as it is.
    None,
    /// Flood-order breaching (the paper's choice and the default).
    Breach,
    /// Priority-flood fill.
    Fill,
    /// Lindsay (2016) selective breaching: carve channels of at most
    /// `max_length` cells lowered by at most `max_depth`, fill the rest.
    Hybrid { max_depth: f32, max_length: usize },
}

/// Remove the depressions of `g` (no NaN expected; the border drains, and
/// so do `sinks` cells when given).
pub fn remove_pits(
    g: &Grid<f32>,
    how: PitRemoval,
    sinks: Option<&Grid<bool>>,
) -> Result<Grid<f32>> {
    let breach = |method| {
        let o = BreachOptions {
            method,
            epsilon: false,
            fill_remaining: false,
        };
        breach_masked(g, &o, sinks)
    };
    match how {
        PitRemoval::None => Ok(g.clone()),
        PitRemoval::Breach => breach(BreachMethod::Breach),
        PitRemoval::Hybrid {
            max_depth,
            max_length,
        } => breach(BreachMethod::Hybrid {
            max_depth,
            max_length,
        }),
        PitRemoval::Fill => fill_with_sinks(g, sinks),
    }
}

/// Priority-Flood fill of `g` with the `sinks` cells as extra outlets (they
/// are given to the fill as nodata, then restored).
fn fill_with_sinks(g: &Grid<f32>, sinks: Option<&Grid<bool>>) -> Result<Grid<f32>> {
    match sinks {
        None => fill(g),
        Some(m) => {
            let mut holed = g.clone();
            for (v, &s) in holed.data_mut().iter_mut().zip(m.data()) {
                if s {
                    *v = f32::NAN;
                }
            }
            let mut f = fill(&holed)?;
            for ((v, &s), &orig) in f.data_mut().iter_mut().zip(m.data()).zip(g.data()) {
                if s {
                    *v = orig;
                }
            }
            Ok(f)
        }
    }
}

/// Remove only the *shallow* depressions of `g`: those whose depth (spill
/// level minus lowest cell, from the Priority-Flood fill with the border and
/// `sinks` as outlets) is at most `max_depth`; deeper ones are left exactly
/// as they are. `how` removes them (breach: carved to their outlet; fill:
/// raised to their spill level; hybrid: Lindsay's selective breaching).
///
/// Why: the finest level of the synthesis is not pit-removed (the paper),
/// and averaging overlapping source patches there leaves many small closed
/// contours on the pit-free coarser shape. Removing only those no deeper
/// than `max_depth` changes no cell by more than `max_depth`: filling raises
/// a cell by at most its depression's depth; a flood-order breach lowers
/// only cells below the depression's spill level (they lie on the flood's
/// path, whose filled level is at most the spill) and never below its
/// lowest cell. Deep depressions are given to the breach as extra outlets
/// (so no carve starts in or crosses one) and restored afterwards.
///
/// `max_depth = 0` (or `how = None`) returns `g` unchanged; errors for a
/// negative or NaN `max_depth`.
pub fn remove_shallow_pits(
    g: &Grid<f32>,
    max_depth: f32,
    how: PitRemoval,
    sinks: Option<&Grid<bool>>,
) -> Result<Grid<f32>> {
    if max_depth.is_nan() || max_depth < 0.0 {
        return Err(crate::error::Error::invalid(format!(
            "shallow pit removal: depth limit {max_depth} must be 0 or more (DEM units)"
        )));
    }
    if max_depth == 0.0 || how == PitRemoval::None {
        return Ok(g.clone());
    }
    let (w, h) = (g.width(), g.height());
    let f = fill_with_sinks(g, sinks)?;
    let (z, fz) = (g.data(), f.data());
    // 8-connected regions of raised cells and the depth of each.
    const NONE: u32 = u32::MAX;
    let mut label = vec![NONE; w * h];
    let mut depth: Vec<f32> = Vec::new();
    let mut stack: Vec<usize> = Vec::new();
    // raised by the fill (false for NaN)
    let raised = |c: usize| fz[c] > z[c];
    for start in 0..w * h {
        if !raised(start) || label[start] != NONE {
            continue;
        }
        let id = depth.len() as u32;
        let mut d = 0f32;
        label[start] = id;
        stack.push(start);
        while let Some(c) = stack.pop() {
            d = d.max(fz[c] - z[c]);
            let (x, y) = (c % w, c / w);
            for ny in y.saturating_sub(1)..(y + 2).min(h) {
                for nx in x.saturating_sub(1)..(x + 2).min(w) {
                    let m = ny * w + nx;
                    if raised(m) && label[m] == NONE {
                        label[m] = id;
                        stack.push(m);
                    }
                }
            }
        }
        depth.push(d);
    }
    let deep = |c: usize| label[c] != NONE && depth[label[c] as usize] > max_depth;
    if how == PitRemoval::Fill {
        let v: Vec<f32> = (0..w * h)
            .map(|c| {
                if label[c] == NONE || deep(c) {
                    z[c]
                } else {
                    fz[c]
                }
            })
            .collect();
        return Grid::from_vec(w, h, v);
    }
    // Breach with the deep depressions as extra outlets: a channel from a
    // shallow pit ends where it reaches one (the water pools there), and
    // none starts inside one. Their cells are restored (a carve may lower
    // the outlet cell it ends on).
    let mut mask: Vec<bool> = (0..w * h).map(deep).collect();
    if let Some(m) = sinks {
        for (o, &s) in mask.iter_mut().zip(m.data()) {
            *o |= s;
        }
    }
    let mut out = remove_pits(g, how, Some(&Grid::from_vec(w, h, mask)?))?;
    for (c, v) in out.data_mut().iter_mut().enumerate() {
        if deep(c) {
            *v = z[c];
        }
    }
    Ok(out)
}

/// Root mean square of the exemplar's finest detail band: `g` minus its
/// Burt & Adelson REDUCE expanded back to full size (the first level of a
/// Laplacian pyramid), over cells where both are valid; 0 when none is.
/// It measures the relief the finest synthesis level adds on top of the
/// coarser levels' shape, hence the depth of the closed contours that
/// averaging those details can make.
pub fn detail_rms(g: &Grid<f32>) -> f32 {
    let coarse = super::pyramid::reduce(g);
    let up = super::pyramid::expand(&coarse, g.width(), g.height());
    let (mut s, mut n) = (0f64, 0u64);
    for (&a, &b) in g.data().iter().zip(up.data()) {
        let d = (a - b) as f64;
        if d.is_finite() {
            s += d * d;
            n += 1;
        }
    }
    if n == 0 {
        0.0
    } else {
        (s / n as f64).sqrt() as f32
    }
}

/// Make `g` drain *strictly* with a physical gradient: every cell that is
/// not on the border (nor a `sinks` cell) ends at least `step` above some
/// neighbour. Priority-Flood+ε (Barnes, Lehman & Mulla 2014, Alg. 3) with a
/// physical increment `step` instead of one ULP: cells are taken lowest
/// first from the outlets; a neighbour reached from `c` is raised to
/// `z(c) + step` when it is lower than that. On a surface without
/// depressions (the output of [`remove_pits`]) this turns the flats that
/// fill and breach leave (filled lakes, flat carved channels) into ramps
/// that fall `step` per cell towards their outlet, and raises other terrain
/// only where it falls by less than `step` per cell. Why: the finer level
/// expands this surface into its target, and patches matched to a target
/// with flats average into small pits; ramps make them match draining
/// shapes. Ties are broken by cell index (deterministic). `step <= 0`
/// returns `g` unchanged; NaN cells are left alone and act as outlets.
/// Errors for an infinite or NaN `step`.
pub fn drain_strictly(g: &Grid<f32>, step: f32, sinks: Option<&Grid<bool>>) -> Result<Grid<f32>> {
    if !step.is_finite() {
        return Err(crate::error::Error::invalid(format!(
            "drain step {step} must be a finite rise per cell"
        )));
    }
    if step <= 0.0 {
        return Ok(g.clone());
    }
    let (w, h) = (g.width(), g.height());
    let mut z = g.data().to_vec();
    let n = w * h;
    let mut done = vec![false; n];
    let mut open: BinaryHeap<Reverse<(u32, usize)>> = BinaryHeap::new();
    // order key of an f32 (monotone for finite values)
    let key = |v: f32| {
        let b = v.to_bits();
        if b >> 31 == 1 {
            !b
        } else {
            b | 0x8000_0000
        }
    };
    for c in 0..n {
        let (x, y) = (c % w, c / w);
        let edge = x == 0 || y == 0 || x + 1 == w || y + 1 == h;
        let sink = sinks.is_some_and(|m| m.data()[c]);
        if !z[c].is_finite() {
            done[c] = true;
            continue;
        }
        let nan_next = (y.saturating_sub(1)..(y + 2).min(h))
            .any(|ny| (x.saturating_sub(1)..(x + 2).min(w)).any(|nx| !z[ny * w + nx].is_finite()));
        if edge || sink || nan_next {
            done[c] = true;
            open.push(Reverse((key(z[c]), c)));
        }
    }
    while let Some(Reverse((_, c))) = open.pop() {
        let (x, y) = (c % w, c / w);
        let floor = z[c] + step;
        for ny in y.saturating_sub(1)..(y + 2).min(h) {
            for nx in x.saturating_sub(1)..(x + 2).min(w) {
                let m = ny * w + nx;
                if done[m] {
                    continue;
                }
                done[m] = true;
                if z[m] < floor {
                    z[m] = floor;
                }
                open.push(Reverse((key(z[m]), m)));
            }
        }
    }
    Grid::from_vec(w, h, z)
}

/// Depressions of a DEM, measured against its Priority-Flood fill.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DepressionStats {
    /// Connected (8-neighbour) regions of cells the fill raises.
    pub count: usize,
    /// Cells the fill raises.
    pub cells: usize,
    /// Σ (filled − z) · cell area (DEM units × area units).
    pub volume: f64,
    /// Depressions whose deepest cell is at least `min_depth` deep.
    pub deep: usize,
}

/// Count and measure the depressions of `g` (border = outlet, NaN = nodata);
/// `deep` counts those at least `min_depth` deep.
pub fn depression_stats(g: &Grid<f32>, cell_area: f64, min_depth: f32) -> Result<DepressionStats> {
    let f = fill(g)?;
    let d = crate::hydro::depressions::depressions(g, &f, &vec![cell_area; g.height()], min_depth);
    Ok(DepressionStats {
        count: d.count,
        cells: d.cells,
        volume: d.volume,
        deep: d.deep,
    })
}
