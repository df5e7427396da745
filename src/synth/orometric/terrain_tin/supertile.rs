//! The final TIN of one super-tile, certified exact (rebuilt with a doubled
//! margin until it is) and repaired, and the value it gives a cell (channel
//! and crest bands, saddle pinches).

use super::super::rivers::cdt;
use super::super::tin::Tin;
use super::cache::cached;
use super::cache::Super;
use super::lines::crosses;
use super::lines::LineKind;
use super::TinTerrain;
use super::BUCKET_CELLS;
use super::CHANNEL_BAND;
use super::MARGIN_LAMBDA;
use super::MAX_SEG;
use super::PEAK_CALM;
use super::REPAIR_ROUNDS;
use crate::error::Error;
use crate::error::Result;
use crate::oro::regions::N8;
use spade::Triangulation;
use std::collections::HashMap;
use std::sync::atomic::Ordering;
use std::sync::Arc;

impl TinTerrain {
    /// The super-tile (sx, sy), from the cache or built.
    pub(super) fn supertile(&self, sx: usize, sy: usize) -> Result<Arc<Super>> {
        cached(&self.cache, (sy * self.nsx + sx) as u64, || {
            self.build_supertile(sx, sy)
        })
    }

    pub(super) fn build_supertile(&self, sx: usize, sy: usize) -> Result<Super> {
        let mut margin = MARGIN_LAMBDA * self.lambda;
        for attempt in 0..6 {
            if attempt == 5 {
                // Last resort: the whole domain (always certified).
                margin = self.wm + self.hm;
            }
            if let Some(s) = self.try_supertile(sx, sy, margin)? {
                self.built.fetch_add(1, Ordering::Relaxed);
                if attempt > 0 {
                    self.retried.fetch_add(1, Ordering::Relaxed);
                }
                self.samples.fetch_add(s.n_samples, Ordering::Relaxed);
                return Ok(s);
            }
            margin *= 2.0;
        }
        Err(Error::invalid(format!(
            "terrain: super-tile ({sx}, {sy}) could not be certified exact with a margin of {margin} m (a bug: please report it with the tree)"
        )))
    }

    /// The final TIN of super-tile (sx, sy) from the vertices within
    /// `margin` of it, or None if its triangles cannot be certified global.
    pub(super) fn try_supertile(&self, sx: usize, sy: usize, margin: f64) -> Result<Option<Super>> {
        let c = self.cell;
        let (c0, r0) = (sx * self.side, sy * self.side);
        let (c1, r1) = (
            (c0 + self.side).min(self.info.width),
            (r0 + self.side).min(self.info.height),
        );
        let core = [c0 as f64 * c, r0 as f64 * c, c1 as f64 * c, r1 as f64 * c];
        let rr = [
            core[0] - margin,
            core[1] - margin,
            core[2] + margin,
            core[3] + margin,
        ];
        // Skeleton vertices and the constraints between them.
        let ids = self.sk_grid.in_rect(rr[0], rr[1], rr[2], rr[3]);
        let mut local: HashMap<u32, u32> = HashMap::with_capacity(ids.len());
        let mut pts: Vec<[f64; 3]> = Vec::with_capacity(2 * ids.len());
        let mut kind: Vec<u8> = Vec::with_capacity(2 * ids.len());
        let mut down: Vec<f64> = Vec::with_capacity(2 * ids.len());
        for (k, &g) in ids.iter().enumerate() {
            local.insert(g, k as u32);
            pts.push(self.sk[g as usize]);
            kind.push(self.sk_kind[g as usize]);
            down.push(self.sk_down[g as usize]);
        }
        let mut eids: Vec<u32> = Vec::new();
        for &g in &ids {
            let g = g as usize;
            for &e in &self.sk_adj[self.sk_adj_start[g] as usize..self.sk_adj_start[g + 1] as usize]
            {
                let [a, b] = self.sk_edges[e as usize];
                if local.contains_key(&a) && local.contains_key(&b) {
                    eids.push(e);
                }
            }
        }
        eids.sort_unstable();
        eids.dedup();
        let edges: Vec<[u32; 2]> = eids
            .iter()
            .map(|&e| {
                let [a, b] = self.sk_edges[e as usize];
                [local[&a], local[&b]]
            })
            .collect();
        drop(local);
        let samples = self.samples_in(rr);
        let n_samples = samples
            .iter()
            .filter(|p| p[0] >= core[0] && p[0] < core[2] && p[1] >= core[1] && p[1] < core[3])
            .count();
        for s in &samples {
            pts.push([s[0], s[1], self.sample_z(*s)]);
            kind.push(3);
            down.push(f64::NAN);
        }
        drop(samples);
        let (t, _) = cdt(&pts, &edges)?;
        let nv = pts.len();

        // Certificate of each face: its circumdisk, clipped to the domain,
        // lies at least one constrained-segment length inside `rr` on every
        // side where `rr` does not reach past the domain.
        let lmax = MAX_SEG * self.lambda;
        let (wm, hm) = (self.wm, self.hm);
        let whole = rr[0] <= 0.0 && rr[1] <= 0.0 && rr[2] >= wm && rr[3] >= hm;
        let certified = |p: [[f64; 3]; 3]| -> bool {
            if whole {
                return true;
            }
            let (ax, ay) = (p[0][0], p[0][1]);
            let (bx, by) = (p[1][0] - ax, p[1][1] - ay);
            let (cx, cy) = (p[2][0] - ax, p[2][1] - ay);
            let d = 2.0 * (bx * cy - by * cx);
            if d == 0.0 {
                return false;
            }
            let (b2, c2) = (bx * bx + by * by, cx * cx + cy * cy);
            let ux = (cy * b2 - by * c2) / d;
            let uy = (bx * c2 - cx * b2) / d;
            let rad = ux.hypot(uy) * (1.0 + 1e-9) + 1e-9 * (wm + hm);
            let (ox, oy) = (ax + ux, ay + uy);
            if !(ox.is_finite() && oy.is_finite() && rad.is_finite()) {
                return false;
            }
            // The disk misses the part of the domain outside rr shrunk by
            // lmax (a strip per side that does not reach past the domain).
            let clear = |x0: f64, y0: f64, x1: f64, y1: f64| {
                let dx = (x0 - ox).max(ox - x1).max(0.0);
                let dy = (y0 - oy).max(oy - y1).max(0.0);
                dx.hypot(dy) > rad
            };
            (rr[0] <= 0.0 || clear(0.0, 0.0, rr[0] + lmax, hm))
                && (rr[1] <= 0.0 || clear(0.0, 0.0, wm, rr[1] + lmax))
                && (rr[2] >= wm || clear(rr[2] - lmax, 0.0, wm, hm))
                && (rr[3] >= hm || clear(0.0, rr[3] - lmax, wm, hm))
        };
        let mut face_ok = vec![false; t.num_all_faces()];
        for f in t.inner_faces() {
            let v = f.vertices().map(|v| pts[v.fix().index()]);
            face_ok[f.fix().index()] = certified(v);
        }
        let on_side = |p: [f64; 3], q: [f64; 3]| {
            (p[0] == 0.0 && q[0] == 0.0)
                || (p[0] == wm && q[0] == wm)
                || (p[1] == 0.0 && q[1] == 0.0)
                || (p[1] == hm && q[1] == hm)
        };
        // Vertex adjacency (CSR) and whether a vertex has its global
        // neighbours (every incident face certified, or the domain border).
        let mut nb_start = vec![0u32; nv + 1];
        let mut nb: Vec<u32> = Vec::with_capacity(6 * nv);
        let mut vok = vec![true; nv];
        for v in t.vertices() {
            let i = v.fix().index();
            for e in v.out_edges() {
                let to = e.to().fix().index();
                nb.push(to as u32);
                match e.face().as_inner() {
                    Some(f) => {
                        if !face_ok[f.fix().index()] {
                            vok[i] = false;
                        }
                    }
                    None => {
                        if !on_side(pts[i], pts[to]) {
                            vok[i] = false;
                        }
                    }
                }
            }
            nb_start[i + 1] = nb.len() as u32;
        }
        for i in 0..nv {
            nb_start[i + 1] = nb_start[i + 1].max(nb_start[i]);
        }
        let faces: Vec<([u32; 3], bool)> = t
            .inner_faces()
            .map(|f| {
                (
                    f.vertices().map(|v| v.fix().index() as u32),
                    face_ok[f.fix().index()],
                )
            })
            .collect();
        drop(t);
        drop(face_ok);

        // Repair, Jacobi rounds; `exact` follows which values are global.
        let nbs = |v: usize| &nb[nb_start[v] as usize..nb_start[v + 1] as usize];
        let mut z: Vec<f64> = pts.iter().map(|p| p[2]).collect();
        let mutable: Vec<bool> = (0..nv).map(|v| kind[v] == 3 || !down[v].is_nan()).collect();
        let mut exact = vec![true; nv];
        let drop_below = 0.5 * self.thr.max(1.0);
        for _ in 0..REPAIR_ROUNDS {
            let mut nz = z.clone();
            let mut nex = exact.clone();
            for v in 0..nv {
                if !mutable[v] {
                    continue;
                }
                nex[v] = exact[v] && vok[v] && nbs(v).iter().all(|&u| exact[u as usize]);
                let (mut lo, mut hi, mut peak) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY);
                for &u in nbs(v) {
                    let zu = z[u as usize];
                    lo = lo.min(zu);
                    hi = hi.max(zu);
                    if kind[u as usize] == 0 {
                        peak = peak.min(zu);
                    }
                }
                if kind[v] == 3 {
                    if hi > lo && (z[v] >= hi || z[v] <= lo) {
                        nz[v] = 0.5 * (lo + hi);
                    }
                    if nz[v] >= peak {
                        nz[v] = peak - drop_below;
                    }
                } else if hi > lo && z[v] >= hi {
                    // A river source that is a maximum: lowered, its river
                    // kept non-increasing.
                    nz[v] = (0.5 * (lo + hi)).max(down[v]);
                }
            }
            z = nz;
            exact = nex;
        }

        // The triangles touching the core: all must be global and exact.
        let mut keep: Vec<[u32; 3]> = Vec::new();
        for (f, ok) in faces {
            let p = f.map(|v| pts[v as usize]);
            let bx0 = p[0][0].min(p[1][0]).min(p[2][0]);
            let by0 = p[0][1].min(p[1][1]).min(p[2][1]);
            let bx1 = p[0][0].max(p[1][0]).max(p[2][0]);
            let by1 = p[0][1].max(p[1][1]).max(p[2][1]);
            if bx1 < core[0] || bx0 > core[2] || by1 < core[1] || by0 > core[3] {
                continue;
            }
            if !(ok && f.iter().all(|&v| exact[v as usize])) {
                return Ok(None);
            }
            // Canonical rotation: the lexicographically smallest vertex first.
            let lo = (0..3)
                .min_by(|&a, &b| {
                    p[a][0]
                        .total_cmp(&p[b][0])
                        .then(p[a][1].total_cmp(&p[b][1]))
                })
                .unwrap_or(0);
            keep.push([f[lo], f[(lo + 1) % 3], f[(lo + 2) % 3]]);
        }
        let key = |t: &[u32; 3]| t.map(|v| [pts[v as usize][0], pts[v as usize][1]]);
        keep.sort_by(|a, b| {
            let (ka, kb) = (key(a), key(b));
            let mut o = std::cmp::Ordering::Equal;
            for i in 0..3 {
                o = o
                    .then(ka[i][0].total_cmp(&kb[i][0]))
                    .then(ka[i][1].total_cmp(&kb[i][1]));
            }
            o
        });
        // Keep only the vertices used.
        let mut remap = vec![u32::MAX; nv];
        let mut xy: Vec<[f64; 2]> = Vec::new();
        let mut zz: Vec<f64> = Vec::new();
        for t in keep.iter_mut() {
            for v in t.iter_mut() {
                let o = *v as usize;
                if remap[o] == u32::MAX {
                    remap[o] = xy.len() as u32;
                    xy.push([pts[o][0], pts[o][1]]);
                    zz.push(z[o]);
                }
                *v = remap[o];
            }
        }
        let tin = Tin::new(
            xy,
            zz,
            keep,
            [core[0], core[1], core[2] - core[0], core[3] - core[1]],
            BUCKET_CELLS * c,
        )?;
        let bytes = tin.heap_bytes() + std::mem::size_of::<Super>();
        Ok(Some(Super {
            tin,
            n_samples,
            bytes,
        }))
    }

    /// Elevation of the cell centre (col + ½, row + ½) in super-tile `st`.
    #[inline]
    /// (surface, whether the cell is a crest or pinch cell, noise).
    pub(super) fn cell_value(&self, st: &Super, col: usize, row: usize) -> (f64, bool, f64) {
        let c = self.cell;
        let (x, y) = ((col as f64 + 0.5) * c, (row as f64 + 0.5) * c);
        let mut v = st.tin.value(x, y);
        let bx = ((x / self.lb) as usize).min(self.lnx - 1);
        let by = ((y / self.lb) as usize).min(self.lny - 1);
        let b = by * self.lnx + bx;
        let (mut crest, mut chan, mut dmin) = (f64::NEG_INFINITY, f64::INFINITY, f64::INFINITY);
        let (mut dridge, mut dchan) = (f64::INFINITY, f64::INFINITY);
        for &i in &self.lids[self.lstart[b] as usize..self.lstart[b + 1] as usize] {
            let l = &self.lines[i as usize];
            let (d, zl) = l.probe(x, y);
            dmin = dmin.min(d);
            if l.kind == LineKind::Ridge {
                dridge = dridge.min(d);
                if d <= self.band {
                    crest = crest.max(zl);
                }
            } else {
                dchan = dchan.min(d);
                if d <= CHANNEL_BAND * c {
                    chan = chan.min(zl);
                }
            }
        }
        v = v.min(chan).max(crest);
        // A crest cell among the 8 neighbours needs a ridge within the
        // band of a neighbour's centre, √2 cells away at most.
        if crest == f64::NEG_INFINITY && dchan <= 1.5 * c && dridge <= self.band + 1.5 * c {
            v = v.min(self.across_crest(b, x, y));
        }
        let mut keep = crest.is_finite();
        for &(sc, sr, sz, k) in &self.pinch[self.pstart[b] as usize..self.pstart[b + 1] as usize] {
            let (dc, dr) = (sc.abs_diff(col as u32), sr.abs_diff(row as u32));
            if dc <= 1
                && dr <= 1
                && (dc, dr) != (0, 0)
                && v > sz
                && !self.calm[self.kstart[b] as usize..self.kstart[b + 1] as usize]
                    .iter()
                    .any(|p| (p.0, p.1) == (col as u32, row as u32))
                && !self.on_other_crest(b, x, y, k)
            {
                v = sz;
                keep = true;
            }
        }
        let mut noise = 0.0;
        if let Some((fbm, amp)) = &self.noise {
            let t = ((dmin - self.band) / (4.0 * c)).clamp(0.0, 1.0);
            let wgt = t * t * (3.0 - 2.0 * t);
            if wgt > 0.0 {
                noise = amp * wgt * fbm.sample(col as f64 + 0.5, row as f64 + 0.5);
            }
            // Near a tree peak, noise lifts no cell above half the
            // threshold under the summit: on a broad summit it could
            // otherwise make a higher cell a few cells off the peak.
            if noise > 0.0 {
                let k = &self.calm[self.kstart[b] as usize..self.kstart[b + 1] as usize];
                for &(pc, pr, pz) in k {
                    if pc.abs_diff(col as u32) <= PEAK_CALM as u32
                        && pr.abs_diff(row as u32) <= PEAK_CALM as u32
                    {
                        noise = noise.min((pz - 0.5 * self.thr - v).max(0.0));
                    }
                }
            }
        }
        (v, keep, noise)
    }

    /// The lowest river level across which a crest cell is an 8-neighbour
    /// of the cell at (x, y) (+∞ if none). The channel band blocks every
    /// 8-step across a river by a cell within √2/2 cell of it, unless that
    /// cell is a crest cell: the crest band wins there (a ridge running
    /// beside a river), and a diagonal step from the crest to the flank
    /// across the river would join two hills above the tree's pass (Alps
    /// seed 3, Dallas seed 2 at 600²; docs/design/orometric-synthesis.md#ridge-clearance-clearancers). So the cell on
    /// the far side takes the block: it reads at most the river.
    pub(super) fn across_crest(&self, b: usize, x: f64, y: f64) -> f64 {
        let c = self.cell;
        let lines = &self.lids[self.lstart[b] as usize..self.lstart[b + 1] as usize];
        let mut level = f64::INFINITY;
        for &i in lines {
            let l = &self.lines[i as usize];
            if l.kind != LineKind::Channel {
                continue;
            }
            let (d, zl) = l.probe(x, y);
            if d > 1.5 * c || zl >= level {
                continue;
            }
            for (dx, dy) in N8 {
                let (nx, ny) = (x + dx as f64 * c, y + dy as f64 * c);
                if !crosses([x, y], [nx, ny], [l.a[0], l.a[1]], [l.b[0], l.b[1]]) {
                    continue;
                }
                let crest = lines.iter().any(|&j| {
                    let r = &self.lines[j as usize];
                    r.kind == LineKind::Ridge && r.probe(nx, ny).0 <= self.band
                });
                if crest {
                    level = zl;
                    break;
                }
            }
        }
        level
    }

    /// Whether (x, y) lies in the crest band of a ridge other than saddle
    /// `k`'s (a pinch must not cut another ridge passing by).
    pub(super) fn on_other_crest(&self, b: usize, x: f64, y: f64, k: u32) -> bool {
        self.lids[self.lstart[b] as usize..self.lstart[b + 1] as usize]
            .iter()
            .map(|&i| &self.lines[i as usize])
            .any(|l| l.kind == LineKind::Ridge && l.saddle != k && l.probe(x, y).0 <= self.band)
    }
}
