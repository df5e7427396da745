//! Edits of a synthesised divide tree followed by regeneration (Argudo,
//! Galin, Peytavie, Paris, Gain & Guérin 2019, "Orometry-based terrain
//! analysis and synthesis", ACM TOG 38(6), §7 "authoring": the user inserts,
//! moves and removes peaks, saddles and ridges, and the tree is completed
//! again so that it stays a valid divide tree).
//!
//! An edit file is JSON:
//! ```json
//! {"format": "orogen-tree-edits", "version": 1, "edits": [
//!   {"op": "move_peak", "peak": 3, "x": 1250.0, "y": 800.0},
//!   {"op": "set_peak", "peak": 3, "elevation": 2400.0},
//!   {"op": "insert_peak", "x": 5000.0, "y": 4200.0, "elevation": 1900.0},
//!   {"op": "delete_peak", "peak": 7},
//!   {"op": "move_saddle", "saddle": 2, "x": 900.0, "y": 950.0},
//!   {"op": "set_saddle", "saddle": 2, "elevation": 1500.0},
//!   {"op": "delete_ridge", "saddle": 5}
//! ]}
//! ```
//! Coordinates are the tree JSON's: metres from the top-left corner, x east,
//! y down. Indices are those of the tree the edits apply to; inserted peaks
//! are numbered after its last peak, in the order inserted.
//!
//! Regeneration, in order: (1) the parts left by deleted ridges and the
//! inserted peaks are joined by the Delaunay minimum spanning tree of
//! [`ridge_tree_with`] that keeps every surviving ridge and never re-creates
//! a deleted one; (2) each new ridge gets a saddle at its midpoint whose
//! elevation is the lower end minus the median prominence of the input tree;
//! ridges of a moved peak get their saddle re-centred (unless the saddle was
//! moved too); (3) saddles left at or above their lower peak (a peak was
//! lowered or a saddle set too high by an edit of a peak) are lowered just
//! below it; a saddle the user set above its lower peak is an error; (4) a
//! peak whose prominence fell below the tree's threshold gets its key saddle
//! lowered to the threshold (not a saddle the user set).

use super::assign::{owners, PROMINENCE_MARGIN};
use super::tree_synth::{ridge_tree_with, SynthPeak, SynthSaddle, SynthTree};
use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// One edit (see the module documentation for the JSON form).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "op", rename_all = "snake_case", deny_unknown_fields)]
pub enum TreeEdit {
    MovePeak { peak: usize, x: f64, y: f64 },
    SetPeak { peak: usize, elevation: f64 },
    InsertPeak { x: f64, y: f64, elevation: f64 },
    DeletePeak { peak: usize },
    MoveSaddle { saddle: usize, x: f64, y: f64 },
    SetSaddle { saddle: usize, elevation: f64 },
    DeleteRidge { saddle: usize },
}

/// An edit file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TreeEdits {
    /// Always "orogen-tree-edits".
    pub format: String,
    pub version: u32,
    pub edits: Vec<TreeEdit>,
}

/// Largest edit file read.
const MAX_EDIT_BYTES: u64 = 64 << 20;

impl TreeEdits {
    /// Edits from a list.
    pub fn new(edits: Vec<TreeEdit>) -> TreeEdits {
        TreeEdits {
            format: "orogen-tree-edits".into(),
            version: 1,
            edits,
        }
    }

    /// Load an edit file (size-checked before reading).
    pub fn load(path: &Path) -> Result<TreeEdits> {
        let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
        if meta.len() > MAX_EDIT_BYTES {
            return Err(Error::too_large(path, "an edit file over 64 MiB"));
        }
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let e: TreeEdits = serde_json::from_str(&text).map_err(|e| {
            Error::corrupt(
                path,
                format!("not an orogen-tree-edits file (see `orogen synth from-tree --help`): {e}"),
            )
        })?;
        if e.format != "orogen-tree-edits" || e.version != 1 {
            return Err(Error::corrupt(
                path,
                format!(
                    "edit file format {:?} version {}; expected orogen-tree-edits 1",
                    e.format, e.version
                ),
            ));
        }
        Ok(e)
    }
}

/// Apply `edits` to `tree` and regenerate (see the module documentation).
/// Errors name the edit (0-based) and what is wrong.
pub fn apply_edits(tree: &SynthTree, edits: &TreeEdits) -> Result<SynthTree> {
    tree.validate()?;
    let cell = tree.cell;
    let (wm, hm) = (tree.width as f64 * cell, tree.height as f64 * cell);
    let inside =
        |x: f64, y: f64| x.is_finite() && y.is_finite() && x >= 0.0 && y >= 0.0 && x < wm && y < hm;
    let mut peaks: Vec<Option<SynthPeak>> = tree.peaks.iter().cloned().map(Some).collect();
    let mut saddles: Vec<Option<SynthSaddle>> = tree.saddles.iter().cloned().map(Some).collect();
    let mut user_set = vec![false; saddles.len()];
    let mut user_moved = vec![false; saddles.len()];
    let mut moved_peak = vec![false; peaks.len()];
    let mut forbidden: Vec<(usize, usize)> = Vec::new();
    let bad = |k: usize, msg: String| Error::invalid(format!("edit {k}: {msg}"));
    for (k, ed) in edits.edits.iter().enumerate() {
        match *ed {
            TreeEdit::MovePeak { peak, x, y } => {
                if !inside(x, y) {
                    return Err(bad(
                        k,
                        format!("({x}, {y}) m is outside the {wm} x {hm} m domain"),
                    ));
                }
                let p =
                    live_peak(&mut peaks, peak).ok_or_else(|| bad(k, format!("no peak {peak}")))?;
                p.x = x;
                p.y = y;
                p.fixed = true;
                moved_peak[peak] = true;
            }
            TreeEdit::SetPeak { peak, elevation } => {
                if !(elevation.is_finite() && elevation > 0.0) {
                    return Err(bad(
                        k,
                        "a peak's elevation must be a number above 0 m".into(),
                    ));
                }
                let p =
                    live_peak(&mut peaks, peak).ok_or_else(|| bad(k, format!("no peak {peak}")))?;
                p.elevation = elevation;
                p.fixed = true;
            }
            TreeEdit::InsertPeak { x, y, elevation } => {
                if !inside(x, y) {
                    return Err(bad(
                        k,
                        format!("({x}, {y}) m is outside the {wm} x {hm} m domain"),
                    ));
                }
                if !(elevation.is_finite() && elevation > 0.0) {
                    return Err(bad(
                        k,
                        "a peak's elevation must be a number above 0 m".into(),
                    ));
                }
                peaks.push(Some(SynthPeak {
                    x,
                    y,
                    elevation,
                    fixed: true,
                }));
                moved_peak.push(false);
            }
            TreeEdit::DeletePeak { peak } => {
                if live_peak(&mut peaks, peak).is_none() {
                    return Err(bad(k, format!("no peak {peak}")));
                }
                // Neighbours reconnect to the highest of them through the
                // saddles they had; the ridge to that one goes.
                let nbrs: Vec<(usize, usize)> = saddles
                    .iter()
                    .enumerate()
                    .filter_map(|(s, v)| {
                        let v = v.as_ref()?;
                        if v.peaks[0] == peak {
                            Some((s, v.peaks[1]))
                        } else if v.peaks[1] == peak {
                            Some((s, v.peaks[0]))
                        } else {
                            None
                        }
                    })
                    .collect();
                let elev = |i: usize| peaks[i].as_ref().map(|p| p.elevation).unwrap_or(0.0);
                if let Some(&(k0, hub)) = nbrs
                    .iter()
                    .max_by(|a, b| elev(a.1).total_cmp(&elev(b.1)).then(b.1.cmp(&a.1)))
                {
                    for &(s, nb) in &nbrs {
                        if s != k0 {
                            if let Some(v) = saddles[s].as_mut() {
                                v.peaks = [nb, hub];
                            }
                        }
                    }
                    saddles[k0] = None;
                }
                peaks[peak] = None;
            }
            TreeEdit::MoveSaddle { saddle, x, y } => {
                if !inside(x, y) {
                    return Err(bad(
                        k,
                        format!("({x}, {y}) m is outside the {wm} x {hm} m domain"),
                    ));
                }
                let s = saddles
                    .get_mut(saddle)
                    .and_then(|s| s.as_mut())
                    .ok_or_else(|| bad(k, format!("no saddle {saddle}")))?;
                s.x = x;
                s.y = y;
                user_moved[saddle] = true;
            }
            TreeEdit::SetSaddle { saddle, elevation } => {
                if !(elevation.is_finite() && elevation >= 0.0) {
                    return Err(bad(k, "a saddle's elevation must be a number ≥ 0 m".into()));
                }
                let s = saddles
                    .get_mut(saddle)
                    .and_then(|s| s.as_mut())
                    .ok_or_else(|| bad(k, format!("no saddle {saddle}")))?;
                s.elevation = elevation;
                user_set[saddle] = true;
            }
            TreeEdit::DeleteRidge { saddle } => {
                let s = saddles
                    .get_mut(saddle)
                    .and_then(|s| s.take())
                    .ok_or_else(|| bad(k, format!("no saddle {saddle}")))?;
                forbidden.push((s.peaks[0], s.peaks[1]));
            }
        }
    }
    // Compact the peaks.
    let mut new_id = vec![usize::MAX; peaks.len()];
    let mut out_peaks = Vec::with_capacity(peaks.len());
    let mut was_moved = Vec::with_capacity(peaks.len());
    for (i, p) in peaks.into_iter().enumerate() {
        if let Some(p) = p {
            new_id[i] = out_peaks.len();
            out_peaks.push(p);
            was_moved.push(moved_peak[i]);
        }
    }
    if out_peaks.is_empty() {
        return Err(Error::invalid("the edits deleted every peak"));
    }
    let mut kept: Vec<(SynthSaddle, bool, bool)> = Vec::new();
    for (s, v) in saddles.into_iter().enumerate() {
        if let Some(mut v) = v {
            v.peaks = [new_id[v.peaks[0]], new_id[v.peaks[1]]];
            kept.push((v, user_set[s], user_moved[s]));
        }
    }
    let forbidden: Vec<(usize, usize)> = forbidden
        .into_iter()
        .filter(|&(a, b)| new_id[a] != usize::MAX && new_id[b] != usize::MAX)
        .map(|(a, b)| (new_id[a], new_id[b]))
        .collect();
    let forced: Vec<(usize, usize)> = kept.iter().map(|k| (k.0.peaks[0], k.0.peaks[1])).collect();
    let edges = ridge_tree_with(&out_peaks, 2, &forced, &forbidden)?;
    // Median prominence of the input tree's non-root peaks.
    let mut prom = tree.prominences();
    let root = tree
        .peaks
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.elevation.total_cmp(&b.1.elevation).then(b.0.cmp(&a.0)))
        .map(|p| p.0)
        .unwrap_or(0);
    prom.remove(root);
    prom.sort_by(|a, b| a.total_cmp(b));
    let median = prom
        .get(prom.len() / 2)
        .copied()
        .unwrap_or(tree.min_prominence)
        .max(tree.min_prominence);
    let snap =
        |v: f64, nmax: usize| ((v / cell).floor().clamp(0.0, nmax as f64 - 1.0) + 0.5) * cell;
    let below = |lo: f64| lo - (0.01 * lo).clamp(0.0, 1.0).max(0.01);
    let mut out_saddles = Vec::with_capacity(edges.len());
    let mut pinned = Vec::with_capacity(edges.len());
    for (e, &(i, j)) in edges.iter().enumerate() {
        let (a, b) = (&out_peaks[i], &out_peaks[j]);
        let lo = a.elevation.min(b.elevation);
        let mid = (
            snap(0.5 * (a.x + b.x), tree.width),
            snap(0.5 * (a.y + b.y), tree.height),
        );
        if let Some((s, set, moved)) = kept.get(e) {
            let mut s = s.clone();
            if (was_moved[i] || was_moved[j]) && !moved {
                (s.x, s.y) = mid;
            }
            if s.elevation >= lo {
                if *set {
                    return Err(Error::invalid(format!(
                        "a saddle set to {} m lies at or above the lower of its peaks ({lo} m); set it lower",
                        s.elevation
                    )));
                }
                s.elevation = below(lo).max(0.0);
            }
            pinned.push(*set);
            out_saddles.push(s);
        } else {
            out_saddles.push(SynthSaddle {
                x: mid.0,
                y: mid.1,
                elevation: (lo - median).clamp(0.0, below(lo).max(0.0)),
                peaks: [i, j],
            });
            pinned.push(false);
        }
    }
    // Threshold repair (monotone: lowering saddles never lowers another
    // peak's prominence).
    let hp: Vec<f64> = out_peaks.iter().map(|p| p.elevation).collect();
    let mut hs: Vec<f64> = out_saddles.iter().map(|s| s.elevation).collect();
    let thr = tree.min_prominence;
    for _ in 0..64 {
        let own = owners(&hp, &edges, &hs);
        let mut changed = false;
        for (e, &o) in own.iter().enumerate() {
            if !pinned[e] && hp[o] - hs[e] < thr * PROMINENCE_MARGIN * (1.0 - 1e-9) && hs[e] > 0.0 {
                hs[e] = (hp[o] - thr * PROMINENCE_MARGIN).max(0.0);
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    for (s, v) in out_saddles.iter_mut().zip(&hs) {
        s.elevation = *v;
    }
    let t = SynthTree {
        peaks: out_peaks,
        saddles: out_saddles,
        ..tree.clone()
    };
    t.validate()?;
    Ok(t)
}

fn live_peak(peaks: &mut [Option<SynthPeak>], i: usize) -> Option<&mut SynthPeak> {
    peaks.get_mut(i).and_then(|p| p.as_mut())
}
