//! The divide tree: peaks joined through their key saddles to their
//! prominence parents, built by one union-find sweep of the flat regions in
//! decreasing elevation.
//!
//! Method: the join (merge) tree of the superlevel sets, i.e. lower the water
//! level from the top; each new region either starts a component (a peak),
//! extends one, or joins several (a saddle). When components meet, the one
//! whose highest peak is highest survives and every other component's highest
//! peak gets this region as its key saddle, the survivor's peak as its
//! prominence parent, and prominence = peak − saddle. This is the prominence
//! definition used by Kirmse & de Ferranti 2017 ("Calculating the prominence
//! and isolation of every mountain in the world", Progress in Physical
//! Geography 41(6)), computed with the descending union-find sweep of
//! join-tree construction (Carr, Snoeyink & Axen 2003, "Computing contour
//! trees in all dimensions"); Argudo et al. 2019 ("Orometry-based terrain
//! analysis and synthesis", ACM TOG 38(6)) §4 use the same peak–saddle–peak
//! structure.
//!
//! Ties: regions of equal elevation are processed in *decreasing* id order
//! (reverse row-major order of their first cell). Of two equal-height peaks,
//! the one processed first counts as higher, so of equal twin summits the
//! southern (north-up DEMs; on one row, the eastern) one is the higher and
//! the other gets the key saddle. This is the choice akirmse/mountains made
//! on all six twin pairs of the two SRTM reference tiles.
//!
//! Edges here run from a peak to its *prominence parent* (the highest peak of
//! the component that absorbed it), not to the ridge-adjacent peak of
//! Kirmse's divide tree; both trees give the same prominences.
//!
//! The sea ([`EdgeConvention::SeaLevel`]) is one more union-find node that
//! wins every merge: it joins when the level drops to 0, taking every
//! component that touched the edge or nodata above 0, and then every region
//! at z ≤ 0 that touches them, at that region's level. A peak beaten by the
//! sea gets elevation − the level of that merge (0, or z < 0 for land below
//! sea level), never a negative prominence.

use super::regions::{Regions, N8};
use crate::error::{Error, Result};
use crate::raster::{Grid, UnionFind};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// What lies beyond the DEM edge and in nodata (NaN) cells.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum EdgeConvention {
    /// Kirmse & de Ferranti 2017: the edge and nodata are sea at elevation
    /// 0, and the sea counts as higher than any peak. Read on the superlevel
    /// sets {z ≥ c}: the sea belongs to them for c ≤ 0, so a component meets
    /// it at level min(0, L), L the highest level at which the component
    /// touches the edge or nodata. A peak whose component meets the sea
    /// before it meets higher ground (an island top) has no key saddle and
    /// prominence = elevation − min(0, L); the others keep elevation − key
    /// col. Prominence is ≥ 0 for any elevation sign.
    ///
    /// Above sea level this is exactly Kirmse's rule (L ≥ 0: prominence =
    /// elevation). It departs from their tool, which never sees land below
    /// sea level touching the edge, where land below 0 reaches the edge or
    /// nodata (the Dead Sea at −430 m, polders, coastal DEM artefacts): the
    /// sea is met at L, not at 0, so an island top at −350 m whose land
    /// reaches the edge at −420 m has prominence 70 (not −350, which a
    /// threshold would drop), and a hill of 50 m whose land reaches the edge
    /// only through a basin at −30 m has 80. A summit at or below 0 that
    /// itself touches the edge or nodata is a peak of prominence 0 (the
    /// outside never makes a region a non-peak); a region with no valid
    /// neighbour is a peak only above 0. The sea joins the sweep when the
    /// level drops to 0 (before cells at 0), also when no cell is ≥ 0.
    #[default]
    SeaLevel,
    /// Nothing is assumed about the outside: the sweep sees only valid cells.
    /// The highest peak of each 8-connected area of valid cells has no key
    /// saddle and prominence = its elevation − the lowest cell of that area
    /// (the deepest drop the DEM proves). For the other peaks the value is an
    /// upper bound of the true prominence: terrain beyond the edge can only
    /// offer a higher key saddle.
    Unknown,
}

/// Nearest strictly higher ground of a peak.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Isolation {
    /// Distance in metres (cell units without georeferencing).
    pub distance_m: f64,
    /// Column and row of the nearest strictly higher cell.
    pub col: u32,
    pub row: u32,
    /// Direction from the peak, degrees clockwise from north (from "up" =
    /// decreasing row without georeferencing).
    pub bearing_deg: f64,
}

/// A peak: a flat region strictly higher than all its valid neighbours,
/// with at least one valid neighbour; the edge and nodata never count as
/// higher. Under [`EdgeConvention::SeaLevel`] a region with no valid
/// neighbour above 0 is an island peak too (an all-flat DEM at 100 m is one
/// peak; at 0 or −100 m it has none, as under `Unknown`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Peak {
    /// Representative cell (first cell of the summit plateau in row-major order).
    pub col: u32,
    pub row: u32,
    pub elevation: f32,
    /// Elevation − key saddle elevation; without one, see [`EdgeConvention`]
    /// (≥ 0 in either convention).
    pub prominence: f64,
    /// Index into [`DivideTree::saddles`] of the key saddle.
    pub key_saddle: Option<usize>,
    /// Index into [`DivideTree::peaks`] of the prominence parent.
    pub parent: Option<usize>,
    /// The summit plateau touches the DEM edge or nodata.
    pub on_edge: bool,
    /// Filled by [`DivideTree::compute_isolation`].
    pub isolation: Option<Isolation>,
}

impl Peak {
    /// Prominence / elevation (Jurgalski's dominance), None for elevations
    /// ≤ 0: the ratio measures the share of the height above sea level that
    /// is the peak's own, and a summit at or below sea level has no such
    /// height (the ratio would be negative or infinite). It exceeds 1 when
    /// the key col, or the level where an island top meets the sea, is below
    /// 0.
    pub fn dominance(&self) -> Option<f64> {
        (self.elevation > 0.0).then(|| self.prominence / self.elevation as f64)
    }
}

/// A saddle of the tree (one per key saddle; a degenerate saddle joining k
/// components appears k − 1 times at the same cell).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Saddle {
    /// Representative cell of the saddle's flat region.
    pub col: u32,
    pub row: u32,
    pub elevation: f32,
}

/// Peaks, saddles and edges peak –key saddle– parent. Serialisable, editable
/// (edit the vectors, then [`DivideTree::validate`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DivideTree {
    pub width: usize,
    pub height: usize,
    pub convention: EdgeConvention,
    /// Sorted by decreasing elevation (ties: sweep order) when built.
    pub peaks: Vec<Peak>,
    pub saddles: Vec<Saddle>,
}

/// Critical points of a DEM (representative cells as (col, row)).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CriticalPoints {
    /// The peaks of [`DivideTree::peaks`] (see [`Peak`] for the convention).
    pub peaks: Vec<(u32, u32)>,
    /// Join saddles: regions where ≥ 2 components of the descending sweep
    /// meet (those of the sweep, without the sea). Split saddles (which join
    /// basins, seen by an ascending sweep) are not listed.
    pub saddles: Vec<(u32, u32)>,
    /// Flat regions strictly lower than all 8 neighbours, not touching the
    /// edge or nodata.
    pub pits: Vec<(u32, u32)>,
}

/// Union-find over regions plus one virtual sea node.
struct Uf {
    sets: UnionFind<u32>,
    /// Union by rank (Tarjan 1975) keeps finds short on huge flats.
    rank: Vec<u8>,
}

impl Uf {
    fn find(&mut self, x: u32) -> u32 {
        self.sets.find(x)
    }
}

/// Owner of a component's top: a real peak (index into the peak list) or the sea.
const SEA_TOP: u32 = u32::MAX;

/// Build the full (unpruned) divide tree and the critical points of `dem`
/// (NaN = nodata).
pub fn build(dem: &Grid<f32>, convention: EdgeConvention) -> Result<(DivideTree, CriticalPoints)> {
    let reg = Regions::new(dem)?;
    let nreg = reg.len();
    let w = reg.width;
    let h = reg.height;
    // Sweep order: (elevation, id) decreasing, sorted as packed u64 keys
    // (order-preserving bits of the f32 above the id) instead of an indirect
    // comparison sort.
    let mut keys: Vec<u64> = reg
        .elev
        .iter()
        .enumerate()
        .map(|(i, &z)| {
            let b = (z + 0.0).to_bits(); // -0.0 sorts as 0.0
            let ord = if b >> 31 == 1 { !b } else { b | 0x8000_0000 };
            ((ord as u64) << 32) | i as u64
        })
        .collect();
    keys.sort_unstable();
    let order: Vec<u32> = keys.iter().rev().map(|&k| k as u32).collect();
    drop(keys);
    let sea = nreg as u32;
    let mut uf = Uf {
        sets: UnionFind::new(nreg + 1),
        rank: vec![0; nreg + 1],
    };
    // Per component root: top peak index (or SEA_TOP), lowest elevation seen.
    let mut top = vec![SEA_TOP; nreg + 1];
    let mut lowest = vec![f32::INFINITY; nreg + 1];
    let data = dem.data();
    let mut peaks: Vec<Peak> = Vec::new();
    let mut saddles: Vec<Saddle> = Vec::new();
    let mut crit = CriticalPoints::default();
    let mut sea_active = false;
    let mut roots: Vec<u32> = Vec::with_capacity(8);
    let pos = |c: u32| (c % w as u32, c / w as u32);

    // Merge the components `roots`: every loser (all but the one with the
    // highest top peak) gets its key saddle. Returns the new union-find root.
    #[allow(clippy::too_many_arguments)]
    fn merge(
        uf: &mut Uf,
        top: &mut [u32],
        lowest: &mut [f32],
        peaks: &mut [Peak],
        saddles: &mut Vec<Saddle>,
        roots: &[u32],
        saddle: Option<Saddle>,
        level: f32,
    ) -> u32 {
        // Peak indices grow in sweep order, so the smallest index is the highest
        // peak; the sea (u32::MAX) is handled as higher than all.
        let rank = |t: u32| if t == SEA_TOP { -1i64 } else { t as i64 };
        let win = *roots
            .iter()
            .min_by_key(|&&r| rank(top[r as usize]))
            .expect("merge called with roots");
        let wtop = top[win as usize];
        // The union-find root is chosen by rank; the component's top peak is
        // carried in `top` independently of which element is the root.
        let mut root = roots[0];
        for &r in roots {
            if uf.rank[r as usize] > uf.rank[root as usize] {
                root = r;
            }
        }
        if roots
            .iter()
            .any(|&r| r != root && uf.rank[r as usize] == uf.rank[root as usize])
        {
            uf.rank[root as usize] = uf.rank[root as usize].saturating_add(1);
        }
        let mut low = lowest[win as usize];
        for &r in roots {
            low = low.min(lowest[r as usize]);
            if r != root {
                uf.sets.union_into(root, r);
            }
        }
        // Losers in the order of their top peaks (highest first), so the
        // saddles of a k-way saddle are pushed in an order that does not
        // depend on how the region's neighbours were scanned (the tiled
        // sweep reproduces it).
        let mut sorted: Vec<u32>;
        let losers: &[u32] = if roots.len() > 2 {
            sorted = roots.to_vec();
            sorted.sort_by_key(|&r| rank(top[r as usize]));
            &sorted
        } else {
            roots
        };
        for &r in losers {
            if r == win {
                continue;
            }
            if top[r as usize] == SEA_TOP {
                // A plateau with no valid neighbour: no peak to attach.
                continue;
            }
            let t = top[r as usize] as usize;
            let p = &mut peaks[t];
            if wtop == SEA_TOP {
                // The component reaches the sea here: at 0 (the sea event) or
                // at `level` < 0 where land below sea level meets the outside.
                p.prominence = p.elevation as f64 - level as f64;
            } else if let Some(s) = &saddle {
                p.prominence = p.elevation as f64 - s.elevation as f64;
                p.key_saddle = Some(saddles.len());
                p.parent = Some(wtop as usize);
                saddles.push(s.clone());
            }
        }
        lowest[root as usize] = low.min(level);
        top[root as usize] = wtop;
        root
    }

    // The sea joins at level 0: every finished component touching the edge
    // or nodata is absorbed by the sea; their top peaks become island
    // summits of prominence elevation − 0.
    #[allow(clippy::too_many_arguments)]
    fn sea_event(
        reg: &Regions,
        uf: &mut Uf,
        top: &mut [u32],
        lowest: &mut [f32],
        peaks: &mut [Peak],
        saddles: &mut Vec<Saddle>,
        sea: u32,
    ) {
        let mut roots = vec![sea];
        top[sea as usize] = SEA_TOP;
        lowest[sea as usize] = 0.0;
        // Regions above 0 are exactly the ones swept so far.
        for (r, (&z, &t)) in reg.elev.iter().zip(&reg.touches_outside).enumerate() {
            if z > 0.0 && t {
                roots.push(uf.find(r as u32));
            }
        }
        roots[1..].sort_unstable();
        roots.dedup();
        merge(uf, top, lowest, peaks, saddles, &roots, None, 0.0);
    }

    // After the last region, one step below every elevation (`None`): there
    // the sea joins if no region reached it.
    for r in order.iter().map(|&r| Some(r as usize)).chain([None]) {
        let z = r.map_or(f32::NEG_INFINITY, |r| reg.elev[r]);
        if convention == EdgeConvention::SeaLevel && !sea_active && z <= 0.0 {
            sea_active = true;
            sea_event(
                &reg,
                &mut uf,
                &mut top,
                &mut lowest,
                &mut peaks,
                &mut saddles,
                sea,
            );
        }
        let Some(r) = r else { break };
        roots.clear();
        let mut pit = true;
        let mut any_valid = false;
        let mut higher = false;
        for &c in reg.cells_of(r) {
            let (x, y) = ((c as usize % w) as i64, (c as usize / w) as i64);
            for (dx, dy) in N8 {
                let (nx, ny) = (x + dx, y + dy);
                // Neighbour states come from the DEM itself (spatially local):
                // higher = already swept, equal = this region, lower = later.
                let nz = if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                    f32::NAN
                } else {
                    data[ny as usize * w + nx as usize]
                };
                if nz.is_nan() {
                    pit = false;
                    if sea_active {
                        let s = uf.find(sea);
                        if !roots.contains(&s) {
                            roots.push(s);
                        }
                    }
                } else if nz < z {
                    // A lower neighbour: not a pit.
                    any_valid = true;
                    pit = false;
                } else if nz > z {
                    any_valid = true;
                    higher = true;
                    let s = uf.find(reg.label[ny as usize * w + nx as usize]);
                    if !roots.contains(&s) {
                        roots.push(s);
                    }
                }
            }
        }
        let rep = reg.rep(r);
        let (col, row) = pos(rep);
        if pit {
            crit.pits.push((col, row));
        }
        // A region with no higher valid neighbour is a peak if it has a
        // (lower) valid neighbour, or, under SeaLevel, if it lies above the
        // sea (z > 0: an island, even with no valid neighbour at all). The
        // outside never makes a region a non-peak: below 0 it is met at the
        // region's own level (see `EdgeConvention::SeaLevel`).
        let is_peak = !higher && (any_valid || (convention == EdgeConvention::SeaLevel && z > 0.0));
        if roots.is_empty() && !is_peak {
            // No valid neighbour (the whole DEM is flat, or a plateau
            // enclosed by nodata) and nothing shows it is higher than
            // anything: not a peak.
            top[r] = SEA_TOP;
            lowest[r] = z;
        } else if is_peak && !roots.is_empty() {
            // A summit at or below 0 touching the edge or nodata (the only
            // root is the sea): it meets the sea at its own level, so its
            // prominence is 0.
            debug_assert!(sea_active && z <= 0.0 && roots.len() == 1);
            crit.peaks.push((col, row));
            peaks.push(Peak {
                col,
                row,
                elevation: z,
                prominence: 0.0,
                key_saddle: None,
                parent: None,
                on_edge: reg.touches_outside[r],
                isolation: None,
            });
            top[r] = SEA_TOP;
            lowest[r] = z;
            uf.sets.union_into(roots[0], r as u32);
        } else if roots.is_empty() {
            top[r] = peaks.len() as u32;
            lowest[r] = z;
            crit.peaks.push((col, row));
            peaks.push(Peak {
                col,
                row,
                elevation: z,
                prominence: f64::NAN,
                key_saddle: None,
                parent: None,
                on_edge: reg.touches_outside[r],
                isolation: None,
            });
        } else {
            let joins_peaks = roots
                .iter()
                .filter(|&&x| top[x as usize] != SEA_TOP)
                .count();
            if joins_peaks >= 2 {
                crit.saddles.push((col, row));
            }
            let s = Saddle {
                col,
                row,
                elevation: z,
            };
            let win = merge(
                &mut uf,
                &mut top,
                &mut lowest,
                &mut peaks,
                &mut saddles,
                &roots,
                Some(s),
                z,
            );
            uf.sets.union_into(win, r as u32);
        }
    }
    // Remaining components (Unknown convention; SeaLevel leaves none).
    for r in 0..nreg {
        if uf.find(r as u32) == r as u32 && top[r] != SEA_TOP {
            let p = &mut peaks[top[r] as usize];
            if p.prominence.is_nan() {
                p.prominence = match convention {
                    EdgeConvention::SeaLevel => p.elevation as f64,
                    EdgeConvention::Unknown => p.elevation as f64 - lowest[r] as f64,
                };
            }
        }
    }
    let tree = DivideTree {
        width: w,
        height: h,
        convention,
        peaks,
        saddles,
    };
    Ok((tree, crit))
}

impl DivideTree {
    /// Check indices and acyclicity of an edited or loaded tree.
    pub fn validate(&self) -> Result<()> {
        let np = self.peaks.len();
        for (i, p) in self.peaks.iter().enumerate() {
            if let Some(s) = p.key_saddle {
                if s >= self.saddles.len() {
                    return Err(Error::invalid(format!(
                        "divide tree: peak {i} names saddle {s} of {}",
                        self.saddles.len()
                    )));
                }
            }
            if let Some(q) = p.parent {
                if q >= np || q == i {
                    return Err(Error::invalid(format!(
                        "divide tree: peak {i} has invalid parent {q} ({np} peaks)"
                    )));
                }
            }
            if p.col as usize >= self.width || p.row as usize >= self.height {
                return Err(Error::invalid(format!(
                    "divide tree: peak {i} at ({}, {}) outside the {} x {} grid",
                    p.col, p.row, self.width, self.height
                )));
            }
        }
        // Cycle check: 0 = unseen, 1 = on the current path, 2 = known acyclic.
        let mut state = vec![0u8; np];
        for i in 0..np {
            let mut path = Vec::new();
            let mut cur = Some(i);
            while let Some(c) = cur {
                match state[c] {
                    2 => break,
                    1 => {
                        return Err(Error::invalid(format!(
                            "divide tree: parent links of peak {c} form a cycle"
                        )))
                    }
                    _ => {}
                }
                state[c] = 1;
                path.push(c);
                cur = self.peaks[c].parent;
            }
            for c in path {
                state[c] = 2;
            }
        }
        Ok(())
    }

    /// The tree restricted to peaks with prominence ≥ `min_prominence`.
    ///
    /// A removed peak's key saddle goes with it; a kept peak whose parent was
    /// removed is re-attached to its nearest kept ancestor (in a tree built by
    /// the sweep that never happens: a parent is always more prominent than
    /// its children, since it is at least as high and its key saddle is at
    /// most as high, so the cut keeps whole sub-trees). Kept peaks keep their
    /// prominence and key saddle, which do not depend on smaller peaks.
    pub fn pruned(&self, min_prominence: f64) -> DivideTree {
        let np = self.peaks.len();
        let mut new_index = vec![usize::MAX; np];
        let mut peaks = Vec::new();
        for (i, p) in self.peaks.iter().enumerate() {
            if p.prominence >= min_prominence {
                new_index[i] = peaks.len();
                peaks.push(p.clone());
            }
        }
        let mut saddles = Vec::new();
        for p in peaks.iter_mut() {
            let mut anc = p.parent;
            let mut steps = 0;
            while let Some(a) = anc {
                if new_index[a] != usize::MAX || steps > np {
                    break;
                }
                anc = self.peaks[a].parent;
                steps += 1;
            }
            p.parent = anc.and_then(|a| (new_index[a] != usize::MAX).then(|| new_index[a]));
            if let Some(s) = p.key_saddle {
                p.key_saddle = Some(saddles.len());
                saddles.push(self.saddles[s].clone());
            }
        }
        DivideTree {
            width: self.width,
            height: self.height,
            convention: self.convention,
            peaks,
            saddles,
        }
    }

    /// Serialise to JSON (loads back identically with [`DivideTree::from_json`]).
    pub fn to_json(&self) -> String {
        serde_json::to_string(self).expect("divide tree serialises (no NaN keys)")
    }

    /// Parse and validate a tree written by [`DivideTree::to_json`].
    pub fn from_json(text: &str) -> Result<DivideTree> {
        let t: DivideTree = serde_json::from_str(text)
            .map_err(|e| Error::invalid(format!("divide tree JSON: {e}")))?;
        t.validate()?;
        Ok(t)
    }

    /// Write the tree as JSON to `path`.
    pub fn save_json(&self, path: &Path) -> Result<()> {
        crate::io::atomic::write_file_atomic(path, self.to_json().as_bytes())
    }

    /// Read a tree saved by [`DivideTree::save_json`].
    pub fn load_json(path: &Path) -> Result<DivideTree> {
        let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
        if meta.len() > (1 << 32) {
            return Err(Error::too_large(
                path,
                "divide tree JSON over 4 GiB; refusing to load it in memory",
            ));
        }
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let t: DivideTree = serde_json::from_str(&text).map_err(|e| {
            Error::corrupt(
                path,
                format!("not a divide tree JSON written by orogen: {e}"),
            )
        })?;
        t.validate()
            .map_err(|e| Error::corrupt(path, format!("inconsistent divide tree: {e}")))?;
        Ok(t)
    }
}
