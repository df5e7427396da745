//! Step 2 of the tectonic-folds pipeline: merging adjacent sub-plates whose
//! velocities agree and whose sizes are comparable ([`merge_plates`]).

use crate::raster::UnionFind;

/// Merge adjacent plates (see the module doc, step 2). `area[i]` and `vel[i]`
/// describe plate i, `adjacent` lists pairs of touching plates. Returns each
/// plate's merged label, numbered 0.. in the order of each group's smallest
/// plate id, and the merged velocities (area-weighted means).
pub fn merge_plates(
    area: &[f64],
    vel: &[[f64; 2]],
    adjacent: &[(u32, u32)],
    t1: f64,
    t2: f64,
) -> (Vec<u32>, Vec<[f64; 2]>) {
    let n = area.len();
    let mut root = UnionFind::<u32>::new(n);
    let mut a: Vec<f64> = area.to_vec();
    let mut mom: Vec<[f64; 2]> = (0..n)
        .map(|i| [vel[i][0] * area[i], vel[i][1] * area[i]])
        .collect();
    let unit = |m: [f64; 2], a: f64| -> Option<[f64; 2]> {
        if a <= 0.0 {
            return None;
        }
        let (x, y) = (m[0] / a, m[1] / a);
        let l = (x * x + y * y).sqrt();
        (l > 0.0 && l.is_finite()).then(|| [x / l, y / l])
    };
    let mut pairs: Vec<(u32, u32)> = adjacent
        .iter()
        .filter(|(i, j)| i != j && (*i as usize) < n && (*j as usize) < n)
        .map(|&(i, j)| (i.min(j), i.max(j)))
        .collect();
    loop {
        for p in pairs.iter_mut() {
            let (i, j) = (root.find(p.0), root.find(p.1));
            *p = (i.min(j), i.max(j));
        }
        pairs.retain(|p| p.0 != p.1);
        pairs.sort_unstable();
        pairs.dedup();
        let mut best: Option<(f64, (u32, u32))> = None;
        for &(i, j) in &pairs {
            let (ai, aj) = (a[i as usize], a[j as usize]);
            let (Some(ui), Some(uj)) = (unit(mom[i as usize], ai), unit(mom[j as usize], aj))
            else {
                continue;
            };
            let dot = ui[0] * uj[0] + ui[1] * uj[1];
            let ratio = ai.min(aj) / ai.max(aj);
            if dot >= t1 && ratio >= t2 && best.is_none_or(|(d, _)| dot > d) {
                best = Some((dot, (i, j)));
            }
        }
        let Some((_, (i, j))) = best else { break };
        // Merge j into i (i < j: the group keeps its smallest id as root).
        root.union_into(i, j);
        a[i as usize] += a[j as usize];
        mom[i as usize][0] += mom[j as usize][0];
        mom[i as usize][1] += mom[j as usize][1];
    }
    let mut label = vec![u32::MAX; n];
    let mut out_vel = Vec::new();
    let mut group = vec![0u32; n];
    for (i, gi) in group.iter_mut().enumerate() {
        let r = root.find(i as u32) as usize;
        if label[r] == u32::MAX {
            label[r] = out_vel.len() as u32;
            out_vel.push(if a[r] > 0.0 {
                [mom[r][0] / a[r], mom[r][1] / a[r]]
            } else {
                [0.0, 0.0]
            });
        }
        *gi = label[r];
    }
    (group, out_vel)
}
