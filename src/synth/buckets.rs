//! The ring walk of the bucket grids of the synthesis (nearest point,
//! nearest higher peak): the buckets at Chebyshev distance exactly `r` from
//! a bucket, so that a search can grow ring by ring and stop once the ring's
//! lower bound on distance exceeds the best found (the grid search of
//! Bentley, Weide & Yao 1980, "Optimal expected-time algorithms for closest
//! point problems", ACM TOMS 6(4)).

/// Call `f(bucket)` for every bucket of ring `r` around bucket `(cx, cy)` of
/// a grid of `nx` x `ny` buckets (row-major ids), clipped to the grid: row by
/// row from the north, west to east in each row.
#[inline]
pub(crate) fn for_each_in_ring(
    (cx, cy): (usize, usize),
    r: usize,
    (nx, ny): (usize, usize),
    mut f: impl FnMut(usize),
) {
    let (x0, x1) = (cx as i64 - r as i64, cx as i64 + r as i64);
    let (y0, y1) = (cy as i64 - r as i64, cy as i64 + r as i64);
    for y in y0..=y1 {
        if y < 0 || y >= ny as i64 {
            continue;
        }
        let edge_row = y == y0 || y == y1;
        let mut x = x0;
        while x <= x1 {
            if x >= 0 && x < nx as i64 {
                f(y as usize * nx + x as usize);
            }
            x = if edge_row || x == x1 { x + 1 } else { x1 };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::for_each_in_ring;

    #[test]
    fn rings_cover_the_grid_once_each() {
        // Every bucket lies in exactly one ring: its Chebyshev distance.
        let (nx, ny) = (7usize, 5usize);
        let c = (2usize, 3usize);
        let mut seen = vec![0u32; nx * ny];
        for r in 0..=7 {
            for_each_in_ring(c, r, (nx, ny), |b| {
                let (x, y) = (b % nx, b / nx);
                let d = (x as i64 - 2).abs().max((y as i64 - 3).abs());
                assert_eq!(d, r as i64, "bucket ({x}, {y}) in ring {r}");
                seen[b] += 1;
            });
        }
        assert!(seen.iter().all(|&k| k == 1), "{seen:?}");
    }
}
