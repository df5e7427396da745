//! Shary's twelve landform types (Shary 1995, "Land surface in gravity
//! points classification by a complete system of curvatures", Mathematical
//! Geology 27(3), 373-390; Shary, Sharaya & Mitusov 2002, "Fundamental
//! quantitative methods of land surface analysis", Geoderma 107, 1-32): the
//! types of non-special points by the signs of the horizontal (tangential)
//! curvature kh, the vertical (profile) curvature kv, the mean curvature
//! H = (kh + kv)/2, the difference curvature E = (kv − kh)/2 and the total
//! Gaussian curvature K (the survey in `../shared/seeds`, §4.1: "twelve
//! classes based on the signs of tangential, profile, mean, difference and
//! total Gaussian curvatures").
//!
//! Why twelve: kh and kv are normal curvatures in orthogonal directions, so
//! K = H² − E² − M² (M the twisting term) and the principal curvatures are
//! H ± √(E² + M²). Where kh and kv have opposite signs, kh·kv = H² − E² < 0,
//! so K < 0 (a saddle) and E's sign is that of kv: only H's sign is free
//! (2 × 2 types). Where they agree, H has their sign and both K (elliptic or
//! saddle) and E (kv above or below kh) are free (2 × 4 types). An earlier
//! version here crossed the signs of K and H with kh and kv; four of its
//! twelve classes (K > 0 with kh, kv of opposite signs) cannot occur, and E
//! was missing.
//!
//! Sign convention as elsewhere in orogen: convex is positive (a hill top
//! has kh, kv > 0). Classes (numbering orogen's, accumulation to
//! dissipation; Shary's own figure was not at hand, the sets are his):
//!
//! | class | kh | kv | K | E | H | |
//! |---|---|---|---|---|---|---|
//! | 1 | − | − | + | − | − | convergent, decelerating, elliptic; kv < kh (a pit's flanks steepening less across than down) |
//! | 2 | − | − | + | + | − | convergent, decelerating, elliptic; kv > kh (a bowl) |
//! | 3 | − | − | − | − | − | convergent, decelerating, saddle |
//! | 4 | − | − | − | + | − | convergent, decelerating, saddle |
//! | 5 | − | + | − | + | − | convergent, accelerating, concave on average (a hollow) |
//! | 6 | − | + | − | + | + | convergent, accelerating, convex on average |
//! | 7 | + | − | − | − | − | divergent, decelerating, concave on average |
//! | 8 | + | − | − | − | + | divergent, decelerating, convex on average (a spur's foot) |
//! | 9 | + | + | − | − | + | divergent, accelerating, saddle |
//! | 10 | + | + | − | + | + | divergent, accelerating, saddle |
//! | 11 | + | + | + | − | + | divergent, accelerating, elliptic; kv < kh (a paraboloid dome) |
//! | 12 | + | + | + | + | + | divergent, accelerating, elliptic; kv > kh |
//!
//! Class 0: a curvature the type needs is zero within the threshold (|kh|,
//! |kv| ≤ t always; |K| ≤ t² and |E| ≤ t for 1-4 and 9-12; |H| ≤ t for
//! 5-8): a plane, a flat summit, an umbilic point such as a sphere's (E = 0).

use super::curvature::FromQuadric;
use super::param::{RADIUS_QUADRIC, SHARY_T};
use super::registry::metric_def;

/// Shary class 0..=12 from the curvatures (NaN if any is NaN); see the
/// module doc for the table. `h` is used as given (not recomputed from kh
/// and kv) only for its sign in classes 5-8.
pub fn shary_class(k: f64, h: f64, kh: f64, kv: f64, t: f64) -> f32 {
    if k.is_nan() || h.is_nan() || kh.is_nan() || kv.is_nan() {
        return f32::NAN;
    }
    if kh.abs() <= t || kv.abs() <= t {
        return 0.0;
    }
    let e = 0.5 * (kv - kh);
    // kh, kv of one sign: `elliptic` (K > 0) or `saddle` (K < 0), + 1 when E > 0.
    let same = |elliptic: u8, saddle: u8| -> f32 {
        if k.abs() <= t * t || e.abs() <= t {
            return 0.0;
        }
        let base = if k > 0.0 { elliptic } else { saddle };
        (base + u8::from(e > 0.0)) as f32
    };
    // kh, kv of opposite signs (K < 0): `base` when H < 0, + 1 when H > 0.
    let mixed = |base: u8| -> f32 {
        if h.abs() <= t {
            0.0
        } else {
            (base + u8::from(h > 0.0)) as f32
        }
    };
    match (kh > 0.0, kv > 0.0) {
        (false, false) => same(1, 3),
        (false, true) => mixed(5),
        (true, false) => mixed(7),
        (true, true) => same(11, 9),
    }
}

/// `shary_landform`: Shary's 12 types from the signs of kh (tangential), kv (profile), K, E = (kv - kh)/2 and H: see metrics::shary; 0 where a needed one is zero.
///
/// Source: Shary 1995, Mathematical Geology 27(3); Shary, Sharaya & Mitusov 2002, Geoderma 107; curvatures of Evans/Wood.
pub static SHARY_LANDFORM: FromQuadric = FromQuadric(metric_def!(
        SharyLandform,
        "shary_landform",
        &[RADIUS_QUADRIC, SHARY_T],
        "class 0..12",
        "Shary's 12 types from the signs of kh (tangential), kv (profile), K, E = (kv - kh)/2 and H: see metrics::shary; 0 where a needed one is zero",
        "Shary 1995, Mathematical Geology 27(3); Shary, Sharaya & Mitusov 2002, Geoderma 107; curvatures of Evans/Wood";
    Categorical
));
