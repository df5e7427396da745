//! The user maps read at a position (density C_P, coarse elevation C_H),
//! the grid of placed peaks that answers "the nearest higher peak", and the
//! spatially coherent coarse elevation map drawn from a profile.

use super::super::profile::SynthProfile;
use super::SynthPeak;
use crate::raster::Grid;
use crate::synth::buckets::for_each_in_ring;

/// A map stretched over the domain, sampled by nearest cell.
pub(super) struct DomainMap<'a> {
    pub(super) g: &'a Grid<f32>,
    pub(super) sx: f64,
    pub(super) sy: f64,
}

impl DomainMap<'_> {
    pub(super) fn at(&self, x: f64, y: f64) -> f64 {
        let c = ((x * self.sx) as usize).min(self.g.width() - 1);
        let r = ((y * self.sy) as usize).min(self.g.height() - 1);
        self.g.get(c, r) as f64
    }
}

/// Uniform grid of placed peaks for nearest-higher queries.
pub(super) struct PeakGrid {
    pub(super) cell: f64,
    pub(super) nx: usize,
    pub(super) ny: usize,
    pub(super) buckets: Vec<Vec<u32>>,
}

impl PeakGrid {
    pub(super) fn new(wm: f64, hm: f64, cell: f64) -> PeakGrid {
        let nx = ((wm / cell).ceil() as usize).max(1);
        let ny = ((hm / cell).ceil() as usize).max(1);
        PeakGrid {
            cell,
            nx,
            ny,
            buckets: vec![Vec::new(); nx * ny],
        }
    }
    pub(super) fn key(&self, x: f64, y: f64) -> (usize, usize) {
        (
            ((x / self.cell).max(0.0) as usize).min(self.nx - 1),
            ((y / self.cell).max(0.0) as usize).min(self.ny - 1),
        )
    }
    pub(super) fn insert(&mut self, i: usize, x: f64, y: f64) {
        let (bx, by) = self.key(x, y);
        self.buckets[by * self.nx + bx].push(i as u32);
    }
    /// Distance to the nearest peak with elevation ≥ h, searched up to `max_d`
    /// (returns `max_d` if none is closer).
    pub(super) fn nearest_higher(
        &self,
        peaks: &[SynthPeak],
        x: f64,
        y: f64,
        h: f64,
        max_d: f64,
    ) -> f64 {
        let (bx, by) = self.key(x, y);
        let mut best = max_d;
        let rings = ((max_d / self.cell).ceil() as usize + 1).min(self.nx.max(self.ny));
        for ring in 0..=rings {
            // Every point in ring r is at least (r − 1) · cell away.
            if ring >= 1 && (ring as f64 - 1.0) * self.cell > best {
                break;
            }
            for_each_in_ring((bx, by), ring, (self.nx, self.ny), |b| {
                for &i in &self.buckets[b] {
                    let p = &peaks[i as usize];
                    if p.elevation >= h {
                        best = best.min((p.x - x).hypot(p.y - y));
                    }
                }
            });
        }
        best
    }
}

/// A coherent coarse elevation map C_H for a domain of `w` x `h` cells: seeded
/// low-frequency fBm (about two massifs across), each value replaced by the
/// profile's peak-elevation quantile of its rank, so its histogram is the
/// profile's elevation histogram (a rank transform, as in histogram
/// matching, Gonzalez & Woods, "Digital Image Processing", §3.3).
pub fn coherent_elevation_map(profile: &SynthProfile, w: usize, h: usize, seed: u64) -> Grid<f32> {
    coherent_map_with(w, h, seed, |u, _, _| profile.elevation.quantile(u))
}

/// [`coherent_elevation_map`] with the quantile function chosen per cell:
/// `q(u, fx, fy)` maps the rank fraction u of the fBm value at the domain
/// fraction (fx, fy) to an elevation (the type map C_T uses the profile of
/// the region there).
pub(super) fn coherent_map_with(
    w: usize,
    h: usize,
    seed: u64,
    q: impl Fn(f64, f64, f64) -> f64,
) -> Grid<f32> {
    let side = 128usize;
    let (gw, gh) = if w >= h {
        (side, ((side * h) / w).max(8))
    } else {
        (((side * w) / h).max(8), side)
    };
    let fbm = crate::synth::Fbm {
        seed: seed ^ 0x0063_686d_6170,
        octaves: 4,
        lacunarity: 2.0,
        gain: 0.5,
        wavelength: side as f64 / 2.0,
        base: 0.0,
        amplitude: 1.0,
        warp: 0.0,
    };
    let vals: Vec<f64> = (0..gw * gh)
        .map(|i| fbm.sample((i % gw) as f64 + 0.5, (i / gw) as f64 + 0.5))
        .collect();
    let mut order: Vec<usize> = (0..vals.len()).collect();
    order.sort_by(|&a, &b| vals[a].total_cmp(&vals[b]).then(a.cmp(&b)));
    let mut out = vec![0f32; vals.len()];
    let n = vals.len() as f64;
    for (rank, &i) in order.iter().enumerate() {
        let (fx, fy) = (
            ((i % gw) as f64 + 0.5) / gw as f64,
            ((i / gw) as f64 + 0.5) / gh as f64,
        );
        out[i] = q((rank as f64 + 0.5) / n, fx, fy) as f32;
    }
    Grid::from_vec(gw, gh, out).unwrap_or_else(|_| Grid::new(gw, gh, 0.0))
}
