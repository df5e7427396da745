//! The divide tree as an exact global pass across tiles: the same tree as
//! [`super::divide_tree`] (same peaks, representative cells, key saddles,
//! parents, prominences, saddle order) for DEMs that do not fit in memory.
//!
//! Method (Kirmse & de Ferranti 2017 merge per-tile divide trees through the
//! "runoffs" where ridges leave a tile; here the tile trees are contracted
//! join trees, as in the distributed contour-tree construction of Pascucci &
//! Cole-McLaughlin 2003, "Parallel computation of the topology of level
//! sets", and merged by one descending union-find sweep, Carr, Snoeyink &
//! Axen 2003):
//!
//! 1. **Plateaus** ([`PlateauStep`]): the in-memory sweep orders regions by
//!    (elevation, first cell in row-major order), and a flat region may span
//!    tiles. *map*: each tile labels the flat pieces touching its perimeter
//!    with their first cell; *reduce*: pieces equal in height and adjacent
//!    across a seam are joined (union-find), giving every perimeter cell the
//!    global representative of its region.
//! 2. **Tree** ([`TreeStep`], halo 1): *map*: each tile runs the descending
//!    sweep on its pieces (open pieces — those with a valid neighbour in
//!    another tile — keyed by their global representative) plus the sea
//!    node of [`EdgeConvention::SeaLevel`] at key (0, +∞). A component is
//!    *closed* while it holds no open piece and not the sea: its cells and
//!    all their neighbours lie in the tile, so the whole DEM sees the same
//!    component. A peak that loses at an interior region where every merging
//!    component is closed (or where the sea wins) is final: its key saddle,
//!    parent and prominence go straight into the summary. The rest becomes a
//!    contracted join tree: nodes are open pieces, the sea, tops of closed
//!    components when they open, and regions where ≥ 2 such branches meet;
//!    each node is linked to the last node of every component it joins. This
//!    keeps the connectivity of every superlevel set among the nodes, so the
//!    global sweep sees the same merges. Edges across seams are emitted from
//!    the halo (the higher cell's tile names both regions).
//!    *reduce*: the tile graphs are joined by region id (pieces of one region
//!    become one node) and swept once more in (elevation, id) order with the
//!    tie and sea rules of `tree.rs`; then all peaks are sorted as the
//!    in-memory sweep numbers them and the saddles as it pushes them.
//!
//!    The sea rule below sea level ([`EdgeConvention::SeaLevel`]): where the
//!    sea wins, at the sea node (z = 0) or at a region z ≤ 0 joined to the
//!    sea's component, a loser's prominence is its elevation − z, in the map
//!    (closed tops) and in the reduce alike. A region with no higher valid
//!    neighbour that joins only the sea is a summit of prominence 0; whether
//!    a region has a higher neighbour in another tile is known only from the
//!    halo, so every piece reports it (`TreeNode::higher`, or-ed over the
//!    pieces of a region as `outside` and `any_valid` are).
//!
//! With a prominence threshold ([`pruned_tree_tiled`]) the map drops final
//! peaks below it when pruning cannot need them, and does not turn a closed
//! top into a node when it is beaten at a saddle below the threshold: on the
//! Poland mosaic (1024-cell tiles, 30 m) ~3,500 nodes per tile instead of
//! ~25,000.
//!
//! Memory: a tile in flight holds its cells and ~40-60 bytes of scratch per
//! cell; the reduce holds all tile graphs (O(total perimeter)) and the final
//! peaks kept. Summaries are merged in one reduce (no hierarchical 2 x 2
//! merging, no contraction of seams that became interior).

mod plateau;
mod tree_step;
pub use plateau::{PlateauSolution, PlateauStep, PlateauSummary};
pub use tree_step::{FinalPeak, TreeNode, TreeStep, TreeSummary};

use super::tree::{DivideTree, EdgeConvention, Peak, Saddle};
use crate::error::{Error, Result};
use crate::exec::{Engine, Run};
use crate::raster::{RasterSource, TileLayout, TileView};
use std::collections::HashMap;

const NONE: u32 = u32::MAX;

/// Floats in summaries travel as their bit patterns: a JSON round trip of a
/// decimal float is not always exact, and the tree must be.
mod bits {
    use serde::{Deserialize, Deserializer, Serialize, Serializer};
    pub mod f32s {
        use super::*;
        pub fn serialize<S: Serializer>(v: &f32, s: S) -> Result<S::Ok, S::Error> {
            v.to_bits().serialize(s)
        }
        pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f32, D::Error> {
            u32::deserialize(d).map(f32::from_bits)
        }
    }
    pub mod f64s {
        use super::*;
        pub fn serialize<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
            v.to_bits().serialize(s)
        }
        pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
            u64::deserialize(d).map(f64::from_bits)
        }
    }
    pub mod saddle {
        use super::*;
        pub fn serialize<S: Serializer>(v: &Option<(u64, f32)>, s: S) -> Result<S::Ok, S::Error> {
            v.map(|(i, z)| (i, z.to_bits())).serialize(s)
        }
        pub fn deserialize<'de, D: Deserializer<'de>>(
            d: D,
        ) -> Result<Option<(u64, f32)>, D::Error> {
            Option::<(u64, u32)>::deserialize(d).map(|o| o.map(|(i, b)| (i, f32::from_bits(b))))
        }
    }
    pub mod f32vec {
        use super::*;
        pub fn serialize<S: Serializer>(v: &[f32], s: S) -> Result<S::Ok, S::Error> {
            s.collect_seq(v.iter().map(|z| z.to_bits()))
        }
        pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<f32>, D::Error> {
            Vec::<u32>::deserialize(d).map(|v| v.into_iter().map(f32::from_bits).collect())
        }
    }
}

/// Region id of the sea node.
pub const SEA_ID: u64 = u64::MAX;

/// Order-preserving bits of an elevation (−0.0 sorts as 0.0), as in `tree.rs`.
#[inline]
fn zkey(z: f32) -> u32 {
    let b = (z + 0.0).to_bits();
    if b >> 31 == 1 {
        !b
    } else {
        b | 0x8000_0000
    }
}

/// Sweep key of a region: (elevation, global id of its first cell). The sea
/// has key (0, +∞): after every region above 0, before every region at 0.
#[inline]
fn key(z: f32, gid: u64) -> (u32, u64) {
    (zkey(z), gid)
}

fn check_finite(z: f32, gx: i64, gy: i64) -> Result<()> {
    if z.is_infinite() {
        return Err(Error::invalid(format!(
            "orometry: cell ({gx}, {gy}) is {z}; elevations must be finite (use NaN for nodata)"
        )));
    }
    Ok(())
}

fn first_view<'v>(inputs: &'v [TileView<f32>], step: &str) -> Result<&'v TileView<f32>> {
    inputs
        .first()
        .ok_or_else(|| Error::invalid(format!("{step} needs one input (the DEM)")))
}

/// Sort peaks as the in-memory sweep numbers them ((elevation, id)
/// decreasing) and saddles as it pushes them (saddle key decreasing, then
/// loser peak order), and resolve parents from region ids to indices.
fn assemble(
    width: usize,
    height: usize,
    convention: EdgeConvention,
    mut recs: Vec<FinalPeak>,
    min_prominence: Option<f64>,
) -> Result<DivideTree> {
    recs.sort_unstable_by_key(|p| std::cmp::Reverse(key(p.z, p.id)));
    let w = width as u64;
    let mut index: HashMap<u64, usize> = HashMap::with_capacity(recs.len());
    for (i, p) in recs.iter().enumerate() {
        if index.insert(p.id, i).is_some() {
            return Err(Error::invalid(format!(
                "divide tree: region {} is a peak twice in the tile summaries",
                p.id
            )));
        }
        if p.prominence.is_nan() {
            return Err(Error::invalid(format!(
                "divide tree: peak {} was left without prominence",
                p.id
            )));
        }
    }
    let mut with_saddle: Vec<(std::cmp::Reverse<(u32, u64)>, usize)> = recs
        .iter()
        .enumerate()
        .filter_map(|(i, p)| {
            p.saddle
                .map(|(sid, sz)| (std::cmp::Reverse(key(sz, sid)), i))
        })
        .collect();
    with_saddle.sort_unstable();
    let mut saddle_of = vec![None; recs.len()];
    let mut saddles = Vec::with_capacity(with_saddle.len());
    for (k, &(_, i)) in with_saddle.iter().enumerate() {
        saddle_of[i] = Some(k);
        let (sid, sz) = recs[i].saddle.expect("filtered on saddle");
        saddles.push(Saddle {
            col: (sid % w) as u32,
            row: (sid / w) as u32,
            elevation: sz,
        });
    }
    let mut peaks = Vec::with_capacity(recs.len());
    for (i, p) in recs.iter().enumerate() {
        let parent = match (p.parent, min_prominence) {
            (None, _) => None,
            // A dropped parent (see `TreeStep::droppable`) only has children
            // that pruning at the same threshold removes as well.
            (Some(pid), Some(m)) if p.prominence < m && !index.contains_key(&pid) => None,
            (Some(pid), _) => Some(*index.get(&pid).ok_or_else(|| {
                Error::invalid(format!(
                    "divide tree: peak {} names parent {pid}, which is not a peak",
                    p.id
                ))
            })?),
        };
        peaks.push(Peak {
            col: (p.id % w) as u32,
            row: (p.id / w) as u32,
            elevation: p.z,
            prominence: p.prominence,
            key_saddle: saddle_of[i],
            parent,
            on_edge: p.on_edge,
            isolation: None,
        });
    }
    Ok(DivideTree {
        width,
        height,
        convention,
        peaks,
        saddles,
    })
}

fn tree_tiled<E: Engine>(
    src: &dyn RasterSource,
    convention: EdgeConvention,
    min_prominence: Option<f64>,
    tile: usize,
    engine: &E,
) -> Result<DivideTree> {
    let info = src.info();
    let layout = TileLayout::new(info.width, info.height, tile.max(1));
    if info.width == 0 || info.height == 0 {
        return Ok(DivideTree {
            width: info.width,
            height: info.height,
            convention,
            peaks: Vec::new(),
            saddles: Vec::new(),
        });
    }
    let plateaus = engine.run_global(&PlateauStep, Run::solution_only(&[src], layout))?;
    let step = TreeStep {
        convention,
        min_prominence,
        layout,
        plateaus: &plateaus,
    };
    let tree = engine.run_global(&step, Run::solution_only(&[src], layout))?;
    Ok(match min_prominence {
        Some(m) => tree.pruned(m),
        None => tree,
    })
}

/// The unpruned divide tree of `src` (read as f32, nodata = NaN) computed
/// tile by tile on `engine` with tiles of `tile` cells: equal to
/// [`super::divide_tree`] on the whole grid. Two passes over the tiles
/// (plateaus, then the tree).
pub fn divide_tree_tiled<E: Engine>(
    src: &dyn RasterSource,
    convention: EdgeConvention,
    tile: usize,
    engine: &E,
) -> Result<DivideTree> {
    tree_tiled(src, convention, None, tile, engine)
}

/// `divide_tree_tiled(..).pruned(min_prominence)`, without ever holding the
/// peaks pruning removes (most of them are dropped in the tiles).
pub fn pruned_tree_tiled<E: Engine>(
    src: &dyn RasterSource,
    convention: EdgeConvention,
    min_prominence: f64,
    tile: usize,
    engine: &E,
) -> Result<DivideTree> {
    if !min_prominence.is_finite() {
        return Err(Error::invalid(format!(
            "peaks: minimum prominence must be a finite number, got {min_prominence}"
        )));
    }
    tree_tiled(src, convention, Some(min_prominence), tile, engine)
}
