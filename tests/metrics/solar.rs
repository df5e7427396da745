//! Solar metrics against published values and closed forms: the sun's
//! position against the worked example of Reda & Andreas 2004 (NREL SPA
//! report, Table A4.1 inputs: 17 Oct 2003, 12:30:30 local = 19:30:30 UTC,
//! 39.742476 N, 105.1786 W: topocentric zenith 50.11162°, azimuth 194.34024°)
//! and the solstice/perihelion values of the Astronomical Almanac; daily
//! direct irradiation of a horizontal plane against the closed-form integral
//! of cos z; a sloped plane at noon against `S_b·cos(z − β)`; a north-facing
//! slope in a high-latitude winter gets no direct sun; a wall's cast shadow;
//! the heat index of tilted planes.
//!
//! The closed forms take the declination and Earth-Sun distance factor from
//! `day_geometry` (itself checked against the almanac here), so they test the
//! time integration, terrain term and shadows independently of the astronomy.

use orogen::metrics::solar::{day_geometry, refraction_deg, sun_position, SOLAR_CONSTANT};
use orogen::raster::RasterSource;
use std::f64::consts::PI;

use crate::common::{source, CELL};

/// [`crate::common::run`] on 2 threads.
fn run(src: &dyn RasterSource, specs: &str, tile: usize) -> Vec<Vec<f32>> {
    crate::common::run(src, specs, tile, 2)
}

/// A plane z = a·x_east + b·y_north (metres) on a w x h grid.
fn plane(w: usize, h: usize, a: f64, b: f64) -> Vec<f32> {
    (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f64 * CELL, -((i / w) as f64) * CELL);
            (1000.0 + a * x + b * y) as f32
        })
        .collect()
}

#[test]
fn sun_position_against_published_values() {
    // Reda & Andreas 2004 (SPA) example; NOAA's formulas are good to ~0.01°.
    let (z, az) = sun_position(
        2003,
        10,
        17,
        19.0 + 30.0 / 60.0 + 30.0 / 3600.0,
        39.742476,
        -105.1786,
    );
    let apparent = z - refraction_deg(90.0 - z);
    assert!((apparent - 50.11162).abs() < 0.1, "zenith {apparent}");
    assert!((az - 194.34024).abs() < 0.1, "azimuth {az}");
    // June solstice 2001 (21 June, day 172): declination 23.44°; perihelion
    // (3-4 Jan, r = 0.98329 AU) and aphelion (4 Jul, r = 1.01671 AU).
    let (d, _) = day_geometry(172.0);
    assert!((d - 23.44).abs() < 0.05, "declination {d}");
    let (d, _) = day_geometry(355.0);
    assert!((d + 23.44).abs() < 0.05, "declination {d}");
    let (_, e) = day_geometry(3.0);
    assert!((e - 1.0 / 0.98329f64.powi(2)).abs() < 1e-3, "E0 {e}");
    let (_, e) = day_geometry(185.0);
    assert!((e - 1.0 / 1.01671f64.powi(2)).abs() < 1e-3, "E0 {e}");
    // Equinox noon at the equator: sun nearly overhead.
    let (d, _) = day_geometry(80.0);
    assert!(d.abs() < 0.5, "equinox declination {d}");
}

#[test]
fn horizontal_plane_daily_direct_closed_form() {
    let (w, h) = (9, 9);
    let src = source(&vec![100.0; w * h], w, h);
    for (lat, day) in [
        (45.0f64, 172.0f64),
        (-33.0, 172.0),
        (60.0, 355.0),
        (10.0, 80.0),
    ] {
        let (decl, e0) = day_geometry(day);
        let (phi, d) = (lat.to_radians(), decl.to_radians());
        // ∫ cos z dt over the day (hours) = (24/π)(ω_s sinφ sinδ + cosφ cosδ sin ω_s).
        let ws = (-phi.tan() * d.tan()).clamp(-1.0, 1.0).acos();
        let want = SOLAR_CONSTANT * e0 * 24.0 / PI
            * (ws * phi.sin() * d.sin() + phi.cos() * d.cos() * ws.sin());
        let out = run(
            &src,
            &format!("solar_direct:lat={lat}:day={day}:tau=1:step=5:radius=2c"),
            4,
        );
        let got = out[0][4 * w + 4] as f64;
        assert!(
            (got - want).abs() < 0.002 * want,
            "lat {lat} day {day}: {got} vs {want} Wh/m2"
        );
        // With tau = 1 there is no diffuse light: global == direct.
        let g = run(
            &src,
            &format!("solar_global:lat={lat}:day={day}:tau=1:step=5:radius=2c"),
            4,
        );
        assert!((g[0][4 * w + 4] as f64 - got).abs() < 1e-3 * want.max(1.0));
        // With tau = 0.7: midpoint sum of S0·E0·τ^(1/cos z)·cos z at 1-minute steps.
        let out = run(
            &src,
            &format!("solar_direct:lat={lat}:day={day}:step=5:radius=2c"),
            4,
        );
        let mut num = 0.0;
        for k in 0..1440 {
            let hour_angle = (15.0 * ((k as f64 + 0.5) / 60.0 - 12.0)).to_radians();
            let cz = phi.sin() * d.sin() + phi.cos() * d.cos() * hour_angle.cos();
            if cz > 0.0 {
                num += SOLAR_CONSTANT * e0 * 0.7f64.powf(1.0 / cz) * cz / 60.0;
            }
        }
        let got = out[0][4 * w + 4] as f64;
        assert!(
            (got - num).abs() < 0.005 * num + 0.5,
            "tau 0.7 lat {lat} day {day}: {got} vs {num}"
        );
    }
}

#[test]
fn slopes_at_noon_and_in_winter() {
    let (w, h) = (9, 9);
    let beta = 30f64.to_radians();
    let lat = 45.0f64;
    let (decl, e0) = day_geometry(172.0);
    let z = (lat - decl).to_radians();
    let beam = SOLAR_CONSTANT * e0 * 0.7f64.powf(1.0 / z.cos());
    // South-facing (z falls to the south, i.e. rises to the north): incidence z − β.
    let south = source(&plane(w, h, 0.0, beta.tan()), w, h);
    let out = run(&south, "solar_direct:lat=45:day=172:hour=12:radius=2c", 4);
    let want = beam * (z - beta).cos();
    let got = out[0][4 * w + 4] as f64;
    assert!(
        (got - want).abs() < 1e-3 * want,
        "south slope {got} vs {want}"
    );
    // North-facing: z + β.
    let north = source(&plane(w, h, 0.0, -beta.tan()), w, h);
    let out = run(&north, "solar_direct:lat=45:day=172:hour=12:radius=2c", 4);
    let want = beam * (z + beta).cos();
    let got = out[0][4 * w + 4] as f64;
    assert!(
        (got - want).abs() < 1e-3 * want,
        "north slope {got} vs {want}"
    );
    // A steep north-facing slope at 60° N in midwinter never sees the sun
    // (noon elevation 6.6° < the 35° the slope turns away); diffuse light remains.
    let steep = source(&plane(w, h, 0.0, -35f64.to_radians().tan()), w, h);
    let out = run(
        &steep,
        "solar_direct:lat=60:day=355:step=5:radius=2c,solar_global:lat=60:day=355:step=5:radius=2c",
        4,
    );
    assert_eq!(out[0][4 * w + 4], 0.0);
    assert!(out[1][4 * w + 4] > 0.0);
    // The same slope facing south gets direct sun: the day's sum against the
    // midpoint integral (1-minute steps) of S0·E0·τ^(1/cos z)·cos i, where a
    // south-facing plane tilted β at latitude φ sees the sun as a horizontal
    // plane at φ − β does: cos i = sin δ sin(φ−β) + cos δ cos(φ−β) cos ω
    // (Duffie & Beckman, eq. 1.6.7), lit while both cos i and cos z are > 0.
    let steep_s = source(&plane(w, h, 0.0, 35f64.to_radians().tan()), w, h);
    let out = run(&steep_s, "solar_direct:lat=60:day=355:step=5:radius=2c", 4);
    let v = out[0][4 * w + 4] as f64;
    let (decl, e0) = day_geometry(355.0);
    let (phi, d, b) = (60f64.to_radians(), decl.to_radians(), 35f64.to_radians());
    let mut want = 0.0;
    for k in 0..1440 {
        let om = (15.0 * ((k as f64 + 0.5) / 60.0 - 12.0)).to_radians();
        let cz = phi.sin() * d.sin() + phi.cos() * d.cos() * om.cos();
        let ci = d.sin() * (phi - b).sin() + d.cos() * (phi - b).cos() * om.cos();
        if cz > 0.0 && ci > 0.0 {
            want += SOLAR_CONSTANT * e0 * 0.7f64.powf(1.0 / cz) * ci / 60.0;
        }
    }
    assert!(
        (v - want).abs() < 0.005 * want,
        "south slope in winter: {v} vs {want} Wh/m2"
    );
}

#[test]
fn wall_casts_a_shadow_at_noon() {
    // Flat ground with a 100 m wall along row 3; the sun at noon (lat 45,
    // day 172) is due south at elevation 90 − (45 − 23.44) = 68.4°: cells
    // north of the wall within 100/tan(68.4°) = 39.6 m are in its shadow.
    let (w, h) = (11, 15);
    let mut d = vec![0.0f32; w * h];
    for x in 0..w {
        d[9 * w + x] = 100.0;
    }
    let src = source(&d, w, h);
    let out = run(&src, "solar_direct:lat=45:day=172:hour=12:radius=8c", 5);
    let (decl, e0) = day_geometry(172.0);
    let z = (45.0 - decl).to_radians();
    let open = SOLAR_CONSTANT * e0 * 0.7f64.powf(1.0 / z.cos()) * z.cos();
    let x = 5;
    // Rows 7 and 6 are 20 and 30 m north of the wall (row 8's 3x3 window
    // touches the wall); rows 4 and 2 are 50 and 70 m away.
    for (y, shadow) in [
        (7usize, true),
        (6, true),
        (4, false),
        (2, false),
        (12, false),
    ] {
        let got = out[0][y * w + x] as f64;
        if shadow {
            assert_eq!(got, 0.0, "row {y} should be in shadow");
        } else {
            assert!((got - open).abs() < 1e-3 * open, "row {y}: {got} vs {open}");
        }
    }
}

#[test]
fn heat_index_tilted_planes() {
    let (w, h) = (7, 7);
    for (a, b) in [(0.3f64, -0.2f64), (0.0, 0.5), (-0.7, 0.1), (0.0, 0.0)] {
        let src = source(&plane(w, h, a, b), w, h);
        let out = run(&src, "heat_index,heat_index:alpha_max=90", 3);
        let slope = (a * a + b * b).sqrt().atan();
        // Aspect: azimuth of steepest descent (−a east, −b north).
        let aspect = (-a).atan2(-b);
        for (k, amax) in [(0, 202.5f64), (1, 90.0)] {
            let want = if a == 0.0 && b == 0.0 {
                0.0
            } else {
                (amax.to_radians() - aspect).cos() * slope.atan()
            };
            let got = out[k][3 * w + 3] as f64;
            assert!(
                (got - want).abs() < 1e-5,
                "plane ({a},{b}) alpha_max {amax}: {got} vs {want}"
            );
        }
        assert!(out[0][0].is_nan(), "edges without neighbours are nodata");
    }
}

#[test]
fn annual_sum_of_a_flat_plane() {
    // Sum of the daily closed forms (tau = 1) over the sampled days, weighted.
    let (w, h) = (7, 7);
    let src = source(&vec![5.0; w * h], w, h);
    let out = run(&src, "solar_annual:lat=40:tau=1:days=5:step=5:radius=2c", 4);
    let phi = 40f64.to_radians();
    let mut want = 0.0;
    let mut day = 1.0;
    while day <= 365.0 {
        let (decl, e0) = day_geometry(day);
        let d = decl.to_radians();
        let ws = (-phi.tan() * d.tan()).clamp(-1.0, 1.0).acos();
        let daily = SOLAR_CONSTANT * e0 * 24.0 / PI
            * (ws * phi.sin() * d.sin() + phi.cos() * d.cos() * ws.sin());
        want += daily * 5f64.min(366.0 - day);
        day += 5.0;
    }
    want /= 1000.0;
    let got = out[0][3 * w + 3] as f64;
    assert!((got - want).abs() < 0.003 * want, "{got} vs {want} kWh/m2");
    // Between 1.5 and 4 MWh/m2 at 40° without atmosphere.
    assert!(got > 2500.0 && got < 4000.0, "{got}");
}
