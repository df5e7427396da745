//! Landform classifications: geomorphons (Jasiewicz & Stepinski 2013,
//! "Geomorphons — a pattern recognition approach to classification and
//! mapping of landforms", Geomorphology 182, 147-156), Weiss's ten TPI
//! landform classes (Weiss 2001, "Topographic position and landforms
//! analysis", poster, ESRI User Conference) and Dikau's nine curvature forms
//! (Dikau 1989, "The application of a digital relief model to landform
//! analysis in geomorphology", in Raper (ed.), Three dimensional applications
//! in GIS, 51-77).
//!
//! Class outputs are small integers stored in f32 (NaN = nodata).

use super::curvature::FromQuadric;
use super::horizon::DIRS;
use super::local_stats::windowed_stat;
use super::param::{
    CURV_T, FLAT_T, GEOMORPHON_RULE, RADIUS_GEOMORPHON, RADIUS_LARGE, RADIUS_QUADRIC, RADIUS_SMALL,
    SLOPE_T,
};
use super::registry::{metric_def, Metric, MetricDef, MetricKind, Needs, ScratchClass};
use super::spec::Resolved;
use super::tile::{region_cells, Tile};
use crate::error::Result;
use crate::exec::LocalStep;
use crate::raster::{Grid, TileView};

/// The 8 geomorphon directions (dx east, dy south in rows), clockwise from
/// north: N, NE, E, SE, S, SW, W, NW (the axes and diagonals that open the
/// horizon scan's [`DIRS`]). Pattern digit `i` is direction `i`.
pub const GEOMORPHON_DIRS: [(i64, i64); 8] = *DIRS.first_chunk::<8>().unwrap();

/// Geomorphon class numbers, as GRASS r.geomorphon numbers them.
pub const FLAT: u8 = 1;
pub const PEAK: u8 = 2;
pub const RIDGE: u8 = 3;
pub const SHOULDER: u8 = 4;
pub const SPUR: u8 = 5;
pub const SLOPE: u8 = 6;
pub const HOLLOW: u8 = 7;
pub const FOOTSLOPE: u8 = 8;
pub const VALLEY: u8 = 9;
pub const PIT: u8 = 10;

/// The landform lookup table of Jasiewicz & Stepinski 2013 (Fig. 4),
/// indexed `[number of −][number of +]`; 0 where `− + +` exceeds 8.
pub const GEOMORPHON_TABLE: [[u8; 9]; 9] = {
    const FL: u8 = FLAT;
    const PK: u8 = PEAK;
    const RI: u8 = RIDGE;
    const SH: u8 = SHOULDER;
    const SP: u8 = SPUR;
    const SL: u8 = SLOPE;
    const HL: u8 = HOLLOW;
    const FS: u8 = FOOTSLOPE;
    const VL: u8 = VALLEY;
    const PT: u8 = PIT;
    [
        [FL, FL, FL, FS, FS, VL, VL, VL, PT],
        [FL, FL, FS, FS, FS, VL, VL, VL, 0],
        [FL, SH, SL, SL, HL, HL, VL, 0, 0],
        [SH, SH, SL, SL, SL, HL, 0, 0, 0],
        [SH, SH, SP, SL, SL, 0, 0, 0, 0],
        [RI, RI, SP, SP, 0, 0, 0, 0, 0],
        [RI, RI, RI, 0, 0, 0, 0, 0, 0],
        [RI, RI, 0, 0, 0, 0, 0, 0, 0],
        [PK, 0, 0, 0, 0, 0, 0, 0, 0],
    ]
};

/// Ternary digit values in pattern codes.
pub const T_FLAT: u32 = 0;
pub const T_PLUS: u32 = 1;
pub const T_MINUS: u32 = 2;

/// Class of a pattern with `plus` '+' and `minus` '−' elements
/// (`plus + minus ≤ 8`).
pub fn geomorphon_class(plus: usize, minus: usize) -> u8 {
    GEOMORPHON_TABLE
        .get(minus)
        .and_then(|r| r.get(plus))
        .copied()
        .unwrap_or(0)
}

/// Ternary element of one line of sight from the largest and smallest
/// elevation angles (degrees) met along it: with zenith `φ = 90° − max` and
/// nadir `ψ = 90° + min` (Jasiewicz & Stepinski 2013, sec. 2.1),
/// `Δ = ψ − φ = max + min`; '+' (the surroundings rise) if `Δ > t`,
/// '−' (they fall) if `Δ < −t`, '0' otherwise. This is the paper's rule
/// and the default; GRASS r.geomorphon's code uses a variant,
/// [`ternary_grass`] (`rule=grass`).
pub fn ternary(max_deg: f64, min_deg: f64, flat_deg: f64) -> u32 {
    let d = max_deg + min_deg;
    if d > flat_deg {
        T_PLUS
    } else if d < -flat_deg {
        T_MINUS
    } else {
        T_FLAT
    }
}

/// Ternary element of one line of sight by GRASS r.geomorphon 8's rule
/// (`comparison=anglev1`, its default; `pattern.c`): with `max`, `min` the
/// largest and smallest elevation angles (degrees) met along the line, the
/// line is non-flat when `|max| > t` or `|min| > t`, and then '+' when
/// `|min| < |max|`, '−' when `|min| > |max|`, '0' on a tie. Unlike the
/// paper's rule ([`ternary`]), a line rising 3° and falling 2.5° is '+'
/// there and '0' here.
pub fn ternary_grass(max_deg: f64, min_deg: f64, flat_deg: f64) -> u32 {
    let (a, b) = (max_deg.abs(), min_deg.abs());
    if a > flat_deg || b > flat_deg {
        if b < a {
            T_PLUS
        } else if b > a {
            T_MINUS
        } else {
            T_FLAT
        }
    } else {
        T_FLAT
    }
}

/// Geomorphons of every core cell of `view`: lines of sight along the 8
/// [`GEOMORPHON_DIRS`] visit the cells at whole steps whose centres lie
/// within `cutoff_m` metres (at most `steps` cells per axis, ≤ the halo;
/// distances from the centre row's true cell sizes, as `horizon`). Nodata
/// cells and cells beyond the raster are skipped; a line without any valid
/// cell is '0'. Writes the class (1..=10) to `class` and the pattern code
/// `Σ digit_i 3^i` (digits [`T_FLAT`], [`T_PLUS`], [`T_MINUS`]) to `pattern`.
/// A nodata centre is nodata.
///
/// `grass`: GRASS r.geomorphon 8's rules (its `pattern.c` and `main.c`,
/// `skip=0 dist=0`) instead of the paper's: [`ternary_grass`]; a cell at
/// exactly `cutoff_m` is left out (GRASS walks while the distance is below
/// the search distance; the paper's rule here includes it); a line whose
/// first cell is nodata or beyond the raster is '0'; and the outermost
/// ring of the raster is nodata (GRASS leaves cells within `skip + 1` of
/// the edge out, "on borders forms usually are unnatural").
pub fn geomorphon(
    view: &TileView<f32>,
    steps: usize,
    cutoff_m: f64,
    flat_deg: f64,
    grass: bool,
    mut class: Option<&mut Grid<f32>>,
    mut pattern: Option<&mut Grid<f32>>,
) {
    let steps = steps.min(view.halo);
    let h = view.halo;
    let gw = view.grid.width();
    let data = view.grid.data();
    let (rw, rh) = (view.raster_width as i64, view.raster_height as i64);
    let limit = cutoff_m * (1.0 + 1e-12);
    let strict = cutoff_m * (1.0 - 1e-12);
    for y in 0..view.core.h {
        let gy = view.core.y + y as i64;
        let (ew, ns) = view.georef.cell_size_m(gy);
        let mut plan = [(0isize, 0.0f64, 0usize); 8];
        for (p, &(dx, dy)) in plan.iter_mut().zip(&GEOMORPHON_DIRS) {
            let d = ((dx as f64 * ew).powi(2) + (dy as f64 * ns).powi(2)).sqrt();
            let mut k = steps;
            if grass {
                while k > 0 && k as f64 * d >= strict {
                    k -= 1;
                }
            } else {
                while k > 0 && k as f64 * d > limit {
                    k -= 1;
                }
            }
            *p = (dy as isize * gw as isize + dx as isize, d, k);
        }
        for x in 0..view.core.w {
            let c = (y + h) * gw + x + h;
            let gx = view.core.x + x as i64;
            let z0 = data[c] as f64;
            let ring = grass && (gx == 0 || gy == 0 || gx + 1 == rw || gy + 1 == rh);
            let (cl, code) = if z0.is_nan() || ring {
                (f32::NAN, f32::NAN)
            } else {
                let (mut plus, mut minus, mut code, mut pow) = (0usize, 0usize, 0u32, 1u32);
                for &(off, d, k) in &plan {
                    let (mut hi, mut lo) = (f64::NEG_INFINITY, f64::INFINITY);
                    let mut i = c as isize;
                    let first_void = grass && data[(c as isize + off) as usize].is_nan();
                    for s in 1..=k {
                        i += off;
                        let z = data[i as usize] as f64;
                        if !z.is_nan() {
                            let t = (z - z0) / (s as f64 * d);
                            hi = hi.max(t);
                            lo = lo.min(t);
                        }
                    }
                    let t = if hi == f64::NEG_INFINITY || first_void {
                        T_FLAT
                    } else if grass {
                        ternary_grass(hi.atan().to_degrees(), lo.atan().to_degrees(), flat_deg)
                    } else {
                        ternary(hi.atan().to_degrees(), lo.atan().to_degrees(), flat_deg)
                    };
                    match t {
                        T_PLUS => plus += 1,
                        T_MINUS => minus += 1,
                        _ => {}
                    }
                    code += t * pow;
                    pow *= 3;
                }
                (geomorphon_class(plus, minus) as f32, code as f32)
            };
            if let Some(g) = class.as_deref_mut() {
                g.set(x, y, cl);
            }
            if let Some(g) = pattern.as_deref_mut() {
                g.set(x, y, code);
            }
        }
    }
}

/// Canonical form of a pattern code (as [`geomorphon`] writes them): the
/// smallest code among its 8 rotations (by 45°) and their mirror images, so
/// patterns that differ only in orientation share one code. Over all 3^8
/// patterns there are 498 canonical codes, the "geomorphons" of Jasiewicz &
/// Stepinski 2013 (sec. 2.2). Codes ≥ 3^8 are returned unchanged.
pub fn canonical_code(code: u32) -> u32 {
    if code >= 6561 {
        return code;
    }
    let mut d = [0u32; 8];
    let mut c = code;
    for v in d.iter_mut() {
        *v = c % 3;
        c /= 3;
    }
    let mut best = code;
    for mirror in [false, true] {
        for rot in 0..8 {
            let mut v = 0u32;
            for i in (0..8).rev() {
                let src = if mirror {
                    (8 - i + rot) % 8
                } else {
                    (i + rot) % 8
                };
                v = v * 3 + d[src];
            }
            best = best.min(v);
        }
    }
    best
}

/// Weiss (2001) landform class from the standardised TPI at a small (`sn`)
/// and a large (`ln`) scale and the slope in degrees, with thresholds ±1
/// standard deviation and `slope_t` degrees separating plains from open
/// slopes:
///
/// | class | sn      | ln      | landform |
/// |-------|---------|---------|----------|
/// | 1 | ≤ −1 | ≤ −1 | canyons, deeply incised streams |
/// | 2 | ≤ −1 | (−1, 1) | midslope drainages, shallow valleys |
/// | 3 | ≤ −1 | ≥ 1 | upland drainages, headwaters |
/// | 4 | (−1, 1) | ≤ −1 | U-shaped valleys |
/// | 5 | (−1, 1) | (−1, 1), slope ≤ t | plains |
/// | 6 | (−1, 1) | (−1, 1), slope > t | open slopes |
/// | 7 | (−1, 1) | ≥ 1 | upper slopes, mesas |
/// | 8 | ≥ 1 | ≤ −1 | local ridges, hills in valleys |
/// | 9 | ≥ 1 | (−1, 1) | midslope ridges, small hills in plains |
/// | 10 | ≥ 1 | ≥ 1 | mountain tops, high ridges |
///
/// NaN in any input gives NaN.
pub fn weiss_class(sn: f64, ln: f64, slope_deg: f64, slope_t: f64) -> f32 {
    if sn.is_nan() || ln.is_nan() || slope_deg.is_nan() {
        return f32::NAN;
    }
    let band = |v: f64| {
        if v <= -1.0 {
            0
        } else if v >= 1.0 {
            2
        } else {
            1
        }
    };
    let c = match (band(sn), band(ln)) {
        (0, 0) => 1,
        (0, 1) => 2,
        (0, _) => 3,
        (1, 0) => 4,
        (1, 1) if slope_deg <= slope_t => 5,
        (1, 1) => 6,
        (1, _) => 7,
        (_, 0) => 8,
        (_, 1) => 9,
        _ => 10,
    };
    c as f32
}

/// Dikau (1989) form class from profile (vertical) and plan curvature
/// (convex positive) with a threshold `t` (1/m) below which a curvature
/// counts as straight: `class = 3·p + q + 1` where p, q are 0 (concave,
/// `k < −t`), 1 (straight, `|k| ≤ t`), 2 (convex, `k > t`) for profile and
/// plan curvature: 1 concave/concave (hollow, V-V), 5 straight/straight
/// (planar), 9 convex/convex (nose, X-X). NaN gives NaN.
pub fn dikau_class(profile: f64, plan: f64, t: f64) -> f32 {
    if profile.is_nan() || plan.is_nan() {
        return f32::NAN;
    }
    let s = |k: f64| {
        if k < -t {
            0
        } else if k > t {
            2
        } else {
            1
        }
    };
    (3 * s(profile) + s(plan) + 1) as f32
}

/// Geomorphon class or ternary pattern (one scan for both when the pass
/// asks for both with the same lookup distance and flatness).
pub struct Geomorphon(MetricDef);

/// The rays and flatness of a geomorphon metric.
fn geomorphon_key(m: &Resolved) -> (usize, u64, u64, bool) {
    (
        m.radius_cells,
        m.radius_m.to_bits(),
        m.spec.threshold.unwrap_or(1.0).to_bits(),
        m.spec.grass,
    )
}

impl Metric for Geomorphon {
    fn def(&self) -> &MetricDef {
        &self.0
    }
    fn halo(&self, m: &Resolved) -> usize {
        m.radius_cells
    }
    fn run(&self, t: &mut Tile<'_>, m: &Resolved, o: &mut Grid<f32>) -> Result<()> {
        let key = geomorphon_key(m);
        let (r, rm) = (m.radius_cells, m.radius_m);
        let flat = m.spec.threshold.unwrap_or(1.0);
        t.grouped(
            (
                if key.3 {
                    "geomorphon_grass"
                } else {
                    "geomorphon"
                },
                key.0,
                key.1,
                key.2,
            ),
            m,
            |n| {
                matches!(
                    n.spec.kind,
                    MetricKind::Geomorphon | MetricKind::GeomorphonPattern
                ) && geomorphon_key(n) == key
            },
            |view, kinds| {
                let (cw, ch) = (view.core.w, view.core.h);
                let mut grids: Vec<Grid<f32>> =
                    kinds.iter().map(|_| Grid::new(cw, ch, f32::NAN)).collect();
                let (mut c, mut p) = (None, None);
                for (kind, g) in kinds.iter().zip(grids.iter_mut()) {
                    match kind {
                        MetricKind::Geomorphon => c = Some(g),
                        _ => p = Some(g),
                    }
                }
                geomorphon(view, r, rm, flat, key.3, c, p);
                grids
            },
            o,
        );
        Ok(())
    }
}

/// The geomorphon pattern reduced to its canonical code.
pub struct GeomorphonCanonical(MetricDef);

impl Metric for GeomorphonCanonical {
    fn def(&self) -> &MetricDef {
        &self.0
    }
    fn halo(&self, m: &Resolved) -> usize {
        m.radius_cells
    }
    fn run(&self, t: &mut Tile<'_>, m: &Resolved, o: &mut Grid<f32>) -> Result<()> {
        let flat = m.spec.threshold.unwrap_or(1.0);
        geomorphon(
            t.view,
            m.radius_cells,
            m.radius_m,
            flat,
            m.spec.grass,
            None,
            Some(o),
        );
        for v in o.data_mut() {
            if !v.is_nan() {
                *v = canonical_code(*v as u32) as f32;
            }
        }
        Ok(())
    }
}

/// Weiss's TPI landforms.
pub struct WeissLandform(MetricDef);

impl Metric for WeissLandform {
    fn def(&self) -> &MetricDef {
        &self.0
    }
    fn halo(&self, m: &Resolved) -> usize {
        m.radius_cells.max(m.radius2_cells)
    }
    fn needs(&self, m: &Resolved) -> Needs {
        Needs {
            sat: Some((m.radius_cells.max(m.radius2_cells), true)),
            ..Needs::default()
        }
    }
    fn scratch(&self, m: &Resolved, tile: usize) -> Option<(ScratchClass, u64)> {
        // summed-area tables as the window statistics plus two NTPI grids
        let core = (tile * tile) as u64;
        let r = m.radius_cells.max(m.radius2_cells);
        Some((
            ("weiss", 0),
            region_cells(tile, r) * (8 + 4 + 16 + 16) + 2 * core * 4,
        ))
    }
    fn run(&self, t: &mut Tile<'_>, m: &Resolved, o: &mut Grid<f32>) -> Result<()> {
        let (big, sat) = t.sat()?;
        let view = t.view;
        let (cw, ch) = (view.core.w, view.core.h);
        let mut sn = Grid::new(cw, ch, f32::NAN);
        let mut ln = Grid::new(cw, ch, f32::NAN);
        let ntpi = MetricKind::Ntpi;
        windowed_stat(view, sat, big, m.radius_cells, false, ntpi, &mut sn);
        windowed_stat(view, sat, big, m.radius2_cells, false, ntpi, &mut ln);
        super::terrain::Slope::default().run(t.inputs, std::slice::from_mut(o))?;
        let th = m.spec.threshold.unwrap_or(5.0);
        for ((o, a), b) in o.data_mut().iter_mut().zip(sn.data()).zip(ln.data()) {
            *o = weiss_class(*a as f64, *b as f64, *o as f64, th);
        }
        Ok(())
    }
}

/// `geomorphon`: geomorphon landform: 1 flat, 2 peak, 3 ridge, 4 shoulder, 5 spur, 6 slope, 7 hollow, 8 footslope, 9 valley, 10 pit.
///
/// Source: Jasiewicz & Stepinski 2013, Geomorphology 182 (classes numbered as GRASS r.geomorphon).
pub static GEOMORPHON: Geomorphon = Geomorphon(metric_def!(
        Geomorphon,
        "geomorphon",
        &[RADIUS_GEOMORPHON, FLAT_T, GEOMORPHON_RULE],
        "class 1..10",
        "geomorphon landform: 1 flat, 2 peak, 3 ridge, 4 shoulder, 5 spur, 6 slope, 7 hollow, 8 footslope, 9 valley, 10 pit",
        "Jasiewicz & Stepinski 2013, Geomorphology 182 (classes numbered as GRASS r.geomorphon)";
    Categorical
));

/// `geomorphon_pattern`: geomorphon ternary pattern sum d_i 3^i, i = N,NE,..,NW clockwise; d = 0 flat, 1 '+', 2 '-' (not canonicalised).
///
/// Source: Jasiewicz & Stepinski 2013, Geomorphology 182.
pub static GEOMORPHON_PATTERN: Geomorphon = Geomorphon(metric_def!(
        GeomorphonPattern,
        "geomorphon_pattern",
        &[RADIUS_GEOMORPHON, FLAT_T, GEOMORPHON_RULE],
        "0..6560",
        "geomorphon ternary pattern sum d_i 3^i, i = N,NE,..,NW clockwise; d = 0 flat, 1 '+', 2 '-' (not canonicalised)",
        "Jasiewicz & Stepinski 2013, Geomorphology 182";
    Categorical
));

/// `geomorphon_canonical`: geomorphon_pattern reduced to its smallest code over 8 rotations and their mirrors (498 values).
///
/// Source: Jasiewicz & Stepinski 2013, Geomorphology 182, sec. 2.2.
pub static GEOMORPHON_CANONICAL: GeomorphonCanonical = GeomorphonCanonical(metric_def!(
        GeomorphonCanonical,
        "geomorphon_canonical",
        &[RADIUS_GEOMORPHON, FLAT_T, GEOMORPHON_RULE],
        "0..6560",
        "geomorphon_pattern reduced to its smallest code over 8 rotations and their mirrors (498 values)",
        "Jasiewicz & Stepinski 2013, Geomorphology 182, sec. 2.2";
    Categorical
));

/// `weiss_landform`: Weiss TPI landforms from NTPI at two scales (thresholds +-1) and Horn slope: 1 canyon .. 5 plain, 6 open slope .. 10 mountain top.
///
/// Source: Weiss 2001 (TPI poster, ESRI UC); standardised locally (NTPI) instead of over the whole raster.
pub static WEISS_LANDFORM: WeissLandform = WeissLandform(metric_def!(
        WeissLandform,
        "weiss_landform",
        &[RADIUS_SMALL, RADIUS_LARGE, SLOPE_T],
        "class 1..10",
        "Weiss TPI landforms from NTPI at two scales (thresholds +-1) and Horn slope: 1 canyon .. 5 plain, 6 open slope .. 10 mountain top",
        "Weiss 2001 (TPI poster, ESRI UC); standardised locally (NTPI) instead of over the whole raster";
    Categorical
));

/// `dikau_form`: Dikau form 3p+q+1 from profile (p) and plan (q) curvature: 0 concave, 1 straight, 2 convex.
///
/// Source: Dikau 1989 (in Raper, 3D applications in GIS); curvatures of Evans/Wood as profile_curvature/plan_curvature.
pub static DIKAU_FORM: FromQuadric = FromQuadric(metric_def!(
        DikauForm,
        "dikau_form",
        &[RADIUS_QUADRIC, CURV_T],
        "class 1..9",
        "Dikau form 3p+q+1 from profile (p) and plan (q) curvature: 0 concave, 1 straight, 2 convex",
        "Dikau 1989 (in Raper, 3D applications in GIS); curvatures of Evans/Wood as profile_curvature/plan_curvature";
    Categorical
));
