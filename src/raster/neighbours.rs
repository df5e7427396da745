//! The 3x3 neighbourhood of a cell: the D8 neighbour order every routing
//! and labelling pass uses, the neighbours' distances and indices, and Horn's 3x3
//! gradient (shared by terrain metrics and hydrological indices).

/// Column offsets of the 8 neighbours in the order E, SE, S, SW, W, NW, N, NE.
pub const DX: [i64; 8] = [1, 1, 0, -1, -1, -1, 0, 1];
/// Row offsets of the 8 neighbours (y grows southwards).
pub const DY: [i64; 8] = [0, 1, 1, 1, 0, -1, -1, -1];
/// The 8 neighbours' `(dx, dy)` in the same order (`DX`, `DY` zipped); the
/// opposite of neighbour `k` is `k ^ 4`.
pub const OFFSETS: [(i64, i64); 8] = {
    let mut o = [(0, 0); 8];
    let mut k = 0;
    while k < 8 {
        o[k] = (DX[k], DY[k]);
        k += 1;
    }
    o
};

/// Distance to each neighbour in cell sizes, order E..NE.
pub const DIST: [f64; 8] = [
    1.0,
    std::f64::consts::SQRT_2,
    1.0,
    std::f64::consts::SQRT_2,
    1.0,
    std::f64::consts::SQRT_2,
    1.0,
    std::f64::consts::SQRT_2,
];

/// Index of neighbour `d` (order E..NE) of cell (x, y) in a row-major
/// `w x h` grid, or `None` beyond the grid.
#[inline]
pub fn neighbour(x: usize, y: usize, d: usize, w: usize, h: usize) -> Option<usize> {
    let nx = x as i64 + DX[d];
    let ny = y as i64 + DY[d];
    if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
        None
    } else {
        Some(ny as usize * w + nx as usize)
    }
}

/// Horn's gradient (dz/dx east, dz/dy north) of a 3x3 window (row-major,
/// north row first), in z units per metre for cell sizes `ew` x `ns` metres.
///
/// Source: Horn, B.K.P. (1981), "Hill shading and the reflectance map",
/// Proc. IEEE 69(1), 14-47, eq. for the 3x3 weighted gradient:
/// `dz/dx = ((c + 2f + i) - (a + 2d + g)) / (8 Δx)`,
/// `dz/dy = ((a + 2b + c) - (g + 2h + i)) / (8 Δy)` (y pointing north).
#[inline]
pub fn horn_gradient(w: &[f64; 9], ew: f64, ns: f64) -> (f64, f64) {
    let dzdx = ((w[2] + 2.0 * w[5] + w[8]) - (w[0] + 2.0 * w[3] + w[6])) / (8.0 * ew);
    let dzdy = ((w[0] + 2.0 * w[1] + w[2]) - (w[6] + 2.0 * w[7] + w[8])) / (8.0 * ns);
    (dzdx, dzdy)
}

/// The spacing of one row of cells to its 8 neighbours, as routing needs it:
/// distances (order E..NE), the two legs and hypotenuse of each D∞ facet and
/// Quinn's contour lengths, all in one unit common to the whole raster
/// (metres on geographic grids, cells otherwise; routers compare ratios
/// only, so the unit never shows in their results).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RowGeometry {
    /// Distance to each neighbour, order E, SE, S, SW, W, NW, N, NE.
    pub dist: [f64; 8],
    /// Per D∞ facet in Tarboton's order (E–NE, N–NE, N–NW, W–NW, W–SW,
    /// S–SW, S–SE, E–SE): the distance to its edge neighbour e1, the
    /// spacing from e1 to its diagonal neighbour e2, the facet's angle
    /// `atan(d2/d1)` and its hypotenuse.
    pub facet: [(f64, f64, f64, f64); 8],
    /// Contour length across which a cell drains to each neighbour (Quinn et
    /// al. 1991: half the face for edge neighbours, a quarter of the
    /// diagonal for diagonal ones; 0.5 and √2/4 cell sizes on square cells).
    pub contour: [f64; 8],
}

impl RowGeometry {
    /// Square cells of unit size: [`DIST`], facets (1, 1, π/4, √2) and
    /// Quinn's (0.5, √2/4), exactly the constants of the square-cell papers.
    pub const SQUARE: RowGeometry = RowGeometry {
        dist: DIST,
        facet: [(
            1.0,
            1.0,
            std::f64::consts::FRAC_PI_4,
            std::f64::consts::SQRT_2,
        ); 8],
        contour: [
            0.5,
            std::f64::consts::SQRT_2 / 4.0,
            0.5,
            std::f64::consts::SQRT_2 / 4.0,
            0.5,
            std::f64::consts::SQRT_2 / 4.0,
            0.5,
            std::f64::consts::SQRT_2 / 4.0,
        ],
    };

    /// A row of rectangular cells: `ew` the east-west spacing along the
    /// row and `ew_up` / `ew_down` along the rows above / below, `ew_n` /
    /// `ew_s` the east-west spacing on the lines half a row north / south
    /// of it (where the diagonal steps cross), `ns_n` / `ns_s` the
    /// north-south spacing to the row above / below. A diagonal step is the
    /// hypotenuse of the spacings on the line it crosses (a plane
    /// approximation of the geodesic, relative error of the order of the
    /// cell's angular size squared: ~1e-9 for 3" cells); a D∞ facet's legs
    /// join its three cell centres (Tarboton's triangle).
    pub fn rectangular(
        ew: f64,
        ew_up: f64,
        ew_down: f64,
        ew_n: f64,
        ew_s: f64,
        ns_n: f64,
        ns_s: f64,
    ) -> RowGeometry {
        let ne = ew_n.hypot(ns_n);
        let se = ew_s.hypot(ns_s);
        let facet = |d1: f64, d2: f64| (d1, d2, d2.atan2(d1), d1.hypot(d2));
        RowGeometry {
            dist: [ew, se, ns_s, se, ew, ne, ns_n, ne],
            facet: [
                facet(ew, ns_n),      // E, NE
                facet(ns_n, ew_up),   // N, NE
                facet(ns_n, ew_up),   // N, NW
                facet(ew, ns_n),      // W, NW
                facet(ew, ns_s),      // W, SW
                facet(ns_s, ew_down), // S, SW
                facet(ns_s, ew_down), // S, SE
                facet(ew, ns_s),      // E, SE
            ],
            contour: [
                0.25 * (ns_n + ns_s),
                se / 4.0,
                0.5 * ew_s,
                se / 4.0,
                0.25 * (ns_n + ns_s),
                ne / 4.0,
                0.5 * ew_n,
                ne / 4.0,
            ],
        }
    }
}

/// The neighbour geometry of a run of rows of a raster ([`RowGeometry`] per
/// row): one row for every row on square or projected grids, a row each on
/// geographic grids, where the east-west spacing shrinks with cos φ.
///
/// - No georeferencing, or square projected cells: [`RowGeometry::SQUARE`]
///   (the results of the square-cell papers, bit for bit).
/// - Projected rectangular cells: the cells' aspect ratio, in cells of the
///   east-west size.
/// - Geographic (lat/lon) grids: metres on the WGS 84 ellipsoid from
///   [`crate::raster::GeoRef::cell_size_m_at`] (radii of curvature at the
///   row's and the half rows' latitudes, Snyder 1987 eqs. 4-18, 4-20), so
///   steepest descent, D∞ facets and MFD slopes use the true distances.
#[derive(Debug, Clone, PartialEq)]
pub struct CellGeometry {
    rows: Vec<RowGeometry>,
    per_row: bool,
}

impl CellGeometry {
    /// Square unit cells everywhere.
    pub fn square() -> CellGeometry {
        CellGeometry {
            rows: vec![RowGeometry::SQUARE],
            per_row: false,
        }
    }

    /// The geometry of `rows` rows of the raster of `georef`, starting at
    /// raster row `first_row` (may be negative or past the raster: a tile
    /// view's halo; the latitude is then clamped to the poles).
    pub fn of_rows(georef: &super::GeoRef, first_row: i64, rows: usize) -> CellGeometry {
        if !georef.georeferenced {
            return CellGeometry::square();
        }
        if !georef.crs.geographic {
            let (cx, cy) = georef.cell_size_units();
            if cx == cy || !(cx > 0.0 && cy > 0.0) {
                return CellGeometry::square();
            }
            let r = cy / cx;
            return CellGeometry {
                rows: vec![RowGeometry::rectangular(1.0, 1.0, 1.0, 1.0, 1.0, r, r)],
                per_row: false,
            };
        }
        let rows = (0..rows)
            .map(|i| {
                let y = (first_row + i as i64) as f64;
                let (ew, _) = georef.cell_size_m_at(y + 0.5);
                let (ew_up, _) = georef.cell_size_m_at(y - 0.5);
                let (ew_down, _) = georef.cell_size_m_at(y + 1.5);
                let (ew_n, ns_n) = georef.cell_size_m_at(y);
                let (ew_s, ns_s) = georef.cell_size_m_at(y + 1.0);
                RowGeometry::rectangular(ew, ew_up, ew_down, ew_n, ew_s, ns_n, ns_s)
            })
            .collect();
        CellGeometry {
            rows,
            per_row: true,
        }
    }

    /// The geometry of row `y` of the run (0 = `first_row`).
    #[inline]
    pub fn row(&self, y: usize) -> &RowGeometry {
        if self.per_row {
            &self.rows[y]
        } else {
            &self.rows[0]
        }
    }

    /// True when every row is [`RowGeometry::SQUARE`].
    pub fn is_square(&self) -> bool {
        !self.per_row && self.rows[0] == RowGeometry::SQUARE
    }
}
