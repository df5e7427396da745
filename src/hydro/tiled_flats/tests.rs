//! Unit tests of the tiled flat solver.

use super::*;

#[test]
fn level_bfs_matches_brute_force_relaxation() {
    // a 9x7 grid with a wall, seeds at different start distances
    let (w, h) = (9, 7);
    let pass: Vec<bool> = (0..w * h).map(|i| !(i % w == 4 && i / w < 5)).collect();
    let mut seeds = vec![(5u32, 0u32), (0, 8), (3, 62), (9, 0)];
    let mut dist = vec![FAR; w * h];
    level_bfs(&pass, w, h, &mut seeds, &mut dist);
    // Bellman-Ford oracle
    let mut want = vec![FAR; w * h];
    for &(d, c) in &seeds {
        want[c as usize] = want[c as usize].min(d);
    }
    loop {
        let mut changed = false;
        for c in 0..w * h {
            if !pass[c] || want[c] == FAR {
                continue;
            }
            let (x, y) = ((c % w) as i64, (c / w) as i64);
            for d in 0..8 {
                let (nx, ny) = (x + DX[d], y + DY[d]);
                if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                    continue;
                }
                let m = ny as usize * w + nx as usize;
                if pass[m] && want[c] + 1 < want[m] {
                    want[m] = want[c] + 1;
                    changed = true;
                }
            }
        }
        if !changed {
            break;
        }
    }
    for c in 0..w * h {
        if pass[c] {
            assert_eq!(dist[c], want[c], "cell {c}");
        }
    }
    assert_eq!(dist[8], 0);
    assert_eq!(dist[0], 5);
}
