//! Depressions of a DEM measured against its filled surface: the cells the
//! fill raised, grouped into 8-connected regions, with their volume and area.
//! Used by the realism report (`compare`) and the example-based synthesis's
//! pit statistics. A depression of the Priority-Flood fill (Barnes, Lehman &
//! Mulla 2014) is a connected set of cells whose filled elevation is above the
//! DEM's.

use crate::raster::Grid;

/// Depression statistics of a DEM.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Depressions {
    /// Connected (8-neighbour) regions of raised cells.
    pub count: usize,
    /// Raised cells.
    pub cells: usize,
    /// Σ (filled − z) · cell area (elevation units × area units).
    pub volume: f64,
    /// Σ cell area over the raised cells.
    pub area: f64,
    /// Regions whose deepest cell is at least `min_depth` deep.
    pub deep: usize,
}

/// Group the cells `filled` raises above `dem` (NaN = nodata, never raised)
/// into 8-connected regions; `row_area[y]` is the area of a cell of row `y`.
/// `min_depth` sets what `deep` counts.
pub fn depressions(
    dem: &Grid<f32>,
    filled: &Grid<f32>,
    row_area: &[f64],
    min_depth: f32,
) -> Depressions {
    let (w, h) = (dem.width(), dem.height());
    debug_assert_eq!(row_area.len(), h);
    let (z, f) = (dem.data(), filled.data());
    let raised: Vec<bool> = z.iter().zip(f).map(|(&a, &b)| b > a).collect();
    let mut seen = vec![false; w * h];
    let mut stack: Vec<usize> = Vec::new();
    let mut out = Depressions {
        count: 0,
        cells: 0,
        volume: 0.0,
        area: 0.0,
        deep: 0,
    };
    for start in 0..w * h {
        if !raised[start] || seen[start] {
            continue;
        }
        out.count += 1;
        seen[start] = true;
        stack.push(start);
        let mut depth = 0f32;
        while let Some(i) = stack.pop() {
            let (x, y) = (i % w, i / w);
            out.cells += 1;
            out.volume += (f[i] as f64 - z[i] as f64) * row_area[y];
            out.area += row_area[y];
            depth = depth.max(f[i] - z[i]);
            for ny in y.saturating_sub(1)..=(y + 1).min(h - 1) {
                for nx in x.saturating_sub(1)..=(x + 1).min(w - 1) {
                    let n = ny * w + nx;
                    if raised[n] && !seen[n] {
                        seen[n] = true;
                        stack.push(n);
                    }
                }
            }
        }
        if depth >= min_depth {
            out.deep += 1;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_pits_counted_with_volume_and_depth() {
        // Row-major 5x4; two separate raised regions: one cell 2 deep, two cells 1 deep.
        let dem = Grid::from_vec(
            5,
            4,
            vec![
                5., 5., 5., 5., 5., 5., 3., 5., 4., 5., 5., 5., 5., 4., 5., 5., 5., 5., 5., 5.,
            ],
        )
        .unwrap();
        let filled = Grid::from_vec(
            5,
            4,
            vec![
                5., 5., 5., 5., 5., 5., 5., 5., 5., 5., 5., 5., 5., 5., 5., 5., 5., 5., 5., 5.,
            ],
        )
        .unwrap();
        let d = depressions(&dem, &filled, &[10.0, 10.0, 20.0, 10.0], 1.5);
        assert_eq!(d.count, 2);
        assert_eq!(d.cells, 3);
        assert_eq!(d.volume, 2.0 * 10.0 + 1.0 * 10.0 + 1.0 * 20.0);
        assert_eq!(d.area, 40.0);
        assert_eq!(d.deep, 1);
    }
}
