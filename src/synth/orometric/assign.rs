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
use crate::raster::UnionFind;

/// Saddles per assignment block.
pub const BLOCK: usize = 128;

/// Every non-root peak of a synthesised tree clears its threshold by this
/// factor: a raster stores f32 elevations, and a peak at exactly the
/// threshold reads a few hundredths of a millimetre under it (Dallas profile,
/// 600² round trips, seeds 11 and 15: 4.99998 m at a 5 m threshold;
/// docs/design/orometric-synthesis.md#ridge-clearance-clearancers).
pub const PROMINENCE_MARGIN: f64 = 1.001;

/// Owner (index of the peak whose key saddle it is) of each saddle, by the
/// descending sweep. Peaks `h`; saddle e joins `edges[e]` at `hs[e]`. Ties:
/// the lower peak index counts as higher; equal saddles in index order.
pub fn owners(h: &[f64], edges: &[(usize, usize)], hs: &[f64]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..edges.len()).collect();
    order.sort_by(|&a, &b| sweep_cmp(hs, a, b));
    owners_in_order(h, edges, &order)
}

/// Order of the descending sweep: higher saddles first, ties by index.
fn sweep_cmp(hs: &[f64], a: usize, b: usize) -> std::cmp::Ordering {
    hs[b].total_cmp(&hs[a]).then(a.cmp(&b))
}

/// [`owners`] with the saddles already in sweep order.
fn owners_in_order(h: &[f64], edges: &[(usize, usize)], order: &[usize]) -> Vec<usize> {
    let mut uf = UnionFind::<usize>::new(h.len());
    let mut top: Vec<usize> = (0..h.len()).collect();
    let higher = |a: usize, b: usize| h[a] > h[b] || (h[a] == h[b] && a < b);
    let mut own = vec![0usize; edges.len()];
    for &e in order {
        let (a, b) = edges[e];
        let (ra, rb) = (uf.find(a), uf.find(b));
        let (ta, tb) = (top[ra], top[rb]);
        let (win, lose) = if higher(ta, tb) { (ta, tb) } else { (tb, ta) };
        own[e] = lose;
        uf.union_into(ra, rb);
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

/// The alternation of [`assign_saddles_grouped`]: `iterations` prominence/dominance
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

/// The fixed data of the grouped saddle problem shared by
/// [`assign_pass_grouped`], [`assign_saddles_grouped`] and
/// [`refine_histograms`] (the saddle heights `hs` are passed apart: they
/// are what the three change).
#[derive(Debug, Clone, Copy)]
pub struct SaddleProblem<'a> {
    /// Peak elevations.
    pub h: &'a [f64],
    /// The two peaks each saddle joins (ridges of the divide tree).
    pub edges: &'a [(usize, usize)],
    /// Upper bound of each saddle's height, h_max(K).
    pub hmax: &'a [f64],
    /// Lower bound of every saddle's height.
    pub floor: f64,
    /// Target group (index into `groups`) of each peak.
    pub group_of_peak: &'a [usize],
    /// Target distributions per group.
    pub groups: &'a [GroupTargets<'a>],
    /// Prominence threshold per group (a peak owning a saddle keeps it).
    pub thresholds: &'a [f64],
    /// Saddles whose height is fixed (pasted fragments).
    pub pinned: &'a [bool],
}

impl SaddleProblem<'_> {
    /// Every per-saddle, per-peak and per-group slice has its length and
    /// every group index exists (`what` names the caller in the error).
    fn check(&self, hs: &[f64], what: &str) -> Result<()> {
        let m = self.edges.len();
        if self.hmax.len() != m
            || hs.len() != m
            || self.pinned.len() != m
            || self.group_of_peak.len() != self.h.len()
            || self.thresholds.len() != self.groups.len()
        {
            return Err(Error::invalid(format!(
                "{what}: bounds, pins, groups and saddles differ in number"
            )));
        }
        if self.group_of_peak.iter().any(|&g| g >= self.groups.len()) {
            return Err(Error::invalid(format!(
                "{what}: a peak belongs to no target group"
            )));
        }
        if self
            .edges
            .iter()
            .any(|&(a, b)| a >= self.h.len() || b >= self.h.len())
        {
            return Err(Error::invalid(format!("{what}: a ridge names no peak")));
        }
        Ok(())
    }
}

/// One assignment pass: every free saddle gets a target of the matched kind,
/// drawn from the group of its owner, and `hs` is set accordingly, clamped to
/// `[floor, hmax[e]]`. Saddle e (not `pinned`) whose owner is in group
/// `group_of_peak[own[e]]` gets one of the lowest `k_g` of `k_g + r_g`
/// stratified samples of that group's histogram (`k_g` = its number of
/// free saddles this pass, `r_g` = its peaks owning no saddle: the root,
/// whose value is the top of the histogram), by blocked linear assignment
/// (see the module doc).
pub fn assign_pass_grouped(pb: &SaddleProblem, hs: &mut [f64], kind: Target) -> Result<()> {
    pb.check(hs, "saddle assignment")?;
    let SaddleProblem {
        h,
        edges,
        hmax,
        floor,
        group_of_peak,
        groups,
        pinned,
        ..
    } = *pb;
    let n = edges.len();
    let own = owners(h, edges, hs);
    // Peaks owning a saddle (all but the root); pinned saddles' owners keep
    // their values and count as owning.
    let mut owns = vec![false; h.len()];
    own.iter().for_each(|&o| owns[o] = true);
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
        // Stratified samples (ascending) of the group's whole population:
        // the profile counts every peak, including the highest, whose
        // prominence is its elevation and which owns no saddle. Its
        // share (the top samples) is left out, else a saddle is also given
        // that root value and the tree gets a second peak of dominance ≈ 1.
        let unowned = group_of_peak
            .iter()
            .enumerate()
            .filter(|&(i, &gp)| gp == g && !owns[i])
            .count();
        let mut st = hist.stratified(se.len() + unowned);
        st.truncate(se.len());
        solve_blocks(&se, &st, &value, hmax, floor, hs, &mut new_hs, &mut cost)?;
    }
    hs.copy_from_slice(&new_hs);
    Ok(())
}

/// Alternate prominence and dominance passes of [`assign_pass_grouped`]
/// `iterations` times, ending with three prominence passes (per-group
/// targets, pinned saddles kept).
pub fn assign_saddles_grouped(pb: &SaddleProblem, hs: &mut [f64], iterations: usize) -> Result<()> {
    schedule(hs, iterations, |hs, kind| assign_pass_grouped(pb, hs, kind))
}

/// Histogram state of one target group during [`refine_histograms`]: bin
/// counts of its peaks' prominences and dominances against its profile.
struct GroupState<'a> {
    t: GroupTargets<'a>,
    n: usize,
    cp: Vec<i64>,
    cd: Vec<i64>,
}

impl GroupState<'_> {
    /// ½ Σ |c_b / n − p_b| for both histograms (the measure of
    /// [`super::profile::Hist::error_against`]).
    fn tv(&self) -> (f64, f64) {
        let one = |c: &[i64], p: &[f64]| {
            if self.n == 0 {
                return 0.0;
            }
            let n = self.n as f64;
            0.5 * c
                .iter()
                .zip(p)
                .map(|(&k, &q)| (k as f64 / n - q).abs())
                .sum::<f64>()
        };
        (
            one(&self.cp, &self.t.prominence.p),
            one(&self.cd, &self.t.dominance.p),
        )
    }
}

/// Scratch and result of one evaluation of the saddle heights.
struct Eval {
    own: Vec<usize>,
    /// Σ over groups of n_g · (TV_π + TV_δ) / n.
    score: f64,
    /// Peaks (not the root) below their group's prominence threshold.
    violations: usize,
}

/// Evaluate `hs`: owners, per-group bin counts and the objective.
/// `order`: the saddles in sweep order for `hs`.
fn evaluate(
    h: &[f64],
    edges: &[(usize, usize)],
    hs: &[f64],
    order: &[usize],
    group_of_peak: &[usize],
    st: &mut [GroupState],
    thresholds: &[f64],
) -> Eval {
    use crate::oro::stats::bin_of;
    let own = owners_in_order(h, edges, order);
    for g in st.iter_mut() {
        g.cp.iter_mut().for_each(|c| *c = 0);
        g.cd.iter_mut().for_each(|c| *c = 0);
    }
    // Prominence per peak: the root keeps its elevation (sea level).
    let mut prom = h.to_vec();
    for (e, &o) in own.iter().enumerate() {
        prom[o] = h[o] - hs[e];
    }
    let mut violations = 0;
    let mut is_owner = vec![false; h.len()];
    own.iter().for_each(|&o| is_owner[o] = true);
    for (i, &p) in prom.iter().enumerate() {
        let g = &mut st[group_of_peak[i]];
        if is_owner[i] && p < thresholds[group_of_peak[i]] * PROMINENCE_MARGIN * (1.0 - 1e-9) {
            violations += 1;
        }
        if let Some(b) = bin_of(&g.t.prominence.edges, p) {
            g.cp[b] += 1;
        }
        let d = if h[i] > 0.0 { p / h[i] } else { 0.0 };
        if let Some(b) = bin_of(&g.t.dominance.edges, d) {
            g.cd[b] += 1;
        }
    }
    let n = h.len().max(1) as f64;
    let score = st
        .iter()
        .map(|g| {
            let (a, b) = g.tv();
            g.n as f64 * (a + b) / n
        })
        .sum();
    Eval {
        own,
        score,
        violations,
    }
}

/// Largest number of owner evaluations [`refine_histograms`] spends in all
/// (each is O(n log n)): the search is bounded on very large trees.
const REFINE_WORK: usize = 20_000_000;

/// Final local search on the saddle heights that lowers the histogram
/// distance of the tree's prominences and dominances to their targets
/// directly (a departure from Argudo et al. 2019, §5.3, whose assignment
/// alternates M_π and M_δ a few times: one assignment matches one marginal
/// exactly but then the other one is off by several percent, and owners
/// changed by the last pass leave bins over- or under-full).
///
/// Moves, on saddles not `pinned`, drawn with a seeded generator:
/// (a) exchange the prominences of the owners of two saddles of one group
/// (the prominence histogram stays, the dominance one changes);
/// (b) give the owner of a saddle in an over-full bin a value drawn
/// uniformly in an under-full bin (of the prominence or the dominance
/// histogram, whichever is farther from its target), chosen with
/// probability ∝ its deficit;
/// (c) give it a value drawn from the target histogram.
/// In (b), raising a saddle also raises the saddles on the tree path from
/// its owner to it that lie below the new height (a chain move): alone, the
/// raised saddle would stop being the owner's key saddle and the owner's
/// value would not change.
/// A move is kept when it adds no peak below its group's threshold and does
/// not raise Σ_g n_g (TV_π + TV_δ) / n (hill climbing with sideways moves;
/// TV = ½ Σ |p − q| on the profile's bins, the measure of the tests).
/// Simulated annealing (e^(−Δ/T), T from 0.5/n down to 0) was tried and
/// ended worse on both real profiles for the same number of steps.
/// Heights stay in `[floor, hmax[e]]`. Returns the final objective.
pub fn refine_histograms(pb: &SaddleProblem, hs: &mut [f64], seed: u64) -> Result<f64> {
    pb.check(hs, "saddle refinement")?;
    let SaddleProblem {
        h,
        edges,
        hmax,
        floor,
        group_of_peak,
        groups,
        thresholds,
        pinned,
    } = *pb;
    let m = edges.len();
    if hs.iter().chain(h).any(|v| !v.is_finite()) {
        return Err(Error::invalid(
            "saddle refinement: an elevation is not finite",
        ));
    }
    let free: Vec<usize> = (0..m).filter(|&e| !pinned[e]).collect();
    if free.is_empty() {
        return Ok(0.0);
    }
    let mut st: Vec<GroupState> = groups
        .iter()
        .enumerate()
        .map(|(g, t)| GroupState {
            t: *t,
            n: group_of_peak.iter().filter(|&&x| x == g).count(),
            cp: vec![0; t.prominence.p.len()],
            cd: vec![0; t.dominance.p.len()],
        })
        .collect();
    // Sweep order of the kept heights, updated per move by moving only the
    // changed saddles (O(m) instead of a sort).
    let mut order: Vec<usize> = (0..m).collect();
    order.sort_by(|&a, &b| sweep_cmp(hs, a, b));
    let mut order2 = order.clone();
    let mut moved = vec![false; m];
    let mut cur = evaluate(h, edges, hs, &order, group_of_peak, &mut st, thresholds);
    // Counts of trials; swapped with `st` when a trial is kept.
    let mut st2: Vec<GroupState> = st
        .iter()
        .map(|g| GroupState {
            t: g.t,
            n: g.n,
            cp: g.cp.clone(),
            cd: g.cd.clone(),
        })
        .collect();
    let steps = (150 * m).min(REFINE_WORK / m.max(1)).max(1);
    let mut best_hs = hs.to_vec();
    let mut best = (cur.violations, cur.score);
    let mut rng = crate::oro::stats::SplitMix64(seed ^ 0x7265_6669_6e65);
    let clamp = |e: usize, v: f64| v.clamp(floor, hmax[e].max(floor));
    let mut trial = hs.to_vec();
    // Tree adjacency (peak → (neighbour, saddle)) for the chain moves.
    let mut adj: Vec<Vec<(usize, usize)>> = vec![Vec::new(); h.len()];
    for (e, &(a, b)) in edges.iter().enumerate() {
        adj[a].push((b, e));
        adj[b].push((a, e));
    }
    let mut changed: Vec<(usize, f64)> = Vec::new();
    let mut prev: Vec<(usize, usize)> = vec![(usize::MAX, usize::MAX); h.len()];
    let mut queue: Vec<usize> = Vec::new();
    for _ in 0..steps {
        if cur.score <= 0.0 {
            break;
        }
        let e1 = free[rng.below(free.len() as u64) as usize];
        let o1 = cur.own[e1];
        let g = group_of_peak[o1];
        let p1 = h[o1] - hs[e1];
        let kind = rng.below(3);
        changed.clear();
        match kind {
            0 => {
                // Exchange with another free saddle of the same group.
                let e2 = free[rng.below(free.len() as u64) as usize];
                let o2 = cur.own[e2];
                if e2 == e1 || group_of_peak[o2] != g {
                    continue;
                }
                let p2 = h[o2] - hs[e2];
                changed.push((e1, clamp(e1, h[o1] - p2)));
                changed.push((e2, clamp(e2, h[o2] - p1)));
            }
            _ => {
                // Re-evaluate the group's bins and pick the histogram farther
                // from its target.
                let gs = &st[g];
                let (tp, td) = gs.tv();
                let use_dom = td > tp;
                let (hist, counts) = if use_dom {
                    (gs.t.dominance, &gs.cd)
                } else {
                    (gs.t.prominence, &gs.cp)
                };
                let value = if kind == 1 {
                    // Targeted: only move out of an over-full bin, into an
                    // under-full one (∝ deficit).
                    let nn = gs.n.max(1) as f64;
                    let cur_v = if use_dom { p1 / h[o1] } else { p1 };
                    let Some(b) = crate::oro::stats::bin_of(&hist.edges, cur_v) else {
                        continue;
                    };
                    if counts[b] as f64 / nn <= hist.p[b] {
                        continue;
                    }
                    let deficit: Vec<f64> = counts
                        .iter()
                        .zip(&hist.p)
                        .map(|(&c, &q)| (q - c as f64 / nn).max(0.0))
                        .collect();
                    let tot: f64 = deficit.iter().sum();
                    if tot <= 0.0 {
                        continue;
                    }
                    let mut r = rng.unit() * tot;
                    let mut k = deficit.len() - 1;
                    for (i, &d) in deficit.iter().enumerate() {
                        if r < d {
                            k = i;
                            break;
                        }
                        r -= d;
                    }
                    hist.edges[k] + rng.unit() * (hist.edges[k + 1] - hist.edges[k])
                } else {
                    hist.quantile(rng.unit())
                };
                let p = if use_dom { value * h[o1] } else { value };
                let z = clamp(e1, h[o1] - p);
                if kind == 1 && z > hs[e1] {
                    // Chain move: raising the key saddle only lowers the
                    // owner's prominence if every saddle on the tree path
                    // from the owner to it stays above; raise those below
                    // to just above z too (else the owner's key saddle
                    // becomes one of them and nothing changes for it).
                    prev.iter_mut().for_each(|v| *v = (usize::MAX, usize::MAX));
                    queue.clear();
                    queue.push(o1);
                    prev[o1] = (o1, usize::MAX);
                    let (a, b) = edges[e1];
                    let mut end = usize::MAX;
                    let mut qi = 0;
                    while qi < queue.len() {
                        let x = queue[qi];
                        qi += 1;
                        if x == a || x == b {
                            end = x;
                            break;
                        }
                        for &(y, f) in &adj[x] {
                            if f != e1 && prev[y].0 == usize::MAX {
                                prev[y] = (x, f);
                                queue.push(y);
                            }
                        }
                    }
                    let mut ok = end != usize::MAX;
                    let mut x = end;
                    while ok && x != o1 {
                        let (px, f) = prev[x];
                        if !pinned[f] && hs[f] <= z {
                            let v = z + 0.01;
                            if v > hmax[f] {
                                ok = false;
                            }
                            changed.push((f, v));
                        } else if pinned[f] && hs[f] <= z {
                            ok = false;
                        }
                        x = px;
                    }
                    if !ok {
                        continue;
                    }
                }
                changed.push((e1, z));
            }
        }
        for &(e, v) in &changed {
            trial[e] = v;
        }
        changed.iter().for_each(|c| moved[c.0] = true);
        order2.clear();
        order2.extend(order.iter().copied().filter(|&e| !moved[e]));
        changed.iter().for_each(|c| moved[c.0] = false);
        for &(e, _) in &changed {
            let at = order2.partition_point(|&x| sweep_cmp(&trial, x, e).is_lt());
            order2.insert(at, e);
        }
        let next = evaluate(
            h,
            edges,
            &trial,
            &order2,
            group_of_peak,
            &mut st2,
            thresholds,
        );
        let keep = next.violations < cur.violations
            || (next.violations == cur.violations && next.score <= cur.score);
        if keep {
            for &(e, v) in &changed {
                hs[e] = v;
            }
            cur = next;
            std::mem::swap(&mut st, &mut st2);
            std::mem::swap(&mut order, &mut order2);
            if (cur.violations, cur.score) < best {
                best = (cur.violations, cur.score);
                best_hs.copy_from_slice(hs);
            }
        } else {
            for &(e, _) in &changed {
                trial[e] = hs[e];
            }
        }
    }
    hs.copy_from_slice(&best_hs);
    Ok(best.1)
}
