//! One level of the source pyramid for PatchMatch ([`SourceLevel`]): its
//! cells, the positions whose patch footprint holds no nodata, and bilinear
//! sampling.

use crate::raster::Grid;

/// One source pyramid level with the box of allowed patch centres and,
/// when the source has nodata, the centres whose footprint avoids it.
pub(crate) struct SourceLevel {
    pub w: usize,
    pub h: usize,
    pub data: Vec<f32>,
    /// Footprint radius: the farthest a sample lies from the centre.
    pub rho: f32,
    pub lo_x: f32,
    pub hi_x: f32,
    pub lo_y: f32,
    pub hi_y: f32,
    /// Summed-area table of nodata counts, `(w+1) x (h+1)`, if any nodata.
    pub(super) sat: Option<Vec<u32>>,
    /// Integer centres (`y·w + x`) with a nodata-free footprint (nodata only).
    pub(super) valid: Vec<u32>,
}

impl SourceLevel {
    /// `None` when the grid is too small for a patch of radius `rho` at an
    /// integer centre.
    pub fn new(g: &Grid<f32>, rho: f32) -> Option<SourceLevel> {
        let (w, h) = (g.width(), g.height());
        if w < 2 || h < 2 {
            return None;
        }
        let (lo_x, hi_x) = (rho, (w - 1) as f32 - rho);
        let (lo_y, hi_y) = (rho, (h - 1) as f32 - rho);
        if hi_x.floor() < lo_x.ceil() || hi_y.floor() < lo_y.ceil() {
            return None;
        }
        let data = g.data().to_vec();
        let mut s = SourceLevel {
            w,
            h,
            data,
            rho,
            lo_x,
            hi_x,
            lo_y,
            hi_y,
            sat: None,
            valid: Vec::new(),
        };
        if s.data.iter().any(|v| !v.is_finite()) {
            let mut sat = vec![0u32; (w + 1) * (h + 1)];
            for y in 0..h {
                let mut run = 0u32;
                for x in 0..w {
                    run += u32::from(!s.data[y * w + x].is_finite());
                    sat[(y + 1) * (w + 1) + x + 1] = sat[y * (w + 1) + x + 1] + run;
                }
            }
            s.sat = Some(sat);
            let mut valid = Vec::new();
            for y in lo_y.ceil() as usize..=hi_y.floor() as usize {
                for x in lo_x.ceil() as usize..=hi_x.floor() as usize {
                    if s.footprint_ok(x as f32, y as f32) {
                        valid.push((y * w + x) as u32);
                    }
                }
            }
            s.valid = valid;
        }
        Some(s)
    }

    /// True when the source has nodata but no usable patch position.
    pub fn exhausted(&self) -> bool {
        self.sat.is_some() && self.valid.is_empty()
    }

    /// Share of nodata-free centres (1 without nodata).
    #[inline]
    pub(super) fn footprint_ok(&self, x: f32, y: f32) -> bool {
        let Some(sat) = &self.sat else { return true };
        let (w, h) = (self.w, self.h);
        let x0 = ((x - self.rho).floor().max(0.0) as usize).min(w - 1);
        let y0 = ((y - self.rho).floor().max(0.0) as usize).min(h - 1);
        let x1 = ((x + self.rho).floor().max(0.0) as usize + 1).min(w - 1);
        let y1 = ((y + self.rho).floor().max(0.0) as usize + 1).min(h - 1);
        let s = |xx: usize, yy: usize| sat[yy * (w + 1) + xx];
        s(x1 + 1, y1 + 1) + s(x0, y0) - s(x0, y1 + 1) - s(x1 + 1, y0) == 0
    }

    #[inline(always)]
    pub(super) fn bilinear(&self, u: f32, v: f32) -> f32 {
        let w = self.w;
        let x0 = (u as usize).min(w - 2);
        let y0 = (v as usize).min(self.h - 2);
        let fx = u - x0 as f32;
        let fy = v - y0 as f32;
        let i = y0 * w + x0;
        let d = &self.data;
        let a = d[i];
        let b = d[i + 1];
        let c = d[i + w];
        let e = d[i + w + 1];
        let top = a + fx * (b - a);
        let bot = c + fx * (e - c);
        top + fy * (bot - top)
    }
}
