//! Ridges between peaks: the minimum spanning tree (Kruskal) of their
//! Delaunay triangulation with weights ‖Pi − Pj‖ / min(h_i, h_j)^ρ, ridges
//! kept verbatim between fixed peaks, the prominence pass of a peak's rank
//! and the ridge density that draws later passes to earlier ridges.

use super::SynthPeak;
use crate::error::Error;
use crate::error::Result;
use crate::raster::Grid;
use crate::raster::UnionFind;
use spade::DelaunayTriangulation;
use spade::HasPosition;
use spade::Point2;
use spade::Triangulation;

pub(super) struct Vtx {
    pub(super) p: Point2<f64>,
    pub(super) id: usize,
}

impl HasPosition for Vtx {
    type Scalar = f64;
    fn position(&self) -> Point2<f64> {
        self.p
    }
}

/// Ridges: Delaunay triangulation of the peaks, then its minimum spanning
/// tree with weights ‖Pi − Pj‖ / min(h_i, h_j)^ρ (Kruskal; ties by indices).
pub fn ridge_tree(peaks: &[SynthPeak], rho: u8) -> Result<Vec<(usize, usize)>> {
    ridge_tree_with(peaks, rho, &[], &[])
}

/// [`ridge_tree`] keeping the ridges `forced` (they come first in the
/// result, in their order; e.g. a pasted real fragment or the ridges an
/// edit left alone) and never using a pair in `forbidden` (a ridge the user
/// deleted). Errors when the forced ridges close a loop or when the
/// Delaunay edges left cannot connect every peak.
pub fn ridge_tree_with(
    peaks: &[SynthPeak],
    rho: u8,
    forced: &[(usize, usize)],
    forbidden: &[(usize, usize)],
) -> Result<Vec<(usize, usize)>> {
    if peaks.len() < 2 {
        return Ok(Vec::new());
    }
    let verts: Vec<Vtx> = peaks
        .iter()
        .enumerate()
        .map(|(id, p)| Vtx {
            p: Point2::new(p.x, p.y),
            id,
        })
        .collect();
    let tri: DelaunayTriangulation<Vtx> = DelaunayTriangulation::bulk_load(verts).map_err(|e| {
        Error::invalid(format!("Delaunay triangulation of the peaks failed: {e:?}"))
    })?;
    if tri.num_vertices() != peaks.len() {
        return Err(Error::invalid(
            "two peaks share a position; move one (each peak needs its own place)",
        ));
    }
    let mut edges: Vec<(f64, usize, usize)> = tri
        .undirected_edges()
        .map(|e| {
            let [a, b] = e.vertices();
            let (i, j) = (a.data().id.min(b.data().id), a.data().id.max(b.data().id));
            let d = (peaks[i].x - peaks[j].x).hypot(peaks[i].y - peaks[j].y);
            let hmin = peaks[i].elevation.min(peaks[j].elevation).max(1.0);
            (d / hmin.powi(rho as i32), i, j)
        })
        .collect();
    edges.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    let mut uf = UnionFind::<usize>::new(peaks.len());
    let mut out = Vec::with_capacity(peaks.len() - 1);
    for &(i, j) in forced {
        if i >= peaks.len() || j >= peaks.len() || i == j {
            return Err(Error::invalid(format!(
                "a kept ridge joins peaks {i} and {j}; it needs two different existing peaks"
            )));
        }
        if !uf.join(i, j) {
            return Err(Error::invalid(format!(
                "the kept ridges close a loop at peaks {i} and {j}; a divide tree has none"
            )));
        }
        out.push((i, j));
    }
    let banned = |i: usize, j: usize| {
        forbidden
            .iter()
            .any(|&(a, b)| (a == i && b == j) || (a == j && b == i))
    };
    for (_, i, j) in edges {
        if !forbidden.is_empty() && banned(i, j) {
            continue;
        }
        if uf.join(i, j) {
            out.push((i, j));
        }
    }
    if out.len() + 1 != peaks.len() {
        return Err(Error::invalid(
            "the peaks cannot be joined into one divide tree without a deleted ridge: delete fewer ridges or add a peak between the parts",
        ));
    }
    Ok(out)
}

/// A ridge of a pasted real divide-tree fragment, kept verbatim: its two
/// peaks (indices into [`TreeOptions::fixed_peaks`]) and its saddle.
#[derive(Debug, Clone, PartialEq)]
pub struct FixedRidge {
    pub peaks: [usize; 2],
    pub x: f64,
    pub y: f64,
    pub elevation: f64,
}

/// Pass (0 = the most prominent bin) of the peak of rank `r` among `n` when
/// the bins hold 1 : 2 : 4 : … parts, the least prominent the largest
/// (Argudo et al. 2019, §5: each less prominent bin about twice as many).
pub fn pass_of_rank(r: usize, n: usize, passes: usize) -> usize {
    if passes <= 1 || n == 0 {
        return 0;
    }
    let total = ((1u64 << passes.min(40)) - 1) as f64;
    let mut bound = 0.0;
    for k in 0..passes {
        bound += (1u64 << k.min(40)) as f64;
        if (r as f64) < n as f64 * bound / total {
            return k;
        }
    }
    passes - 1
}

/// Ridges of the placed peaks (their Delaunay MST) rasterised on a coarse
/// grid of `gc`-metre cells and diffused by three box blurs of radius one
/// cell (≈ a Gaussian of σ ≈ 1.4 cells; Wells 1986, "Efficient synthesis of
/// Gaussian filters by cascaded uniform filters", IEEE PAMI 8(2)),
/// normalised to a maximum of 1: the attraction of the ridges of earlier
/// passes added to C_P (Argudo et al. 2019, §5).
pub(super) fn ridge_density(
    peaks: &[SynthPeak],
    rho: u8,
    wm: f64,
    hm: f64,
    gc: f64,
) -> Result<Grid<f32>> {
    let nx = ((wm / gc).ceil() as usize).clamp(1, 4096);
    let ny = ((hm / gc).ceil() as usize).clamp(1, 4096);
    let (sx, sy) = (nx as f64 / wm, ny as f64 / hm);
    let mut g = vec![0f32; nx * ny];
    for (i, j) in ridge_tree(peaks, rho)? {
        let (a, b) = (&peaks[i], &peaks[j]);
        let len = ((b.x - a.x) * sx).hypot((b.y - a.y) * sy);
        let steps = (2.0 * len).ceil().max(1.0) as usize;
        for s in 0..=steps {
            let t = s as f64 / steps as f64;
            let c = (((a.x + t * (b.x - a.x)) * sx) as usize).min(nx - 1);
            let r = (((a.y + t * (b.y - a.y)) * sy) as usize).min(ny - 1);
            g[r * nx + c] = 1.0;
        }
    }
    let mut tmp = vec![0f32; nx * ny];
    for _ in 0..3 {
        // Horizontal then vertical box of radius 1 (edges clamped).
        for r in 0..ny {
            for c in 0..nx {
                let (l, rr) = (c.saturating_sub(1), (c + 1).min(nx - 1));
                tmp[r * nx + c] = (g[r * nx + l] + g[r * nx + c] + g[r * nx + rr]) / 3.0;
            }
        }
        for r in 0..ny {
            let (u, d) = (r.saturating_sub(1), (r + 1).min(ny - 1));
            for c in 0..nx {
                g[r * nx + c] = (tmp[u * nx + c] + tmp[r * nx + c] + tmp[d * nx + c]) / 3.0;
            }
        }
    }
    let max = g.iter().fold(0f32, |a, &b| a.max(b));
    if max > 0.0 {
        g.iter_mut().for_each(|v| *v /= max);
    }
    Grid::from_vec(nx, ny, g)
}
