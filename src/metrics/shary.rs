//! Shary's twelve landform types (Shary 1995, "Land surface in gravity
//! points classification by a complete system of curvatures", Mathematical
//! Geology 27(3), 373-390; Shary, Sharaya & Mitusov 2002, "Fundamental
//! quantitative methods of land surface analysis", Geoderma 107, 1-32):
//! the Gaussian classification by the signs of the Gaussian curvature K and
//! the mean curvature H, crossed with the accumulation classification by the
//! signs of the horizontal (tangential) curvature kh and the vertical
//! (profile) curvature kv. Because `H = (kh + kv)/2`, the sign of H is fixed
//! when kh and kv agree, which leaves 4 × 4 − 4 = 12 types.
//!
//! Sign convention as elsewhere in orogen: convex is positive (so a hill top
//! has K > 0, H > 0, kh > 0, kv > 0). Classes:
//!
//! | class | K | H | kh | kv | |
//! |---|---|---|---|---|---|
//! | 1 | − | − | − | − | saddle, concave in both directions |
//! | 2 | − | − | − | + | |
//! | 3 | − | − | + | − | |
//! | 4 | − | + | − | + | |
//! | 5 | − | + | + | − | |
//! | 6 | − | + | + | + | saddle, convex in both directions |
//! | 7 | + | − | − | − | closed depression (pit-like) |
//! | 8 | + | − | − | + | |
//! | 9 | + | − | + | − | |
//! | 10 | + | + | − | + | |
//! | 11 | + | + | + | − | |
//! | 12 | + | + | + | + | hill (dome-like) |
//!
//! Class 0: one of the curvatures is zero within the threshold (|kh|, |kv|,
//! |H| ≤ t, |K| ≤ t²), e.g. a plane or a flat summit, or (rounding at
//! H ≈ 0) the signs contradict `H = (kh + kv)/2`.

use super::curvature::FromQuadric;
use super::param::{RADIUS_QUADRIC, SHARY_T};
use super::registry::metric_def;

/// Shary class 0..=12 from the curvatures (NaN if any is NaN).
pub fn shary_class(k: f64, h: f64, kh: f64, kv: f64, t: f64) -> f32 {
    if k.is_nan() || h.is_nan() || kh.is_nan() || kv.is_nan() {
        return f32::NAN;
    }
    if k.abs() <= t * t || h.abs() <= t || kh.abs() <= t || kv.abs() <= t {
        return 0.0;
    }
    let (hp, khp, kvp) = (h > 0.0, kh > 0.0, kv > 0.0);
    // Order within a K sign: (H, kh, kv) = −−−, −−+, −+−, +−+, ++−, +++.
    let idx = match (hp, khp, kvp) {
        (false, false, false) => 1,
        (false, false, true) => 2,
        (false, true, false) => 3,
        (true, false, true) => 4,
        (true, true, false) => 5,
        (true, true, true) => 6,
        // H's sign contradicts kh and kv (only by rounding near H = 0).
        _ => return 0.0,
    };
    (if k > 0.0 { idx + 6 } else { idx }) as f32
}

/// `shary_landform`: Shary's 12 types from the signs of K, H, kh (tangential) and kv (profile): see metrics::shary; 0 where one is zero.
///
/// Source: Shary 1995, Mathematical Geology 27(3); Shary, Sharaya & Mitusov 2002, Geoderma 107; curvatures of Evans/Wood.
pub static SHARY_LANDFORM: FromQuadric = FromQuadric(metric_def!(
        SharyLandform,
        "shary_landform",
        &[RADIUS_QUADRIC, SHARY_T],
        "class 0..12",
        "Shary's 12 types from the signs of K, H, kh (tangential) and kv (profile): see metrics::shary; 0 where one is zero",
        "Shary 1995, Mathematical Geology 27(3); Shary, Sharaya & Mitusov 2002, Geoderma 107; curvatures of Evans/Wood";
    Categorical
));
