//! Poisson-disk samples as a pure function of position (phase-group dart
//! throwing, Wei 2008) and their elevation between ridges and rivers.

use super::TinTerrain;
use super::SAMPLE_PAD;

/// SplitMix64 finaliser (Steele, Lea & Flood 2014, "Fast splittable
/// pseudorandom number generators", OOPSLA): a hash of a 64-bit word.
#[inline]
pub(super) fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

#[inline]
pub(super) fn unit(h: u64) -> f64 {
    (h >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

impl TinTerrain {
    /// Poisson-disk samples in [x0, x1) x [y0, y1) (metres), exactly those
    /// of the whole domain there (see the module doc).
    pub(super) fn samples_in(&self, r: [f64; 4]) -> Vec<[f64; 2]> {
        let lam = self.lambda;
        let gs = lam / std::f64::consts::SQRT_2;
        let gw = ((self.wm / gs).ceil() as i64).max(1);
        let gh = ((self.hm / gs).ceil() as i64).max(1);
        let gx0 = ((r[0] / gs).floor() as i64 - SAMPLE_PAD).max(0);
        let gy0 = ((r[1] / gs).floor() as i64 - SAMPLE_PAD).max(0);
        let gx1 = ((r[2] / gs).ceil() as i64 + SAMPLE_PAD).min(gw);
        let gy1 = ((r[3] / gs).ceil() as i64 + SAMPLE_PAD).min(gh);
        if gx1 <= gx0 || gy1 <= gy0 {
            return Vec::new();
        }
        let (lw, lh) = ((gx1 - gx0) as usize, (gy1 - gy0) as usize);
        let mut slot = vec![u32::MAX; lw * lh];
        let mut acc: Vec<[f64; 2]> = Vec::new();
        let h0 = mix(self.seed ^ 0x706f_6973_736f_6e00);
        // Away from ridge and river segments too (no sliver triangle along
        // a constraint, whose circumdisk would be huge).
        let seg_avoid = (0.25 * lam).min(4.0 * self.cell);
        for phase in 0..9i64 {
            let (px, py) = (phase % 3, phase / 3);
            let mut gy = gy0 + (py - gy0).rem_euclid(3);
            while gy < gy1 {
                let mut gx = gx0 + (px - gx0).rem_euclid(3);
                while gx < gx1 {
                    let (lx, ly) = ((gx - gx0) as usize, (gy - gy0) as usize);
                    let hc = mix(mix(h0 ^ gx as u64) ^ gy as u64);
                    for t in 0..4u64 {
                        let h = mix(hc ^ t);
                        let x = (gx as f64 + unit(h)) * gs;
                        let y = (gy as f64 + unit(mix(h))) * gs;
                        if x <= 0.0 || y <= 0.0 || x >= self.wm || y >= self.hm {
                            continue;
                        }
                        let mut ok = true;
                        'n: for yy in ly.saturating_sub(2)..(ly + 3).min(lh) {
                            for xx in lx.saturating_sub(2)..(lx + 3).min(lw) {
                                let j = slot[yy * lw + xx];
                                if j != u32::MAX {
                                    let q = acc[j as usize];
                                    if (q[0] - x).hypot(q[1] - y) < lam {
                                        ok = false;
                                        break 'n;
                                    }
                                }
                            }
                        }
                        if ok
                            && !self.avoid.any_within(x, y, 0.4 * lam)
                            && !self.near_line(x, y, seg_avoid)
                        {
                            slot[ly * lw + lx] = acc.len() as u32;
                            acc.push([x, y]);
                            break;
                        }
                    }
                    gx += 3;
                }
                gy += 3;
            }
        }
        acc.retain(|p| p[0] >= r[0] && p[0] < r[2] && p[1] >= r[1] && p[1] < r[3]);
        acc.sort_by(|a, b| a[1].total_cmp(&b[1]).then(a[0].total_cmp(&b[0])));
        acc
    }

    /// Whether a ridge or river segment passes within `d` (≤ 4.7 cells) of (x, y).
    pub(super) fn near_line(&self, x: f64, y: f64, d: f64) -> bool {
        let bx = ((x / self.lb) as usize).min(self.lnx - 1);
        let by = ((y / self.lb) as usize).min(self.lny - 1);
        let b = by * self.lnx + bx;
        self.lids[self.lstart[b] as usize..self.lstart[b + 1] as usize]
            .iter()
            .any(|&i| self.lines[i as usize].probe(x, y).0 < d)
    }

    /// Elevation of a sample: the skeleton flank, eased to the nearest
    /// river within its valley half-width.
    pub(super) fn sample_z(&self, s: [f64; 2]) -> f64 {
        let zl = self.skeleton.value(s[0], s[1]);
        let zl = if zl.is_finite() { zl } else { self.floor };
        let Some((i, dr)) = self.river_grid.nearest(s[0], s[1], 50.0 * self.lambda) else {
            return zl;
        };
        let n = &self.rivers.nodes[i];
        let w = self.valley_width * (n.area_m2.max(0.0) / 1e6).powf(0.4);
        let u = if w > 0.0 { (dr / w).min(1.0) } else { 1.0 };
        let f = u * u * (3.0 - 2.0 * u);
        if zl > n.z {
            n.z + (zl - n.z) * f
        } else {
            zl
        }
    }
}
