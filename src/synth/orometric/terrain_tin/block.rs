//! The reconstruction blocks of the raster: a grey-scale reconstruction
//! from the crest and pinch cells of a fixed 512-cell grid with a 32-cell
//! halo cuts the knolls no path joins to a ridge above their col.

use super::super::reconstruct::reconstruct;
use super::cache::Block;
use super::TinTerrain;
use super::BLOCK_HALO;
use super::BLOCK_SIDE;
use crate::error::Result;

impl TinTerrain {
    /// The finished cells of block (bx, by) of the fixed [`BLOCK_SIDE`]
    /// grid: the cell values of the block grown by [`BLOCK_HALO`] cells,
    /// reconstructed from the crest and pinch cells, then the noise.
    ///
    /// Grey-scale reconstruction by dilation (Vincent 1993, "Morphological
    /// grayscale reconstruction in image analysis", IEEE TIP 2(2)) under the
    /// surface from the marker "crest and pinch cells, and the halo's outer
    /// ring where the raster goes on": each cell becomes min(its value, the
    /// highest level at which an 8-path joins it to a marker), computed by
    /// a priority flood from the markers, highest first (Barnes, Lehman &
    /// Mulla 2014, turned upside down). Knolls the TIN leaves between river
    /// channels, which no path joins to a ridge above their col, are cut to
    /// that col: the raster's peaks are the tree's. Cells joined to a ridge
    /// (or to the ring) at their own height keep it, so only such knolls
    /// change. A knoll that reaches the ring stays (the halo bounds what a
    /// block sees); every cell depends only on its position and the fixed
    /// block grid, so windows equal the whole render.
    pub(super) fn build_block(&self, bx: usize, by: usize) -> Result<Block> {
        let s = self.side;
        let (w, h) = (self.info.width, self.info.height);
        let (c0, r0) = (bx * BLOCK_SIDE, by * BLOCK_SIDE);
        let (c1, r1) = ((c0 + BLOCK_SIDE).min(w), (r0 + BLOCK_SIDE).min(h));
        let (ex0, ey0) = (c0.saturating_sub(BLOCK_HALO), r0.saturating_sub(BLOCK_HALO));
        let (ex1, ey1) = ((c1 + BLOCK_HALO).min(w), (r1 + BLOCK_HALO).min(h));
        let (ew, eh) = (ex1 - ex0, ey1 - ey0);
        let n = ew * eh;
        let mut val = vec![0f64; n];
        let mut marker = vec![false; n];
        let mut noise = vec![0f64; n];
        for ty in ey0 / s..=(ey1 - 1) / s {
            for tx in ex0 / s..=(ex1 - 1) / s {
                let st = self.supertile(tx, ty)?;
                let (ca, cb) = ((tx * s).max(ex0), ((tx + 1) * s).min(ex1));
                let (ra, rb) = ((ty * s).max(ey0), ((ty + 1) * s).min(ey1));
                for r in ra..rb {
                    let o = (r - ey0) * ew;
                    for col in ca..cb {
                        let (v, k, z) = self.cell_value(&st, col, r);
                        val[o + col - ex0] = v;
                        marker[o + col - ex0] = k;
                        noise[o + col - ex0] = z;
                    }
                }
            }
        }
        // The outer ring, where the raster goes on beyond the halo.
        for r in 0..eh {
            for c in 0..ew {
                let (gc, gr) = (c + ex0, r + ey0);
                if (c == 0 && gc > 0)
                    || (r == 0 && gr > 0)
                    || (c + 1 == ew && gc + 1 < w)
                    || (r + 1 == eh && gr + 1 < h)
                {
                    marker[r * ew + c] = true;
                }
            }
        }
        let level = reconstruct(&val, &marker, |i, buf| {
            let (c, r) = (i % ew, i / ew);
            for rr in r.saturating_sub(1)..(r + 2).min(eh) {
                for cc in c.saturating_sub(1)..(c + 2).min(ew) {
                    if (cc, rr) != (c, r) {
                        buf.push(rr * ew + cc);
                    }
                }
            }
        });
        let bw = c1 - c0;
        let mut cells = vec![0f32; bw * (r1 - r0)];
        for r in r0..r1 {
            for c in c0..c1 {
                let i = (r - ey0) * ew + c - ex0;
                // A cut knoll is flat at its col: noise only roughens it
                // downwards, so it cannot rise above the col (next to a
                // summit, the col can be within the noise of the peak).
                let (v, z) = if level[i] < val[i] {
                    (level[i], noise[i].min(0.0))
                } else {
                    (val[i], noise[i])
                };
                cells[(r - r0) * bw + c - c0] = (v + z) as f32;
            }
        }
        Ok(Block { cells })
    }
}
