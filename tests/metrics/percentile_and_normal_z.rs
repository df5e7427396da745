//! The elevation percentile and the up component of the unit normal against
//! brute force written here: counting lower cells in the square window, and
//! 1/√(1 + p² + q²) from Horn's gradient computed by hand, on a random DEM
//! with ties and nodata holes, in tiles; and the normal on a plane (closed
//! form).

use crate::common::{run, source, Rng, CELL};

const W: usize = 37;
const H: usize = 29;

/// Integer heights (many ties) with about 5 % nodata.
fn dem(seed: u64) -> Vec<f32> {
    let mut r = Rng(seed);
    (0..W * H)
        .map(|_| {
            if r.unit() < 0.05 {
                f32::NAN
            } else {
                (r.unit() * 12.0).floor() as f32 * 5.0 + 100.0
            }
        })
        .collect()
}

#[test]
fn percentile_counts_the_lower_cells_of_the_window() {
    for (seed, r) in [(1u64, 1i64), (2, 2), (3, 4)] {
        let z = dem(seed);
        let got = run(&source(&z, W, H), &format!("percentile:radius={r}c"), 16, 2).remove(0);
        for y in 0..H as i64 {
            for x in 0..W as i64 {
                let c = z[(y * W as i64 + x) as usize];
                let g = got[(y * W as i64 + x) as usize];
                if c.is_nan() {
                    assert!(g.is_nan(), "percentile at a nodata cell ({x}, {y})");
                    continue;
                }
                let (mut lower, mut others) = (0, 0);
                for yy in (y - r).max(0)..=(y + r).min(H as i64 - 1) {
                    for xx in (x - r).max(0)..=(x + r).min(W as i64 - 1) {
                        let v = z[(yy * W as i64 + xx) as usize];
                        if (xx, yy) != (x, y) && !v.is_nan() {
                            others += 1;
                            lower += (v < c) as usize;
                        }
                    }
                }
                if others == 0 {
                    assert!(g.is_nan(), "({x}, {y}) has no other cell");
                } else {
                    let want = 100.0 * lower as f64 / others as f64;
                    assert!(
                        (g as f64 - want).abs() < 1e-4,
                        "r {r} ({x}, {y}): {g}, {lower} of {others} lower = {want}"
                    );
                }
            }
        }
    }
}

#[test]
fn normal_z_is_one_over_the_gradient_norm() {
    let z = dem(7);
    let got = run(&source(&z, W, H), "normal_z", 16, 2).remove(0);
    let at = |x: usize, y: usize| z[y * W + x] as f64;
    let mut n = 0;
    for y in 0..H {
        for x in 0..W {
            let g = got[y * W + x];
            let inside = x > 0 && y > 0 && x < W - 1 && y < H - 1;
            if !inside
                || (y - 1..=y + 1).any(|yy| (x - 1..=x + 1).any(|xx| z[yy * W + xx].is_nan()))
            {
                assert!(
                    g.is_nan(),
                    "normal_z ({x}, {y}) without a full 3x3 window: {g}"
                );
                continue;
            }
            // Horn 1981: east minus west columns, north minus south rows
            // (row y − 1 is north), weights 1, 2, 1, over 8 cells.
            let p = ((at(x + 1, y - 1) + 2.0 * at(x + 1, y) + at(x + 1, y + 1))
                - (at(x - 1, y - 1) + 2.0 * at(x - 1, y) + at(x - 1, y + 1)))
                / (8.0 * CELL);
            let q = ((at(x - 1, y - 1) + 2.0 * at(x, y - 1) + at(x + 1, y - 1))
                - (at(x - 1, y + 1) + 2.0 * at(x, y + 1) + at(x + 1, y + 1)))
                / (8.0 * CELL);
            let want = 1.0 / (1.0 + p * p + q * q).sqrt();
            assert!((g as f64 - want).abs() < 1e-6, "({x}, {y}): {g} vs {want}");
            n += 1;
        }
    }
    assert!(n > W * H / 2, "{n} cells checked");
    // A plane rising 0.3 to the east and 0.4 to the north: 1/√1.25.
    let plane: Vec<f32> = (0..W * H)
        .map(|k| (0.3 * (k % W) as f64 * CELL - 0.4 * (k / W) as f64 * CELL) as f32)
        .collect();
    let got = run(&source(&plane, W, H), "normal_z", 16, 2).remove(0);
    let want = 1.0 / 1.25f64.sqrt();
    for y in 1..H - 1 {
        for x in 1..W - 1 {
            assert!(
                (got[y * W + x] as f64 - want).abs() < 1e-6,
                "plane ({x}, {y})"
            );
        }
    }
}
