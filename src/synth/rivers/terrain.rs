//! The terrain of a river network as a [`RasterSource`]: each edge a
//! digital line carved into the land ([`RiverTerrain`]).

use super::super::tectonic::PointIndex;
use super::RiverNetwork;
use crate::error::Result;
use crate::raster::AnyGrid;
use crate::raster::Crs;
use crate::raster::DType;
use crate::raster::GeoRef;
use crate::raster::Grid;
use crate::raster::RasterInfo;
use crate::raster::RasterSource;
use crate::raster::Window;
use crate::synth::source_info;

/// A channel source: a digital line from `a` to `b` (cells) with heights
/// `ha` → `hb` and cone slope `s` (metres per cell).
#[derive(Debug, Clone, Copy)]
pub(super) struct Channel {
    pub(super) a: [i64; 2],
    pub(super) b: [i64; 2],
    pub(super) ha: f64,
    pub(super) hb: f64,
    pub(super) s: f64,
}

impl Channel {
    pub(super) fn steps(&self) -> i64 {
        (self.b[0] - self.a[0])
            .abs()
            .max((self.b[1] - self.a[1]).abs())
    }
    /// Cell i (0..=steps) and its height; integer rounding keeps every
    /// step 8-connected.
    #[inline]
    pub(super) fn cell(&self, i: i64, k: i64) -> ([i64; 2], f64) {
        if k == 0 {
            return (self.a, self.ha.min(self.hb));
        }
        let (dx, dy) = (self.b[0] - self.a[0], self.b[1] - self.a[1]);
        let x = self.a[0] + (2 * i * dx + k).div_euclid(2 * k);
        let y = self.a[1] + (2 * i * dy + k).div_euclid(2 * k);
        let t = i as f64 / k as f64;
        ([x, y], self.ha + (self.hb - self.ha) * t)
    }
}

/// River-network terrain as a tileable raster source (f32 metres).
pub struct RiverTerrain {
    pub(super) net: RiverNetwork,
    pub(super) channels: Vec<Channel>,
    /// Channel ids per bucket of `bs` cells (listed where within R).
    pub(super) buckets: Vec<Vec<u32>>,
    pub(super) bs: i64,
    pub(super) gw: usize,
    pub(super) reach: i64,
    /// Distances 0..=reach: `dist[dy * (reach+1) + dx]`.
    pub(super) dist: Vec<f64>,
    pub(super) nearest: PointIndex,
    pub(super) sea_depth: f64,
    pub(super) info: RasterInfo,
}

impl RiverTerrain {
    /// Rasteriser of `net` on a `width x height` raster with `cell_m` metre
    /// cells, georeferenced by `georef` (a local metric CRS if `None`).
    pub fn new(
        net: RiverNetwork,
        width: usize,
        height: usize,
        cell_m: f64,
        radius: f64,
        sea_depth: f64,
        georef: Option<GeoRef>,
    ) -> Result<Self> {
        let reach = (2.5 * radius).ceil() as i64 + 1;
        let cellpos = |q: [f64; 2]| {
            [
                (q[0].floor() as i64).clamp(0, width as i64 - 1),
                (q[1].floor() as i64).clamp(0, height as i64 - 1),
            ]
        };
        let mut channels = Vec::new();
        for v in 0..net.nodes.len() {
            if net.sea[v] {
                let c = cellpos(net.nodes[v]);
                channels.push(Channel {
                    a: c,
                    b: c,
                    ha: -sea_depth,
                    hb: -sea_depth,
                    s: net.lateral[v].max(1e-3) * cell_m,
                });
            } else {
                let u = net.parent[v] as usize;
                channels.push(Channel {
                    a: cellpos(net.nodes[v]),
                    b: cellpos(net.nodes[u]),
                    ha: net.height[v],
                    hb: net.height[u],
                    s: net.lateral[v] * cell_m,
                });
            }
        }
        let bs = (reach * 2).max(32);
        let gw = (width as i64 + bs - 1) / bs;
        let gh = (height as i64 + bs - 1) / bs;
        let mut buckets = vec![Vec::new(); (gw * gh) as usize];
        for (id, c) in channels.iter().enumerate() {
            let x0 = ((c.a[0].min(c.b[0]) - reach).div_euclid(bs)).max(0);
            let x1 = ((c.a[0].max(c.b[0]) + reach).div_euclid(bs)).min(gw - 1);
            let y0 = ((c.a[1].min(c.b[1]) - reach).div_euclid(bs)).max(0);
            let y1 = ((c.a[1].max(c.b[1]) + reach).div_euclid(bs)).min(gh - 1);
            for y in y0..=y1 {
                for x in x0..=x1 {
                    buckets[(y * gw + x) as usize].push(id as u32);
                }
            }
        }
        let r1 = (reach + 1) as usize;
        let dist = (0..r1 * r1)
            .map(|i| (((i / r1) * (i / r1) + (i % r1) * (i % r1)) as f64).sqrt())
            .collect();
        let georef = georef.unwrap_or_else(|| {
            GeoRef::north_up(0.0, height as f64 * cell_m, cell_m, Crs::default())
        });
        let nearest = PointIndex::new(net.nodes.clone(), width, height);
        Ok(RiverTerrain {
            net,
            channels,
            buckets,
            bs,
            gw: gw as usize,
            reach,
            dist,
            nearest,
            sea_depth,
            info: source_info(width, height, DType::F32, georef, "<rivers>"),
        })
    }

    /// The network it rasterises.
    pub fn network(&self) -> &RiverNetwork {
        &self.net
    }

    /// True if cell (x, y) is sea (its nearest node is a sea node).
    pub fn is_sea(&self, x: usize, y: usize) -> bool {
        self.net.sea[self.nearest.nearest([x as f64 + 0.5, y as f64 + 0.5]).0]
    }

    pub(super) fn render(&self, win: Window) -> Vec<f32> {
        let (wx, wy, ww, wh) = (win.x, win.y, win.w as i64, win.h as i64);
        let r = self.reach;
        let mut best = vec![f64::INFINITY; (ww * wh) as usize];
        let gh = self.buckets.len() / self.gw;
        let bx0 = (wx.div_euclid(self.bs)).max(0) as usize;
        let bx1 = ((wx + ww - 1).div_euclid(self.bs) as usize).min(self.gw - 1);
        let by0 = (wy.div_euclid(self.bs)).max(0) as usize;
        let by1 = ((wy + wh - 1).div_euclid(self.bs) as usize).min(gh - 1);
        let mut ids: Vec<u32> = Vec::new();
        for by in by0..=by1 {
            for bx in bx0..=bx1 {
                ids.extend_from_slice(&self.buckets[by * self.gw + bx]);
            }
        }
        ids.sort_unstable();
        ids.dedup();
        let r1 = (r + 1) as usize;
        for &id in &ids {
            let ch = self.channels[id as usize];
            let k = ch.steps();
            for i in 0..=k {
                let (c, hc) = ch.cell(i, k);
                // Rows of the window within reach of this cell.
                let ya = (c[1] - r).max(wy);
                let yb = (c[1] + r).min(wy + wh - 1);
                if ya > yb || c[0] + r < wx || c[0] - r > wx + ww - 1 {
                    continue;
                }
                for y in ya..=yb {
                    let dy = (y - c[1]).unsigned_abs() as usize;
                    // Columns with dx² + dy² <= r².
                    let mut span = (((r * r) as f64 - (dy * dy) as f64).sqrt()) as i64;
                    while (span + 1) * (span + 1) + (dy * dy) as i64 <= r * r {
                        span += 1;
                    }
                    while span >= 0 && span * span + (dy * dy) as i64 > r * r {
                        span -= 1;
                    }
                    let xa = (c[0] - span).max(wx);
                    let xb = (c[0] + span).min(wx + ww - 1);
                    if xa > xb {
                        continue;
                    }
                    let row = ((y - wy) * ww) as usize;
                    let drow = &self.dist[dy * r1..dy * r1 + r1];
                    for x in xa..=xb {
                        let dx = (x - c[0]).unsigned_abs() as usize;
                        let v = hc + ch.s * drow[dx];
                        let o = &mut best[row + (x - wx) as usize];
                        if v < *o {
                            *o = v;
                        }
                    }
                }
            }
        }
        let mut out = vec![0f32; best.len()];
        for y in 0..wh {
            for x in 0..ww {
                let i = (y * ww + x) as usize;
                out[i] = if self.is_sea((wx + x) as usize, (wy + y) as usize) {
                    -self.sea_depth as f32
                } else {
                    best[i] as f32
                };
            }
        }
        out
    }
}

impl RasterSource for RiverTerrain {
    fn info(&self) -> &RasterInfo {
        &self.info
    }
    fn read_native(&self, win: Window) -> Result<AnyGrid> {
        Ok(AnyGrid::F32(Grid::from_vec(
            win.w,
            win.h,
            self.render(win),
        )?))
    }
}
