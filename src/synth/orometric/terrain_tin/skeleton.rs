//! The global skeleton of the terrain model (O(tree)): ridges and rivers
//! refined to λ, the border frame, the skeleton TIN and its grey-scale
//! reconstruction, the point and line indices ([`TinTerrain::with_supertile`]).

use super::super::reconstruct::reconstruct;
use super::super::rivers::cdt;
use super::super::rivers::dedup;
use super::super::rivers::RiverNetwork;
use super::super::rivers::RiverOptions;
use super::super::terrain::TerrainOptions;
use super::super::tin::Tin;
use super::super::tree_synth::SynthTree;
use super::cache::Cache;
use super::index::bucket_cells;
use super::index::PointGrid;
use super::lines::Line;
use super::lines::LineKind;
use super::TinTerrain;
use super::BUCKET_CELLS;
use super::CHANNEL_BAND;
use super::PEAK_CALM;
use super::SUPERTILE_LAMBDA;
use crate::error::Error;
use crate::error::Result;
use crate::raster::Crs;
use crate::raster::DType;
use crate::raster::GeoRef;
use crate::synth::source_info;
use spade::Triangulation;
use std::sync::atomic::AtomicUsize;

/// Grey-scale reconstruction on the skeleton triangulation (Vincent 1993,
/// on a graph): every river or frame vertex becomes min(its elevation, the
/// highest level at which a path of triangle edges joins it to a ridge
/// vertex), by a priority flood from the ridge vertices (`kind` 0 or 1),
/// highest first. Rivers far from the ridges can otherwise stand as hills
/// of the skeleton (a stretch of river above every river around it), too
/// wide for the per-block reconstruction of the raster. A river stays
/// non-increasing downstream: a node joined to the ridges at level L passes
/// at least min(z, L) to its downstream node, which was at most z.
pub(super) fn reconstruct_skeleton(sk: &mut [[f64; 3]], kind: &[u8], tris: &[[u32; 3]]) {
    let n = sk.len();
    let mut start = vec![0u32; n + 1];
    for t in tris {
        for &v in t {
            start[v as usize + 1] += 2;
        }
    }
    for i in 1..=n {
        start[i] += start[i - 1];
    }
    let mut fill = start.clone();
    let mut adj = vec![0u32; start[n] as usize];
    for t in tris {
        for k in 0..3 {
            let (a, b, c) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
            for u in [b, c] {
                adj[fill[a as usize] as usize] = u;
                fill[a as usize] += 1;
            }
        }
    }
    drop(fill);
    let val: Vec<f64> = sk.iter().map(|p| p[2]).collect();
    let marker: Vec<bool> = kind.iter().map(|&k| k <= 1).collect();
    let level = reconstruct(&val, &marker, |v, buf| {
        buf.extend(
            adj[start[v] as usize..start[v + 1] as usize]
                .iter()
                .map(|&u| u as usize),
        )
    });
    for (p, l) in sk.iter_mut().zip(level) {
        p[2] = l;
    }
}

impl TinTerrain {
    /// As [`TinTerrain::new`] with super-tiles of `side_cells` cells
    /// (rounded up to a multiple of 8; 0: the default 64 λ). The terrain
    /// does not depend on it (see the module doc).
    pub fn with_supertile(
        tree: &SynthTree,
        opts: &TerrainOptions,
        side_cells: usize,
    ) -> Result<TinTerrain> {
        tree.validate()?;
        if !(opts.spacing_m.is_finite() && opts.spacing_m > 0.0) {
            return Err(Error::invalid("terrain: the spacing λ must be positive"));
        }
        if !(opts.jitter.is_finite() && (0.0..=0.5).contains(&opts.jitter)) {
            return Err(Error::invalid(
                "terrain: the ridge jitter must be in [0, 0.5]",
            ));
        }
        if !(opts.valley_width.is_finite() && opts.valley_width >= 0.0) {
            return Err(Error::invalid(
                "terrain: the valley width at 1 km² must be ≥ 0 m",
            ));
        }
        let cell = tree.cell;
        let (wm, hm) = (tree.width as f64 * cell, tree.height as f64 * cell);
        let lambda = opts.spacing_m.max(cell);
        let lb = BUCKET_CELLS * cell;
        let (lnx, lny) = (
            ((wm / lb).ceil() as usize).max(1),
            ((hm / lb).ceil() as usize).max(1),
        );
        if lnx.saturating_mul(lny) > 1 << 28 {
            return Err(Error::invalid(format!(
                "terrain: {} x {} cells is too large (at most 2^28 blocks of 8 x 8 cells); render it in parts",
                tree.width, tree.height
            )));
        }
        let thr = tree.min_prominence;
        let (floor, amp) = opts.floor_and_amplitude(tree)?;
        let mut rivers = RiverNetwork::new(
            tree,
            &RiverOptions {
                spacing_m: lambda,
                jitter: opts.jitter,
                floor,
                margin: thr.max(2.0 * amp),
                river_slope: opts.river_slope,
            },
        )?;
        let mut nodes = std::mem::take(&mut rivers.nodes);
        let ridges = &rivers.ridges;
        let np = tree.peaks.len();
        let nn = nodes.len();

        // Skeleton: ridges (peaks first), river nodes, frame; deduplicated.
        let n_ridge = ridges.pts.len();
        let mut all: Vec<[f64; 3]> = ridges.pts.clone();
        all.extend(nodes.iter().map(|n| [n.x, n.y, n.z]));
        let s0 = all.len();
        all.extend_from_slice(&rivers.frame);
        let (mut sk, map) = dedup(&all);
        drop(all);
        let mut first = vec![u32::MAX; sk.len()];
        for (i, &m) in map.iter().enumerate() {
            if first[m as usize] == u32::MAX {
                first[m as usize] = i as u32;
            }
        }
        let mut has_up = vec![false; nn];
        for n in &nodes {
            if let Some(d) = n.down {
                has_up[d as usize] = true;
            }
        }
        let mut sk_kind = vec![2u8; sk.len()];
        // River sources: (skeleton vertex, downstream node).
        let mut sources: Vec<(usize, usize)> = Vec::new();
        for (v, &f) in first.iter().enumerate() {
            let f = f as usize;
            sk_kind[v] = if f < np {
                0
            } else if f < n_ridge {
                1
            } else {
                2
            };
            if (n_ridge..s0).contains(&f) {
                let i = f - n_ridge;
                if let (false, Some(d)) = (has_up[i], nodes[i].down) {
                    sources.push((v, d as usize));
                }
            }
        }
        drop(first);
        let mut sk_edges: Vec<[u32; 2]> = ridges
            .segs
            .iter()
            .zip(&rivers.ridge_constrained)
            .filter(|(_, &c)| c)
            .map(|(s, _)| [map[s[0] as usize], map[s[1] as usize]])
            .collect();
        for (i, n) in nodes.iter().enumerate() {
            if let Some(d) = n.down {
                sk_edges.push([map[n_ridge + i], map[n_ridge + d as usize]]);
            }
        }
        sk_edges.retain(|e| e[0] != e[1]);
        let node_sk: Vec<u32> = map[n_ridge..s0].to_vec();
        drop(map);
        let mut sk_adj_start = vec![0u32; sk.len() + 1];
        for e in &sk_edges {
            sk_adj_start[e[0] as usize + 1] += 1;
            sk_adj_start[e[1] as usize + 1] += 1;
        }
        for i in 1..sk_adj_start.len() {
            sk_adj_start[i] += sk_adj_start[i - 1];
        }
        let mut fill = sk_adj_start.clone();
        let mut sk_adj = vec![0u32; 2 * sk_edges.len()];
        for (k, e) in sk_edges.iter().enumerate() {
            for &v in e {
                sk_adj[fill[v as usize] as usize] = k as u32;
                fill[v as usize] += 1;
            }
        }
        drop(fill);

        // Skeleton TIN of ridges, rivers and frame: its barycentric value is
        // the flank between them (no interior extremum by construction).
        let (skeleton, dropped) = {
            let (t, dropped) = cdt(&sk, &sk_edges)?;
            let tris: Vec<[u32; 3]> = t
                .inner_faces()
                .map(|f| f.vertices().map(|v| v.fix().index() as u32))
                .collect();
            drop(t);
            reconstruct_skeleton(&mut sk, &sk_kind, &tris);
            for (n, &v) in nodes.iter_mut().zip(&node_sk) {
                n.z = sk[v as usize][2];
            }
            let tin = Tin::new(
                sk.iter().map(|p| [p[0], p[1]]).collect(),
                sk.iter().map(|p| p[2]).collect(),
                tris,
                [0.0, 0.0, wm, hm],
                4.0 * lambda,
            )?;
            (tin, dropped)
        };
        let mut sk_down = vec![f64::NAN; sk.len()];
        for &(v, d) in &sources {
            sk_down[v] = nodes[d].z;
        }
        drop(sources);
        let sk_grid = PointGrid::new(
            sk.iter().map(|p| [p[0], p[1]]).collect(),
            2.0 * lambda,
            wm,
            hm,
        );
        let avoid = PointGrid::new(
            ridges
                .pts
                .iter()
                .map(|p| [p[0], p[1]])
                .chain(nodes.iter().map(|n| [n.x, n.y]))
                .collect(),
            2.0 * lambda,
            wm,
            hm,
        );
        let river_grid = PointGrid::new(
            nodes.iter().map(|n| [n.x, n.y]).collect(),
            4.0 * lambda,
            wm,
            hm,
        );

        // Ridge and river lines, bucketed with the fade reach.
        let mut lines: Vec<Line> = ridges
            .segs
            .iter()
            .zip(&ridges.seg_saddle)
            .map(|(s, &k)| Line {
                a: ridges.pts[s[0] as usize],
                b: ridges.pts[s[1] as usize],
                kind: LineKind::Ridge,
                saddle: k,
            })
            .collect();
        for n in &nodes {
            if let Some(d) = n.down {
                let m = &nodes[d as usize];
                lines.push(Line {
                    a: [n.x, n.y, n.z],
                    b: [m.x, m.y, m.z],
                    kind: LineKind::Channel,
                    saddle: u32::MAX,
                });
            }
        }
        let band = 0.55 * cell;
        let reach = CHANNEL_BAND.max(0.55) * cell + 4.0 * cell;
        let bi = |v: f64, n: usize| ((v / lb).floor().max(0.0) as usize).min(n - 1);
        let span = |l: &Line| {
            (
                bi(l.a[0].min(l.b[0]) - reach, lnx),
                bi(l.a[1].min(l.b[1]) - reach, lny),
                bi(l.a[0].max(l.b[0]) + reach, lnx),
                bi(l.a[1].max(l.b[1]) + reach, lny),
            )
        };
        let mut lstart = vec![0u32; lnx * lny + 1];
        let mut total = 0usize;
        for l in &lines {
            let (x0, y0, x1, y1) = span(l);
            total += (x1 - x0 + 1) * (y1 - y0 + 1);
            for by in y0..=y1 {
                for bx in x0..=x1 {
                    lstart[by * lnx + bx + 1] += 1;
                }
            }
        }
        if total > u32::MAX as usize {
            return Err(Error::invalid(
                "terrain: the line index would be too large; give a larger --spacing",
            ));
        }
        for i in 1..lstart.len() {
            lstart[i] += lstart[i - 1];
        }
        let mut fill = lstart.clone();
        let mut lids = vec![0u32; total];
        for (i, l) in lines.iter().enumerate() {
            let (x0, y0, x1, y1) = span(l);
            for by in y0..=y1 {
                for bx in x0..=x1 {
                    let b = by * lnx + bx;
                    lids[fill[b] as usize] = i as u32;
                    fill[b] += 1;
                }
            }
        }
        drop(fill);
        let noise = opts.noise(tree, amp);
        let b = BUCKET_CELLS as usize;
        let side = if side_cells > 0 {
            side_cells
        } else {
            (SUPERTILE_LAMBDA * lambda / cell).ceil() as usize
        };
        let side = side.div_ceil(b).max(1) * b;
        let nsx = tree.width.div_ceil(side);
        let georef = GeoRef::north_up(0.0, hm, cell, Crs::default());
        let dropped = dropped + rivers.dropped_ridges;
        // Saddle pinches: the crest band keeps a ridge 8-connected, so
        // where it bends at a saddle the two crest cells beside the saddle
        // cell can touch diagonally and bypass it (a pass above the tree's
        // saddle). The cells around a saddle cell read at most the saddle.
        let cell_of = |x: f64, y: f64| {
            (
                ((x / cell).floor().clamp(0.0, (tree.width - 1) as f64)) as u32,
                ((y / cell).floor().clamp(0.0, (tree.height - 1) as f64)) as u32,
            )
        };
        let saddle_cells: Vec<(u32, u32, f64, u32)> = tree
            .saddles
            .iter()
            .enumerate()
            .map(|(k, s)| {
                let (c, r) = cell_of(s.x, s.y);
                (c, r, s.elevation, k as u32)
            })
            .collect();
        let (pstart, pinch) = bucket_cells(&saddle_cells, |p| (p.0, p.1), 1, b, lnx, lny);
        let peak_list: Vec<(u32, u32, f64)> = tree
            .peaks
            .iter()
            .map(|p| {
                let (c, r) = cell_of(p.x, p.y);
                (c, r, p.elevation)
            })
            .collect();
        let (kstart, calm) =
            bucket_cells(&peak_list, |p| (p.0, p.1), PEAK_CALM as u32, b, lnx, lny);
        rivers.nodes = nodes;
        Ok(TinTerrain {
            info: source_info(
                tree.width,
                tree.height,
                DType::F32,
                georef,
                "<orometric-tin>",
            ),
            cell,
            wm,
            hm,
            lambda,
            thr,
            seed: tree.seed,
            floor,
            valley_width: opts.valley_width,
            rivers,
            sk,
            sk_kind,
            sk_down,
            sk_edges,
            sk_adj_start,
            sk_adj,
            sk_grid,
            avoid,
            skeleton,
            river_grid,
            lines,
            lb,
            lnx,
            lny,
            lstart,
            lids,
            pstart,
            pinch,
            kstart,
            calm,
            band,
            noise,
            side,
            nsx,
            cache: Cache::new(),
            blocks: Cache::new(),
            built: AtomicUsize::new(0),
            retried: AtomicUsize::new(0),
            samples: AtomicUsize::new(0),
            dropped,
        })
    }
}
