//! Generalised PatchMatch over a grid of synthesis patches, and the E-step.
//!
//! PatchMatch: Barnes, Shechtman, Finkelstein & Goldman (2009), "PatchMatch:
//! a randomized correspondence algorithm for structural image editing", ACM
//! TOG 28(3) — propagation of good matches to neighbours, then a random
//! search around the best match with radii `r0 · 2^-i`. Generalised search
//! space (continuous translation, rotation, reflection): Barnes, Shechtman,
//! Goldman & Finkelstein (2010), "The Generalized PatchMatch Correspondence
//! Algorithm", ECCV, §3 — a propagated candidate carries its neighbour's
//! similarity transform, applied at the patch's own position; random
//! search perturbs every dimension with the same shrinking radius.
//!
//! Parallel and deterministic: each pass reads the previous correspondence
//! map and writes a new one (order independent, like the jump flooding of
//! Rong & Tan 2006, "Jump flooding in GPU with applications to Voronoi
//! diagram and distance transform", I3D), with propagation from the four
//! neighbours at a jump `j` that halves from pass to pass; random numbers
//! come from a counter-based hash of (seed, level, iteration, pass, patch,
//! candidate). The result does not depend on the thread count.
//!
//! A correspondence maps a synthesis patch's cell offset `d` (relative to its
//! centre) to the source position `c + R(θ)·F·d` (F mirrors x when
//! reflected), sampled bilinearly; axis-aligned candidates at integer
//! positions read cells directly (the same values bilinear sampling gives).

mod geom;
mod source;

pub(crate) use geom::Geom;
use rayon::prelude::*;
pub(crate) use source::SourceLevel;

/// The search space switches (see `SearchSpace` in the parent module).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Space {
    pub rotation: bool,
    pub reflection: bool,
    pub subpixel: bool,
    pub offset: bool,
}

/// One correspondence: source centre, angle, mirror flag, height offset and
/// the SSD against the current target.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Corr {
    pub x: f32,
    pub y: f32,
    pub theta: f32,
    pub refl: bool,
    pub offset: f32,
    pub cost: f32,
}

impl Corr {
    #[inline]
    fn axis_int(&self) -> bool {
        self.theta == 0.0 && !self.refl && self.x.fract() == 0.0 && self.y.fract() == 0.0
    }
    /// Columns of R(θ)·F: `u = x + ax·dx + bx·dy`, `v = y + ay·dx + by·dy`.
    #[inline]
    fn frame(&self) -> [f32; 4] {
        let (s, c) = self.theta.sin_cos();
        let f = if self.refl { -1.0 } else { 1.0 };
        [c * f, s * f, -s, c]
    }
}

#[inline(always)]
fn uv(c: &Corr, fr: &[f32; 4], dx: f32, dy: f32) -> (f32, f32) {
    (
        (c.x + fr[2] * dy) + fr[0] * dx,
        (c.y + fr[3] * dy) + fr[1] * dx,
    )
}

/// The splitmix64 finaliser (Steele, Lea & Flood 2014), used as a
/// counter-based generator: hash of a key and a counter.
#[inline]
pub(crate) fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Uniform in [0, 1) from a key and a counter.
#[inline]
fn unit(key: u64, k: u64) -> f32 {
    (mix(key ^ k.wrapping_mul(0xd6e8_feb8_6659_fd93)) >> 40) as f32 / (1u64 << 24) as f32
}

/// Everything a pass needs about one level.
pub(crate) struct Level<'a> {
    pub src: &'a SourceLevel,
    pub geom: &'a Geom,
    pub space: Space,
    /// Hash key of (seed, level).
    pub key: u64,
    /// Per-cell weights of a patch (n·n, row-major), see `falloff_weights`.
    pub weights: &'a [f32],
}

/// Gaussian falloff weights of a patch's cells, `exp(−|d|²/(2σ²))` with `d`
/// the offset from the patch centre; `sigma = ∞` gives uniform weights
/// (Kwatra et al. 2005's plain energy).
pub(crate) fn falloff_weights(n: usize, sigma: f32) -> Vec<f32> {
    let h0 = ((n - 1) / 2) as f32;
    let mut w = Vec::with_capacity(n * n);
    for j in 0..n {
        for i in 0..n {
            let (dx, dy) = (i as f32 - h0, j as f32 - h0);
            w.push(if sigma.is_finite() {
                (-(dx * dx + dy * dy) / (2.0 * sigma * sigma)).exp()
            } else {
                1.0
            });
        }
    }
    w
}

impl Level<'_> {
    /// Clamp a centre into the allowed box (integers without sub-pixel).
    #[inline]
    fn clamp(&self, x: f32, y: f32) -> (f32, f32) {
        let s = self.src;
        if self.space.subpixel {
            (x.clamp(s.lo_x, s.hi_x), y.clamp(s.lo_y, s.hi_y))
        } else {
            (
                x.round().clamp(s.lo_x.ceil(), s.hi_x.floor()),
                y.round().clamp(s.lo_y.ceil(), s.hi_y.floor()),
            )
        }
    }

    /// A random valid correspondence (cost unknown: infinity).
    pub fn random(&self, key: u64) -> Corr {
        let s = self.src;
        let (x, y) = if s.sat.is_some() {
            let k = (mix(key ^ 0x51) % s.valid.len().max(1) as u64) as usize;
            let c = s.valid.get(k).copied().unwrap_or(0) as usize;
            ((c % s.w) as f32, (c / s.w) as f32)
        } else {
            self.clamp(
                s.lo_x + unit(key, 1) * (s.hi_x - s.lo_x),
                s.lo_y + unit(key, 2) * (s.hi_y - s.lo_y),
            )
        };
        let theta = if self.space.rotation {
            self.rot((unit(key, 3) * 2.0 - 1.0) * std::f32::consts::PI)
        } else {
            0.0
        };
        let refl = self.space.reflection && unit(key, 4) < 0.5;
        Corr {
            x,
            y,
            theta,
            refl,
            offset: 0.0,
            cost: f32::INFINITY,
        }
    }

    /// Angles wrapped to [-π, π); without sub-pixel positions, angles are
    /// still continuous (rotated samples are bilinear anyway).
    #[inline]
    fn rot(&self, t: f32) -> f32 {
        use std::f32::consts::PI;
        let r = (t + PI).rem_euclid(2.0 * PI) - PI;
        if r.abs() < 1e-7 {
            0.0
        } else {
            r
        }
    }

    /// SSD of `c` against `target` (n·n cells); stops early once the partial
    /// sum reaches `bound` (then the returned cost is ≥ bound). With height
    /// offsets, the optimal offset (mean difference) is returned too.
    #[inline]
    fn cost(&self, c: &Corr, target: &[f32], bound: f32) -> (f32, f32) {
        let s = self.src;
        let n = self.geom.n;
        let h0 = self.geom.h0;
        let wt = self.weights;
        if self.space.offset {
            let (mut sd, mut sd2, mut sw) = (0f32, 0f32, 0f32);
            self.for_each_sample(c, |k, v| {
                let d = target[k] - v;
                sd += wt[k] * d;
                sd2 += wt[k] * d * d;
                sw += wt[k];
            });
            let off = sd / sw;
            return ((sd2 - sd * off).max(0.0), off);
        }
        let mut acc = 0f32;
        if c.axis_int() {
            let x0 = c.x as usize - h0;
            let y0 = c.y as usize - h0;
            for j in 0..n {
                let row = &s.data[(y0 + j) * s.w + x0..(y0 + j) * s.w + x0 + n];
                let t = &target[j * n..(j + 1) * n];
                let ww = &wt[j * n..(j + 1) * n];
                for i in 0..n {
                    let d = t[i] - row[i];
                    acc += ww[i] * d * d;
                }
                if acc >= bound {
                    return (acc, 0.0);
                }
            }
        } else {
            let fr = c.frame();
            for j in 0..n {
                let dy = j as f32 - h0 as f32;
                let t = &target[j * n..(j + 1) * n];
                let ww = &wt[j * n..(j + 1) * n];
                for (i, &tv) in t.iter().enumerate() {
                    let (u, v) = uv(c, &fr, i as f32 - h0 as f32, dy);
                    let d = tv - s.bilinear(u, v);
                    acc += ww[i] * d * d;
                }
                if acc >= bound {
                    return (acc, 0.0);
                }
            }
        }
        (acc, 0.0)
    }

    /// Visit the n·n source samples of `c` in row-major order.
    #[inline]
    fn for_each_sample(&self, c: &Corr, mut f: impl FnMut(usize, f32)) {
        let s = self.src;
        let n = self.geom.n;
        let h0 = self.geom.h0;
        if c.axis_int() {
            let x0 = c.x as usize - h0;
            let y0 = c.y as usize - h0;
            for j in 0..n {
                for i in 0..n {
                    f(j * n + i, s.data[(y0 + j) * s.w + x0 + i]);
                }
            }
        } else {
            let fr = c.frame();
            for j in 0..n {
                let dy = j as f32 - h0 as f32;
                for i in 0..n {
                    let (u, v) = uv(c, &fr, i as f32 - h0 as f32, dy);
                    f(j * n + i, s.bilinear(u, v));
                }
            }
        }
    }

    /// One source value of `c` at patch offset (i, j) (0-based in the patch),
    /// identical to what [`Self::cost`] compares.
    #[inline(always)]
    fn value(&self, c: &Corr, fr: &[f32; 4], fast: bool, i: usize, j: usize) -> f32 {
        let s = self.src;
        let h0 = self.geom.h0;
        if fast {
            s.data[(c.y as usize - h0 + j) * s.w + c.x as usize - h0 + i]
        } else {
            let (u, v) = uv(c, fr, i as f32 - h0 as f32, j as f32 - h0 as f32);
            s.bilinear(u, v)
        }
    }

    fn load_target(&self, target: &[f32], i: usize, j: usize, buf: &mut [f32]) {
        let g = self.geom;
        let n = g.n;
        for r in 0..n {
            let o = (g.cy[j] + r) * g.w + g.cx[i];
            buf[r * n..(r + 1) * n].copy_from_slice(&target[o..o + n]);
        }
    }

    /// Recompute every cost (and optimal offset) against `target`; returns
    /// the energy Σ SSD.
    pub fn refresh(&self, target: &[f32], corr: &mut [Corr]) -> f64 {
        let g = self.geom;
        let nx = g.nx();
        corr.par_chunks_mut(nx).enumerate().for_each(|(j, row)| {
            let mut buf = vec![0f32; g.n * g.n];
            for (i, c) in row.iter_mut().enumerate() {
                self.load_target(target, i, j, &mut buf);
                let (cost, off) = self.cost(c, &buf, f32::INFINITY);
                c.cost = cost;
                if self.space.offset {
                    c.offset = off;
                }
            }
        });
        corr.iter().map(|c| c.cost as f64).sum()
    }

    /// One PatchMatch pass: propagation at distance `jump` (patches) and
    /// random search; reads `old`, writes `new`. Only strict improvements are
    /// taken, so each patch's cost never increases.
    pub fn pass(&self, target: &[f32], old: &[Corr], new: &mut [Corr], jump: usize, pkey: u64) {
        let g = self.geom;
        let (nx, ny) = (g.nx(), g.cy.len());
        let s = self.src;
        let r0 = (s.w.max(s.h) as f32) * 0.5;
        let rmin = if self.space.subpixel { 0.25 } else { 1.0 };
        new.par_chunks_mut(nx).enumerate().for_each(|(j, row)| {
            let mut buf = vec![0f32; g.n * g.n];
            for (i, out) in row.iter_mut().enumerate() {
                let q = j * nx + i;
                self.load_target(target, i, j, &mut buf);
                let mut best = old[q];
                let (ci, cj) = g.centre(i, j);
                let try_cand = |c: Corr, best: &mut Corr| {
                    if !s.footprint_ok(c.x, c.y) {
                        return;
                    }
                    let (cost, off) = self.cost(&c, &buf, best.cost);
                    if cost < best.cost {
                        *best = Corr {
                            cost,
                            offset: if self.space.offset { off } else { 0.0 },
                            ..c
                        };
                    }
                };
                // Propagation from the four neighbours at distance `jump`.
                let nbrs = [
                    (i.checked_sub(jump), Some(j)),
                    (Some(i + jump).filter(|&v| v < nx), Some(j)),
                    (Some(i), j.checked_sub(jump)),
                    (Some(i), Some(j + jump).filter(|&v| v < ny)),
                ];
                for (ni, nj) in nbrs {
                    let (Some(ni), Some(nj)) = (ni, nj) else {
                        continue;
                    };
                    let o = old[nj * nx + ni];
                    let (oi, oj) = g.centre(ni, nj);
                    let fr = o.frame();
                    let (u, v) = uv(&o, &fr, ci - oi, cj - oj);
                    let (u, v) = self.clamp(u, v);
                    try_cand(Corr { x: u, y: v, ..o }, &mut best);
                }
                // Random search around the best, radius halving.
                let key = mix(pkey ^ mix(q as u64));
                let mut r = r0;
                let mut k = 0u64;
                while r >= rmin {
                    let b = best;
                    let (u, v) = self.clamp(
                        b.x + r * (2.0 * unit(key, k) - 1.0),
                        b.y + r * (2.0 * unit(key, k + 1) - 1.0),
                    );
                    let theta = if self.space.rotation {
                        let span = std::f32::consts::PI * (r / r0);
                        self.rot(b.theta + span * (2.0 * unit(key, k + 2) - 1.0))
                    } else {
                        0.0
                    };
                    let refl = if self.space.reflection && k == 0 {
                        unit(key, k + 3) < 0.5
                    } else {
                        b.refl
                    };
                    try_cand(
                        Corr {
                            x: u,
                            y: v,
                            theta,
                            refl,
                            ..b
                        },
                        &mut best,
                    );
                    r *= 0.5;
                    k += 4;
                }
                *out = best;
            }
        });
    }

    /// E-step: each cell is the weighted mean of the source values (plus
    /// offsets) of the patches covering it, summed in a fixed order (Kwatra et al. 2005,
    /// "Texture optimization for example-based synthesis", SIGGRAPH, §3: the
    /// least-squares minimiser of Σ_p ‖x_p − z_p‖² for fixed matches z).
    pub fn e_step(&self, corr: &[Corr], out: &mut [f32]) {
        let g = self.geom;
        let nx = g.nx();
        let frames: Vec<[f32; 4]> = corr.iter().map(|c| c.frame()).collect();
        let fast: Vec<bool> = corr.iter().map(|c| c.axis_int()).collect();
        out.par_chunks_mut(g.w).enumerate().for_each(|(y, row)| {
            let ys = &g.cover_y.1[g.cover_y.0[y]..g.cover_y.0[y + 1]];
            for (x, o) in row.iter_mut().enumerate() {
                let xs = &g.cover_x.1[g.cover_x.0[x]..g.cover_x.0[x + 1]];
                let mut sum = 0f32;
                let mut wsum = 0f32;
                for &(pj, dj) in ys {
                    for &(pi, di) in xs {
                        let q = pj as usize * nx + pi as usize;
                        let c = &corr[q];
                        let wk = self.weights[dj as usize * g.n + di as usize];
                        sum += wk
                            * (self.value(c, &frames[q], fast[q], di as usize, dj as usize)
                                + c.offset);
                        wsum += wk;
                    }
                }
                *o = sum / wsum;
            }
        });
    }

    /// Correspondences of this level from those of the coarser level
    /// (`prev` on `pg`): the generalisation of Scott & Dodgson's
    /// `C^{k-1}(p) = 2C^k(⌊p/2⌋) + (p − 2⌊p/2⌋)` to patches on a grid and to
    /// rotated/reflected matches — a fine patch centred at `c` takes the
    /// coarse patch nearest to `c/2` (centre `c'`, transform `(s, R F)`) and
    /// becomes `2s + R F (c − 2c')`. Out-of-box results are clamped; results
    /// on nodata are replaced by random valid matches.
    pub fn upsample(&self, prev: &[Corr], pg: &Geom) -> Vec<Corr> {
        let g = self.geom;
        let nearest = |c: f32, corners: &[usize]| -> usize {
            let t = c / 2.0 - pg.h0 as f32;
            let mut best = 0usize;
            let mut bd = f32::INFINITY;
            let guess = ((t / pg.spacing as f32).round().max(0.0) as usize).min(corners.len() - 1);
            let lo = guess.saturating_sub(1);
            let hi = (guess + 2).min(corners.len());
            for (k, &ck) in corners.iter().enumerate().take(hi).skip(lo) {
                let d = (ck as f32 - t).abs();
                if d < bd {
                    bd = d;
                    best = k;
                }
            }
            best
        };
        let pnx = pg.nx();
        let mut out = Vec::with_capacity(g.count());
        for j in 0..g.cy.len() {
            for i in 0..g.nx() {
                let (fx, fy) = g.centre(i, j);
                let (pi, pj) = (nearest(fx, &pg.cx), nearest(fy, &pg.cy));
                let o = prev[pj * pnx + pi];
                let (ox, oy) = pg.centre(pi, pj);
                let fr = o.frame();
                let base = Corr {
                    x: 2.0 * o.x,
                    y: 2.0 * o.y,
                    ..o
                };
                let (u, v) = uv(&base, &fr, fx - 2.0 * ox, fy - 2.0 * oy);
                let (u, v) = self.clamp(u, v);
                let c = if self.src.footprint_ok(u, v) {
                    Corr {
                        x: u,
                        y: v,
                        cost: f32::INFINITY,
                        ..o
                    }
                } else {
                    self.random(mix(self.key ^ mix(0x1000_0000 + (j * g.nx() + i) as u64)))
                };
                out.push(c);
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster::Grid;

    fn noise(w: usize, h: usize, seed: u64) -> Grid<f32> {
        Grid::from_fn(w, h, |x, y| {
            (mix(seed ^ mix((y * w + x) as u64)) >> 40) as f32 / 1e5
        })
    }

    fn space(rotation: bool, reflection: bool, subpixel: bool) -> Space {
        Space {
            rotation,
            reflection,
            subpixel,
            offset: false,
        }
    }

    #[test]
    fn finds_an_exact_crop_of_the_source() {
        // Target = the source shifted by (10, 7): every patch's true match is
        // its own position + (10, 7) with SSD 0 (noise makes it unique).
        let sg = noise(64, 64, 3);
        let src = SourceLevel::new(&sg, 3.0).unwrap();
        let geom = Geom::new(30, 30, 7, 3);
        let target: Vec<f32> = (0..30 * 30)
            .map(|i| sg.get(i % 30 + 10, i / 30 + 7))
            .collect();
        let weights = falloff_weights(7, f32::INFINITY);
        let lev = Level {
            src: &src,
            geom: &geom,
            space: space(false, false, false),
            key: 77,
            weights: &weights,
        };
        let mut corr: Vec<Corr> = (0..geom.count())
            .map(|q| lev.random(mix(q as u64)))
            .collect();
        lev.refresh(&target, &mut corr);
        let mut other = corr.clone();
        let exact = |corr: &[Corr]| corr.iter().filter(|c| c.cost == 0.0).count();
        let mut counts = Vec::new();
        for p in 0..40 {
            lev.pass(
                &target,
                &corr,
                &mut other,
                [8, 4, 2, 1][p % 4],
                mix(p as u64 + 100),
            );
            std::mem::swap(&mut corr, &mut other);
            counts.push(exact(&corr));
        }
        assert!(counts.windows(2).all(|w| w[1] >= w[0]), "{counts:?}");
        for j in 0..geom.cy.len() {
            for i in 0..geom.nx() {
                let c = corr[j * geom.nx() + i];
                let (x, y) = geom.centre(i, j);
                assert_eq!(
                    (c.x, c.y, c.cost),
                    (x + 10.0, y + 7.0, 0.0),
                    "patch {i},{j}"
                );
            }
        }
        // The E-step of exact matches reproduces the target.
        let mut out = vec![0f32; 900];
        lev.e_step(&corr, &mut out);
        for (a, b) in out.iter().zip(&target) {
            assert!((a - b).abs() <= 1e-4 * b.abs().max(1.0));
        }
    }

    #[test]
    fn upsampling_keeps_a_rotated_field() {
        // Coarse field s(c) = a + R(θ)F(c − b); the fine field must be
        // 2a + R(θ)F(c_f − 2b) (the paper's 2C(⌊p/2⌋) + (p − 2⌊p/2⌋) for θ = 0).
        let sg = noise(400, 400, 5);
        let src = SourceLevel::new(&sg, 3.0 * std::f32::consts::SQRT_2 + 1e-3).unwrap();
        let pg = Geom::new(40, 40, 7, 3);
        let g = Geom::new(80, 80, 7, 3);
        let weights = falloff_weights(7, 2.0);
        let lev = Level {
            src: &src,
            geom: &g,
            space: space(true, true, true),
            key: 1,
            weights: &weights,
        };
        for (theta, refl) in [(0.0f32, false), (0.7, false), (-2.0, true)] {
            let (a, b) = ((100.0f32, 90.0f32), (20.0f32, 20.0f32));
            let field = Corr {
                x: 0.0,
                y: 0.0,
                theta,
                refl,
                offset: 0.0,
                cost: 0.0,
            };
            let fr = field.frame();
            let at = |c: (f32, f32), a: (f32, f32), b: (f32, f32)| {
                let (dx, dy) = (c.0 - b.0, c.1 - b.1);
                (a.0 + fr[0] * dx + fr[2] * dy, a.1 + fr[1] * dx + fr[3] * dy)
            };
            let mut prev = Vec::new();
            for j in 0..pg.cy.len() {
                for i in 0..pg.nx() {
                    let (x, y) = at(pg.centre(i, j), a, b);
                    prev.push(Corr { x, y, ..field });
                }
            }
            let up = lev.upsample(&prev, &pg);
            for j in 0..g.cy.len() {
                for i in 0..g.nx() {
                    let c = up[j * g.nx() + i];
                    let (x, y) = at(
                        g.centre(i, j),
                        (2.0 * a.0, 2.0 * a.1),
                        (2.0 * b.0, 2.0 * b.1),
                    );
                    assert!(
                        (c.x - x).abs() < 1e-3 && (c.y - y).abs() < 1e-3,
                        "{theta} {i},{j}"
                    );
                    assert_eq!((c.theta, c.refl), (theta, refl));
                }
            }
        }
    }

    #[test]
    fn nodata_positions_are_never_used() {
        let mut sg = noise(40, 40, 9);
        for y in 0..40 {
            for x in 0..40 {
                if x >= 20 {
                    sg.set(x, y, f32::NAN);
                }
            }
        }
        let src = SourceLevel::new(&sg, 3.0).unwrap();
        // centres must keep x + 3 + 1 (bilinear neighbour) below 20
        assert!(!src.exhausted());
        for q in 0..500u64 {
            let geom = Geom::new(20, 20, 7, 3);
            let weights = falloff_weights(7, f32::INFINITY);
            let lev = Level {
                src: &src,
                geom: &geom,
                space: space(false, false, false),
                key: 0,
                weights: &weights,
            };
            let c = lev.random(mix(q));
            assert!(c.x + 4.0 < 20.0, "{c:?}");
        }
    }
}
