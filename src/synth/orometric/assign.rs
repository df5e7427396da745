//! Saddle elevations by optimal assignment (Argudo et al. 2019, "Orometry-based
//! terrain analysis and synthesis", ACM TOG 38(6), §5.3): target prominences
//! and dominances sampled from the profile are assigned to the saddles of a
//! divide tree by solving linear assignment problems on the cost matrices
//! M_π and M_δ, alternating the two targets for a few iterations, subject to
//! `floor ≤ h′(K) ≤ h_max(K)`.
//!
//! In a divide tree with n peaks and n − 1 saddles every saddle is the key
//! saddle of exactly one peak: its *owner*, the lower of the two highest
//! peaks it joins in the descending sweep (Kirmse & de Ferranti 2017). With
//! owners fixed, giving saddle e the target prominence π_k means
//! h′(e) = h(owner(e)) − π_k (dominance δ_k: h′(e) = h(owner)(1 − δ_k)). The
//! cost of the pair (e, k) is the squared violation of the bounds (weighted
//! 10⁴) plus the squared change from the current saddle elevation, so the
//! assignment keeps every target feasible and moves saddles as little as
//! possible (which preserves the owners and what the other target achieved).
//! The problems are solved by the `lsap` crate (shortest augmenting path,
//! Crouse 2016) in blocks of [`BLOCK`] saddles and targets of neighbouring
//! rank (both sorted), so the cost stays O(n · BLOCK²).

use crate::error::{Error, Result};

/// Saddles per assignment block.
pub const BLOCK: usize = 128;

/// Owner (index of the peak whose key saddle it is) of each saddle, by the
/// descending sweep. Peaks `h`; saddle e joins `edges[e]` at `hs[e]`. Ties:
/// the lower peak index counts as higher; equal saddles in index order.
pub fn owners(h: &[f64], edges: &[(usize, usize)], hs: &[f64]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..edges.len()).collect();
    order.sort_by(|&a, &b| hs[b].total_cmp(&hs[a]).then(a.cmp(&b)));
    let mut parent: Vec<usize> = (0..h.len()).collect();
    let mut top: Vec<usize> = (0..h.len()).collect();
    fn find(p: &mut [usize], mut x: usize) -> usize {
        while p[x] != x {
            p[x] = p[p[x]];
            x = p[x];
        }
        x
    }
    let higher = |a: usize, b: usize| h[a] > h[b] || (h[a] == h[b] && a < b);
    let mut own = vec![0usize; edges.len()];
    for e in order {
        let (a, b) = edges[e];
        let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
        let (ta, tb) = (top[ra], top[rb]);
        let (win, lose) = if higher(ta, tb) { (ta, tb) } else { (tb, ta) };
        own[e] = lose;
        parent[rb] = ra;
        top[ra] = win;
    }
    own
}

/// Prominence of every peak of a tree (the root: its elevation, as under the
/// sea-level convention).
pub fn prominences(h: &[f64], edges: &[(usize, usize)], hs: &[f64]) -> Vec<f64> {
    let mut p: Vec<f64> = h.to_vec();
    for (e, o) in owners(h, edges, hs).into_iter().enumerate() {
        p[o] = h[o] - hs[e];
    }
    p
}

/// The saddle height that gives the owner (height `ho`) the target `t`.
fn target_height(kind: Target, ho: f64, t: f64) -> f64 {
    match kind {
        Target::Prominence => ho - t,
        Target::Dominance => ho * (1.0 - t),
    }
}

/// The owner's current prominence or dominance with its saddle at `hsad`.
fn current_value(kind: Target, ho: f64, hsad: f64) -> f64 {
    match kind {
        Target::Prominence => ho - hsad,
        Target::Dominance => {
            if ho > 0.0 {
                (ho - hsad) / ho
            } else {
                0.0
            }
        }
    }
}

/// Match saddles `se` (sorted by current value) to targets `st` (ascending)
/// in blocks of [`BLOCK`] by linear assignment; cost = 10⁴·(bound
/// violation)² + (change)². Writes the clamped heights into `new_hs`.
#[allow(clippy::too_many_arguments)]
fn solve_blocks(
    se: &[usize],
    st: &[f64],
    value: &dyn Fn(usize, f64) -> f64,
    hmax: &[f64],
    floor: f64,
    hs: &[f64],
    new_hs: &mut [f64],
    cost: &mut Vec<f64>,
) -> Result<()> {
    for (blk_e, blk_t) in se.chunks(BLOCK).zip(st.chunks(BLOCK)) {
        let m = blk_e.len();
        cost.clear();
        for &e in blk_e {
            for &t in blk_t {
                let v = value(e, t);
                let c = v.clamp(floor, hmax[e].max(floor));
                let d = v - hs[e];
                cost.push(1e4 * (v - c) * (v - c) + d * d);
            }
        }
        if cost.iter().any(|c| !c.is_finite()) {
            return Err(Error::invalid(
                "saddle assignment: a cost is not finite (NaN or infinite elevation)",
            ));
        }
        let (rows, cols) = lsap::solve(m, m, cost, false)
            .map_err(|e| Error::invalid(format!("saddle assignment failed: {e:?}")))?;
        for (r, c) in rows.into_iter().zip(cols) {
            let e = blk_e[r];
            new_hs[e] = value(e, blk_t[c]).clamp(floor, hmax[e].max(floor));
        }
    }
    Ok(())
}

/// Which target a pass matches.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Target {
    Prominence,
    Dominance,
}

/// One assignment pass: give every saddle one of `targets` (len = saddles)
/// and set `hs` accordingly, clamped to `[floor, hmax[e]]`.
pub fn assign_pass(
    h: &[f64],
    edges: &[(usize, usize)],
    hmax: &[f64],
    floor: f64,
    hs: &mut [f64],
    targets: &[f64],
    kind: Target,
) -> Result<()> {
    let n = edges.len();
    if targets.len() != n || hmax.len() != n || hs.len() != n {
        return Err(Error::invalid(
            "saddle assignment: targets, bounds and saddles differ in number",
        ));
    }
    let own = owners(h, edges, hs);
    let value = |e: usize, t: f64| target_height(kind, h[own[e]], t);
    // Current value of the target quantity per saddle, to sort by rank.
    let current = |e: usize| current_value(kind, h[own[e]], hs[e]);
    let mut se: Vec<usize> = (0..n).collect();
    se.sort_by(|&a, &b| current(a).total_cmp(&current(b)).then(a.cmp(&b)));
    let mut st: Vec<f64> = targets.to_vec();
    st.sort_by(|a, b| a.total_cmp(b));
    let mut new_hs = hs.to_vec();
    let mut cost = Vec::with_capacity(BLOCK * BLOCK);
    solve_blocks(&se, &st, &value, hmax, floor, hs, &mut new_hs, &mut cost)?;
    hs.copy_from_slice(&new_hs);
    Ok(())
}

/// Alternate prominence and dominance passes `iterations` times, ending with
/// three prominence passes.
#[allow(clippy::too_many_arguments)]
pub fn assign_saddles(
    h: &[f64],
    edges: &[(usize, usize)],
    hmax: &[f64],
    floor: f64,
    hs: &mut [f64],
    prominence: &[f64],
    dominance: &[f64],
    iterations: usize,
) -> Result<()> {
    schedule(hs, iterations, |hs, kind| {
        let targets = match kind {
            Target::Prominence => prominence,
            Target::Dominance => dominance,
        };
        assign_pass(h, edges, hmax, floor, hs, targets, kind)
    })
}

/// The alternation both assignments use: `iterations` prominence/dominance
/// pairs, then prominence last, repeated (a pass can change owners; the next
/// one re-targets the saddles whose owner changed).
fn schedule(
    hs: &mut [f64],
    iterations: usize,
    mut pass: impl FnMut(&mut [f64], Target) -> Result<()>,
) -> Result<()> {
    for _ in 0..iterations {
        pass(hs, Target::Prominence)?;
        pass(hs, Target::Dominance)?;
    }
    for _ in 0..3 {
        pass(hs, Target::Prominence)?;
    }
    Ok(())
}

/// Target distributions of one group of peaks (a region of the type map
/// C_T, or the whole domain).
#[derive(Debug, Clone, Copy)]
pub struct GroupTargets<'a> {
    pub prominence: &'a super::profile::Hist,
    pub dominance: &'a super::profile::Hist,
}

/// One pass of [`assign_pass`] where each saddle draws its target from the
/// group of its owner: saddle e (not `pinned`) whose owner is in group
/// `group_of_peak[own[e]]` gets one of the `k_g` stratified samples of that
/// group's histogram (`k_g` = its number of free saddles this pass), by the
/// same blocked assignment. With one group and nothing pinned this is
/// [`assign_pass`] with `targets` = the stratified samples.
#[allow(clippy::too_many_arguments)]
pub fn assign_pass_grouped(
    h: &[f64],
    edges: &[(usize, usize)],
    hmax: &[f64],
    floor: f64,
    hs: &mut [f64],
    group_of_peak: &[usize],
    groups: &[GroupTargets],
    pinned: &[bool],
    kind: Target,
) -> Result<()> {
    let n = edges.len();
    if hmax.len() != n || hs.len() != n || pinned.len() != n || group_of_peak.len() != h.len() {
        return Err(Error::invalid(
            "saddle assignment: bounds, pins, groups and saddles differ in number",
        ));
    }
    if group_of_peak.iter().any(|&g| g >= groups.len()) {
        return Err(Error::invalid(
            "saddle assignment: a peak belongs to no target group",
        ));
    }
    let own = owners(h, edges, hs);
    let value = |e: usize, t: f64| target_height(kind, h[own[e]], t);
    let current = |e: usize| current_value(kind, h[own[e]], hs[e]);
    let mut new_hs = hs.to_vec();
    let mut cost = Vec::with_capacity(BLOCK * BLOCK);
    for (g, gt) in groups.iter().enumerate() {
        let mut se: Vec<usize> = (0..n)
            .filter(|&e| !pinned[e] && group_of_peak[own[e]] == g)
            .collect();
        if se.is_empty() {
            continue;
        }
        se.sort_by(|&a, &b| current(a).total_cmp(&current(b)).then(a.cmp(&b)));
        let hist = match kind {
            Target::Prominence => gt.prominence,
            Target::Dominance => gt.dominance,
        };
        // Stratified samples are ascending already.
        let st = hist.stratified(se.len());
        solve_blocks(&se, &st, &value, hmax, floor, hs, &mut new_hs, &mut cost)?;
    }
    hs.copy_from_slice(&new_hs);
    Ok(())
}

/// [`assign_saddles`] with per-group targets and pinned saddles (see
/// [`assign_pass_grouped`]).
#[allow(clippy::too_many_arguments)]
pub fn assign_saddles_grouped(
    h: &[f64],
    edges: &[(usize, usize)],
    hmax: &[f64],
    floor: f64,
    hs: &mut [f64],
    group_of_peak: &[usize],
    groups: &[GroupTargets],
    pinned: &[bool],
    iterations: usize,
) -> Result<()> {
    let pass = |hs: &mut [f64], kind| {
        assign_pass_grouped(
            h,
            edges,
            hmax,
            floor,
            hs,
            group_of_peak,
            groups,
            pinned,
            kind,
        )
    };
    schedule(hs, iterations, pass)
}
