//! One tile of a metric pass ([`super::MultiMetric`]): the input view and
//! the products shared by the metrics of the pass, each computed once per
//! tile: the quadric coefficients per radius (all curvatures and quadric
//! landforms of one radius), one summed-area table of values, counts and
//! squares (stdev, variance, NTPI, Weiss landforms, disk windows at any
//! radius), one field of fixed-point unit normals (roughness at any radius),
//! and groups of outputs one scan yields together (openness and sky view
//! from one horizon scan per rays; geomorphon classes and patterns).

use super::neighbourhood::{walk_3x3, EdgeMode};
use super::quadric::{wood_fit, Quadric};
use super::registry::{metric, MetricKind, Needs};
use super::roughness::{normal_field, NormalField};
use super::spec::Resolved;
use super::windowed::Sat;
use crate::error::{Error, Result};
use crate::raster::{Grid, TileView};

/// Key of a group of outputs one scan computes together: the family's name
/// and the parameters the scan depends on.
pub type GroupKey = (&'static str, usize, u64, u64);

struct Group {
    key: GroupKey,
    /// One grid per kind of the group present in the pass.
    grids: Vec<(MetricKind, Grid<f32>)>,
    /// Metrics of the pass in the group that have not taken their output.
    left: usize,
}

/// A tile of the pass with its shared products.
pub struct Tile<'a> {
    /// The step's inputs (the DEM view first).
    pub inputs: &'a [TileView<f32>],
    /// The DEM's tile view (core + halo).
    pub view: &'a TileView<f32>,
    /// The input's path, for error messages.
    pub path: &'a str,
    /// Every metric of the pass, in output order.
    pub metrics: &'a [Resolved],
    quads: Vec<(usize, Grid<Quadric>)>,
    sat: Option<(usize, Sat)>,
    normals: Option<(usize, NormalField)>,
    /// Scratch lines of the running max/min (relief).
    pub g1: Vec<f64>,
    pub g2: Vec<f64>,
    groups: Vec<Group>,
}

impl<'a> Tile<'a> {
    /// The tile of `inputs` with the products `metrics` need.
    pub fn new(
        inputs: &'a [TileView<f32>],
        path: &'a str,
        metrics: &'a [Resolved],
    ) -> Result<Tile<'a>> {
        let view = inputs
            .first()
            .ok_or_else(|| Error::invalid("metrics need one input"))?;
        let (cw, ch) = (view.core.w, view.core.h);
        let needs: Vec<Needs> = metrics
            .iter()
            .map(|m| metric(m.spec.kind).needs(m))
            .collect();
        // Quadric coefficients per radius (Evans 3x3 for radius 1, Wood's
        // n x n fit beyond).
        let mut quads: Vec<(usize, Grid<Quadric>)> = Vec::new();
        for r in needs.iter().filter_map(|n| n.quadric) {
            if quads.iter().any(|q| q.0 == r) {
                continue;
            }
            let mut g = Grid::new(cw, ch, Quadric::NAN);
            if r == 1 {
                walk_3x3(view, &mut g, EdgeMode::Nodata, Quadric::NAN, Quadric::fit);
            } else {
                wood_fit(view, r, &mut g);
            }
            quads.push((r, g));
        }
        // One SAT over core + the largest SAT radius.
        let sat = match needs.iter().filter_map(|n| n.sat).map(|s| s.0).max() {
            Some(r) => {
                let vals = region(view, r);
                let squares = needs.iter().any(|n| n.sat.is_some_and(|s| s.1));
                Some((r, Sat::new(&vals, cw + 2 * r, ch + 2 * r, squares, path)?))
            }
            None => None,
        };
        // Unit normals for roughness.
        let normals = needs
            .iter()
            .filter_map(|n| n.normals)
            .max()
            .map(|r| (r, normal_field(view, r)));
        Ok(Tile {
            inputs,
            view,
            path,
            metrics,
            quads,
            sat,
            normals,
            g1: Vec::new(),
            g2: Vec::new(),
            groups: Vec::new(),
        })
    }

    /// The quadric coefficients at radius `r` (declared in [`Needs::quadric`]).
    pub fn quadric(&self, r: usize) -> Result<&Grid<Quadric>> {
        self.quads
            .iter()
            .find(|q| q.0 == r)
            .map(|q| &q.1)
            .ok_or_else(|| Error::invalid("metrics: quadric table missing"))
    }

    /// The summed-area table and its radius (declared in [`Needs::sat`]).
    pub fn sat(&self) -> Result<(usize, &Sat)> {
        self.sat
            .as_ref()
            .map(|(r, s)| (*r, s))
            .ok_or_else(|| Error::invalid("metrics: summed-area table missing"))
    }

    /// The unit normals and their radius (declared in [`Needs::normals`]).
    pub fn normals(&self) -> Result<(usize, &NormalField)> {
        self.normals
            .as_ref()
            .map(|(r, f)| (*r, f))
            .ok_or_else(|| Error::invalid("metrics: normal field missing"))
    }

    /// Write the output of `m` from the group `key` into `o`. The first
    /// member of the pass to ask computes the group: `compute` gets the
    /// distinct kinds of the members (every metric of the pass for which
    /// `member` holds), in order of first appearance, and returns one grid
    /// per kind. A group is dropped once every member has taken its output.
    pub fn grouped(
        &mut self,
        key: GroupKey,
        m: &Resolved,
        member: impl Fn(&Resolved) -> bool,
        compute: impl FnOnce(&TileView<f32>, &[MetricKind]) -> Vec<Grid<f32>>,
        o: &mut Grid<f32>,
    ) {
        let i = match self.groups.iter().position(|g| g.key == key) {
            Some(i) => i,
            None => {
                let mut kinds: Vec<MetricKind> = Vec::new();
                let mut left = 0;
                for n in self.metrics.iter().filter(|n| member(n)) {
                    left += 1;
                    if !kinds.contains(&n.spec.kind) {
                        kinds.push(n.spec.kind);
                    }
                }
                let grids = compute(self.view, &kinds);
                self.groups.push(Group {
                    key,
                    grids: kinds.into_iter().zip(grids).collect(),
                    left,
                });
                self.groups.len() - 1
            }
        };
        let g = &mut self.groups[i];
        if let Some((_, grid)) = g.grids.iter().find(|(k, _)| *k == m.spec.kind) {
            o.data_mut().copy_from_slice(grid.data());
        }
        g.left = g.left.saturating_sub(1);
        if g.left == 0 {
            self.groups.swap_remove(i);
        }
    }
}

/// The core plus `r` cells on each side of `view`, as f64 (NaN = nodata).
pub fn region(view: &TileView<f32>, r: usize) -> Vec<f64> {
    let (h, gw) = (view.halo, view.grid.width());
    let (w, hh) = (view.core.w + 2 * r, view.core.h + 2 * r);
    let mut v = Vec::with_capacity(w * hh);
    for y in 0..hh {
        let start = (y + h - r) * gw + h - r;
        v.extend(view.grid.data()[start..start + w].iter().map(|&z| z as f64));
    }
    v
}

/// Cells of the core of a `tile x tile` tile plus `r` cells on each side
/// and one more row and column (scratch-memory estimates).
pub fn region_cells(tile: usize, r: usize) -> u64 {
    ((tile + 2 * r + 1) * (tile + 2 * r + 1)) as u64
}
