//! One-dimensional Earth Mover's Distance between histograms.
//!
//! For two distributions on the real line the optimal-transport cost with
//! ground distance |x − y| equals the L1 distance between their cumulative
//! distribution functions, EMD = ∫ |F(x) − G(x)| dx (Vallender 1974,
//! "Calculation of the Wasserstein distance between probability
//! distributions on the line", Theory Probab. Appl. 18(4)). With the mass
//! of bin i placed at position x_i (sorted), F and G are step functions and
//! the integral is Σ_i |F_i − G_i| · (x_{i+1} − x_i); for equal bins this is
//! the L1 distance between the CDFs times the bin width.

/// EMD between histograms `p` and `q` whose bins carry their mass at the
/// increasing positions `x` (same length). Each histogram is normalised to
/// sum 1 first; both empty gives 0, one empty (or any length mismatch,
/// negative or non-finite mass) gives NaN. In the units of `x`.
pub fn emd_1d(x: &[f64], p: &[f64], q: &[f64]) -> f64 {
    if x.len() != p.len() || x.len() != q.len() {
        return f64::NAN;
    }
    let ok = |v: &[f64]| v.iter().all(|m| m.is_finite() && *m >= 0.0);
    if !ok(p) || !ok(q) || x.iter().any(|v| !v.is_finite()) {
        return f64::NAN;
    }
    let (sp, sq): (f64, f64) = (p.iter().sum(), q.iter().sum());
    match (sp > 0.0, sq > 0.0) {
        (false, false) => return 0.0,
        (true, true) => {}
        _ => return f64::NAN,
    }
    let (mut fp, mut fq, mut d) = (0.0, 0.0, 0.0);
    for i in 0..x.len().saturating_sub(1) {
        fp += p[i] / sp;
        fq += q[i] / sq;
        d += (fp - fq).abs() * (x[i + 1] - x[i]);
    }
    d
}

/// Mass positions of bins with `edges` (len = bins + 1): the bin centres;
/// an open-ended last bin (edge infinite or `f64::MAX`) is placed half the
/// previous bin's width beyond its lower edge.
pub fn bin_positions(edges: &[f64]) -> Vec<f64> {
    let n = edges.len().saturating_sub(1);
    (0..n)
        .map(|i| {
            let (a, b) = (edges[i], edges[i + 1]);
            if b.is_finite() && b < f64::MAX {
                0.5 * (a + b)
            } else {
                let prev = if i > 0 { a - edges[i - 1] } else { 1.0 };
                a + 0.5 * prev
            }
        })
        .collect()
}

/// Total variation distance ½ Σ |p − q| of two normalised copies of `p`
/// and `q` (for categories without order, e.g. landform classes); 0 when
/// both are empty, NaN when one is.
pub fn total_variation(p: &[f64], q: &[f64]) -> f64 {
    let (sp, sq): (f64, f64) = (p.iter().sum(), q.iter().sum());
    match (sp > 0.0, sq > 0.0) {
        (false, false) => 0.0,
        (true, true) if p.len() == q.len() => {
            0.5 * p
                .iter()
                .zip(q)
                .map(|(a, b)| (a / sp - b / sq).abs())
                .sum::<f64>()
        }
        _ => f64::NAN,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Brute-force oracle: expand integer histograms into equal numbers of
    /// samples and take the cheapest of all one-to-one assignments.
    fn brute(x: &[f64], p: &[u32], q: &[u32]) -> f64 {
        let expand = |h: &[u32]| -> Vec<f64> {
            h.iter()
                .enumerate()
                .flat_map(|(i, &c)| std::iter::repeat_n(x[i], c as usize))
                .collect()
        };
        let (a, b) = (expand(p), expand(q));
        assert_eq!(a.len(), b.len());
        let n = a.len();
        let mut perm: Vec<usize> = (0..n).collect();
        let mut best = f64::INFINITY;
        // Heap's algorithm over all permutations.
        fn heap(k: usize, perm: &mut Vec<usize>, a: &[f64], b: &[f64], best: &mut f64) {
            if k == 1 {
                let c: f64 = perm
                    .iter()
                    .enumerate()
                    .map(|(i, &j)| (a[i] - b[j]).abs())
                    .sum();
                *best = best.min(c);
                return;
            }
            for i in 0..k {
                heap(k - 1, perm, a, b, best);
                let j = if k.is_multiple_of(2) { i } else { 0 };
                perm.swap(j, k - 1);
            }
        }
        heap(n, &mut perm, &a, &b, &mut best);
        best / n as f64
    }

    #[test]
    fn matches_brute_force_assignment() {
        // Deterministic pseudo-random small cases (xorshift).
        let mut s = 0x9e3779b97f4a7c15u64;
        let mut rnd = |m: u64| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            s % m
        };
        for _ in 0..60 {
            let nb = 2 + rnd(4) as usize;
            let total = 1 + rnd(6) as u32;
            let mut x = vec![0.0; nb];
            for i in 1..nb {
                x[i] = x[i - 1] + 0.5 + rnd(5) as f64;
            }
            let mut draw = |t: u32| {
                let mut h = vec![0u32; nb];
                for _ in 0..t {
                    h[rnd(nb as u64) as usize] += 1;
                }
                h
            };
            let (p, q) = (draw(total), draw(total));
            let pf: Vec<f64> = p.iter().map(|&v| v as f64).collect();
            let qf: Vec<f64> = q.iter().map(|&v| v as f64).collect();
            let got = emd_1d(&x, &pf, &qf);
            let want = brute(&x, &p, &q);
            assert!(
                (got - want).abs() < 1e-9,
                "{x:?} {p:?} {q:?}: {got} vs {want}"
            );
        }
    }

    #[test]
    fn closed_forms_and_edge_cases() {
        let x = [0.5, 1.5, 2.5, 3.5];
        // All mass moved three bins: distance 3 bin widths.
        assert_eq!(
            emd_1d(&x, &[1.0, 0.0, 0.0, 0.0], &[0.0, 0.0, 0.0, 2.0]),
            3.0
        );
        assert_eq!(
            emd_1d(&x, &[0.2, 0.3, 0.5, 0.0], &[0.2, 0.3, 0.5, 0.0]),
            0.0
        );
        assert_eq!(emd_1d(&x, &[0.0; 4], &[0.0; 4]), 0.0);
        assert!(emd_1d(&x, &[0.0; 4], &[1.0, 0.0, 0.0, 0.0]).is_nan());
        assert!(emd_1d(&x, &[f64::NAN, 0.0, 0.0, 0.0], &[1.0, 0.0, 0.0, 0.0]).is_nan());
        assert!(emd_1d(&x[..3], &[1.0; 4], &[1.0; 4]).is_nan());
        assert_eq!(
            bin_positions(&[0.0, 1.0, 3.0, f64::INFINITY]),
            vec![0.5, 2.0, 4.0]
        );
        assert_eq!(total_variation(&[1.0, 0.0], &[0.0, 3.0]), 1.0);
        assert_eq!(total_variation(&[1.0, 1.0], &[2.0, 2.0]), 0.0);
    }
}
