//! Poisson-disc samples of a rectangle (Bridson 2007, "Fast Poisson disk
//! sampling in arbitrary dimensions", SIGGRAPH sketches): the nodes of the
//! river network.

use super::Rng;

/// Poisson-disc samples in [0, w) x [0, h) with spacing r (Bridson 2007,
/// 30 candidates per active sample), then gap filling so that every point
/// of the rectangle is within 2.5 r of a sample.
pub fn poisson_disc(w: f64, h: f64, r: f64, seed: u64) -> Vec<[f64; 2]> {
    let cs = r / std::f64::consts::SQRT_2;
    let gw = (w / cs).ceil() as usize;
    let gh = (h / cs).ceil() as usize;
    let mut grid = vec![u32::MAX; gw * gh];
    let mut pts: Vec<[f64; 2]> = Vec::new();
    let mut rng = Rng(seed ^ 0x005e_ed0f_d15c);
    let cell =
        |p: [f64; 2]| ((p[0] / cs) as usize).min(gw - 1) + ((p[1] / cs) as usize).min(gh - 1) * gw;
    let free = |pts: &[[f64; 2]], grid: &[u32], p: [f64; 2], rr: f64| -> bool {
        let (cx, cy) = ((p[0] / cs) as i64, (p[1] / cs) as i64);
        let reach = (rr / cs).ceil() as i64;
        for y in (cy - reach).max(0)..=(cy + reach).min(gh as i64 - 1) {
            for x in (cx - reach).max(0)..=(cx + reach).min(gw as i64 - 1) {
                let i = grid[y as usize * gw + x as usize];
                if i != u32::MAX {
                    let q = pts[i as usize];
                    if (q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2) < rr * rr {
                        return false;
                    }
                }
            }
        }
        true
    };
    let first = [rng.unit() * w, rng.unit() * h];
    grid[cell(first)] = 0;
    pts.push(first);
    let mut active = vec![0u32];
    while !active.is_empty() {
        let k = (rng.next() % active.len() as u64) as usize;
        let base = pts[active[k] as usize];
        let mut found = false;
        for _ in 0..30 {
            let a = rng.unit() * std::f64::consts::TAU;
            let d = r * (1.0 + rng.unit());
            let q = [base[0] + d * a.cos(), base[1] + d * a.sin()];
            if q[0] >= 0.0 && q[1] >= 0.0 && q[0] < w && q[1] < h && free(&pts, &grid, q, r) {
                grid[cell(q)] = pts.len() as u32;
                active.push(pts.len() as u32);
                pts.push(q);
                found = true;
                break;
            }
        }
        if !found {
            active.swap_remove(k);
        }
    }
    // Gap filling: a grid-cell centre with no sample within 2r gets one (it is
    // then more than r from all others). Grid cells have half-diagonal r/2.
    for gy in 0..gh {
        for gx in 0..gw {
            let c = [
                ((gx as f64 + 0.5) * cs).min(w * 0.999_999),
                ((gy as f64 + 0.5) * cs).min(h * 0.999_999),
            ];
            if grid[cell(c)] == u32::MAX && free(&pts, &grid, c, 2.0 * r) {
                grid[cell(c)] = pts.len() as u32;
                pts.push(c);
            }
        }
    }
    pts
}
