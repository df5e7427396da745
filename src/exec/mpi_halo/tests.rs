//! Tests of the halo plans and transports.

use super::*;

/// Brute force: the set of cells of `rects`.
fn cells(rects: &[Window]) -> std::collections::BTreeSet<(i64, i64)> {
    let mut s = std::collections::BTreeSet::new();
    for r in rects {
        for y in r.y..r.y_end() {
            for x in r.x..r.x_end() {
                s.insert((x, y));
            }
        }
    }
    s
}

#[test]
fn partition_is_contiguous_and_even() {
    let l = TileLayout::new(367, 359, 50); // 8 x 8 = 64 tiles
    for ranks in 1..=7 {
        let o = partition(&l, ranks);
        assert_eq!(o.len(), 64);
        assert!(o.windows(2).all(|w| w[0] <= w[1] && w[1] - w[0] <= 1));
        let sizes: Vec<usize> = (0..ranks)
            .map(|r| o.iter().filter(|&&x| x == r).count())
            .collect();
        assert_eq!(sizes.iter().sum::<usize>(), 64);
        let (mn, mx) = (sizes.iter().min().unwrap(), sizes.iter().max().unwrap());
        assert!(mx - mn <= 1, "{ranks} ranks: {sizes:?}");
    }
    // More ranks than tiles: the last ranks own nothing.
    let o = partition(&TileLayout::new(10, 10, 5), 6);
    assert_eq!(o, vec![0, 1, 2, 3]);
}

#[test]
fn disjoint_cover_matches_the_union() {
    let sets: Vec<Vec<Window>> = vec![
        vec![],
        vec![Window::new(3, 4, 5, 2)],
        // L-shape (right strip + bottom strip of a tile), overlapping.
        vec![Window::new(40, 0, 10, 50), Window::new(0, 45, 50, 5)],
        // Nested, touching and disjoint pieces.
        vec![
            Window::new(0, 0, 10, 3),
            Window::new(2, 1, 3, 1),
            Window::new(10, 0, 4, 3),
            Window::new(20, 2, 2, 6),
            Window::new(0, 3, 14, 1),
        ],
    ];
    for rects in sets {
        let cover = disjoint_cover(&rects);
        let total: usize = cover.iter().map(|w| w.len()).sum();
        let want = cells(&rects);
        assert_eq!(total, want.len(), "overlap in {cover:?}");
        assert_eq!(cells(&cover), want);
        // Canonical: order of the input does not matter.
        let mut rev = rects.clone();
        rev.reverse();
        assert_eq!(disjoint_cover(&rev), cover);
    }
    // A full-width strip stays one rectangle.
    let c = disjoint_cover(&[Window::new(0, 0, 50, 4), Window::new(0, 0, 9, 4)]);
    assert_eq!(c, vec![Window::new(0, 0, 50, 4)]);
}

/// A value that identifies field and global cell.
fn val(f: usize, x: i64, y: i64) -> f64 {
    (f * 1_000_000) as f64 + (y * 1000 + x) as f64 + 0.25
}

fn tile_state(layout: &TileLayout, id: TileId, nf: usize) -> Vec<f64> {
    let w = layout.window(id);
    let mut v = Vec::with_capacity(w.len() * nf);
    for f in 0..nf {
        for y in w.y..w.y_end() {
            for x in w.x..w.x_end() {
                v.push(val(f, x, y));
            }
        }
    }
    v
}

/// Every rank's plan, strips extracted from the owners' tiles, "sent"
/// and pasted with the local tiles into each patch, equals the patch
/// copied cell by cell from the global state; and each rank receives
/// exactly the distinct remote cells its patches need.
#[test]
fn strips_rebuild_every_patch() {
    let nf = 3;
    for &(w, h, tile, ghost) in &[
        (37usize, 29usize, 8usize, 3usize),
        (37, 29, 8, 11), // ghost wider than a tile
        (64, 16, 16, 4),
        (23, 41, 7, 1),
        (20, 20, 32, 5), // one tile
    ] {
        let layout = TileLayout::new(w, h, tile);
        let states: Vec<Vec<f64>> = (0..layout.count())
            .map(|id| tile_state(&layout, id, nf))
            .collect();
        for ranks in 1..=5 {
            let owner = partition(&layout, ranks);
            let plans: Vec<HaloPlan> = (0..ranks)
                .map(|r| HaloPlan::new(&layout, ghost, owner.clone(), (r, ranks), nf).unwrap())
                .collect();
            // Messages: outbox[p][q].
            let outbox: Vec<Vec<Vec<f64>>> = plans
                .iter()
                .map(|pl| {
                    let mut out = vec![Vec::new(); ranks];
                    for (q, strips) in pl.sends.iter().enumerate() {
                        for s in strips {
                            let tw = layout.window(s.tile);
                            extract(tw, &states[s.tile], nf, s.win, &mut out[q]);
                        }
                    }
                    out
                })
                .collect();
            for (r, pl) in plans.iter().enumerate() {
                assert_eq!(
                    pl.mine,
                    (0..layout.count())
                        .filter(|&t| owner[t] == r)
                        .collect::<Vec<_>>()
                );
                let inbox: Vec<&Vec<f64>> = (0..ranks).map(|p| &outbox[p][r]).collect();
                for (p, msg) in inbox.iter().enumerate() {
                    assert_eq!(msg.len(), pl.recv_len[p], "{ranks} ranks, {p}->{r}");
                }
                // Distinct remote cells this rank's patches need.
                let mut want_remote = std::collections::BTreeSet::new();
                for &id in &pl.mine {
                    let pw = patch_window(&layout, id, ghost);
                    let mut fields = vec![vec![f64::NAN; pw.len()]; nf];
                    for tid in layout.tiles_in(&pw) {
                        let tw = layout.window(tid);
                        let iw = tw.intersect(&pw).unwrap();
                        if owner[tid] == r {
                            paste(pw, &mut fields, tw, &states[tid], iw);
                        } else {
                            for y in iw.y..iw.y_end() {
                                for x in iw.x..iw.x_end() {
                                    want_remote.insert((x, y));
                                }
                            }
                            for g in &pl.ghosts[tid] {
                                let n = g.win.len() * nf;
                                let src = &inbox[g.from][g.offset..g.offset + n];
                                paste(pw, &mut fields, g.win, src, iw);
                            }
                        }
                    }
                    for (f, field) in fields.iter().enumerate() {
                        for y in 0..pw.h {
                            for x in 0..pw.w {
                                let (gx, gy) = (pw.x + x as i64, pw.y + y as i64);
                                assert_eq!(
                                    field[y * pw.w + x].to_bits(),
                                    val(f, gx, gy).to_bits(),
                                    "{w}x{h} tile {tile} ghost {ghost}, {ranks} ranks: rank {r} tile {id} field {f} cell ({gx},{gy})"
                                );
                            }
                        }
                    }
                }
                let got: usize = pl.recv_len.iter().sum();
                assert_eq!(got, want_remote.len() * nf, "no cell received twice");
            }
        }
    }
}
