//! Slope, aspect and hillshade against closed forms on analytic surfaces.

use orogen::exec::LocalStep;
use orogen::metrics::{Aspect, EdgeMode, Hillshade, Slope, SlopeUnits};
use orogen::raster::{read_view, Crs, GeoRef, Grid, MemRaster, TileLayout};

/// A plane z = a*E + b*N sampled on a north-up grid with `cell`-metre cells.
fn plane(w: usize, h: usize, cell: f64, a: f64, b: f64) -> MemRaster {
    let g = Grid::from_fn(w, h, |x, y| {
        let e = (x as f64 + 0.5) * cell;
        let n = (h as f64 - y as f64 - 0.5) * cell;
        (100.0 + a * e + b * n) as f32
    });
    MemRaster::from_grid(
        g,
        GeoRef::north_up(0.0, h as f64 * cell, cell, Crs::projected(32611)),
    )
}

fn run<S: LocalStep<In = f32>>(step: &S, src: &MemRaster) -> Grid<S::Out>
where
    S::Out: Default,
{
    let (w, h) = (src.info().width, src.info().height);
    let layout = TileLayout::new(w, h, w.max(h));
    let view = read_view::<f32>(src, &layout, 0, step.halo()).unwrap();
    let mut out = vec![Grid::new(w, h, S::Out::default())];
    step.run(&[view], &mut out).unwrap();
    out.pop().unwrap()
}

use orogen::raster::RasterSource;

#[test]
fn plane_slope_and_aspect_are_exact() {
    // (a, b) = gradient east, north; expected slope atan(|g|), aspect = azimuth of -g.
    for &(a, b) in &[
        (0.1, 0.0),
        (0.0, -0.25),
        (0.3, 0.4),
        (-0.05, 0.02),
        (-1.0, -1.0),
    ] {
        let src = plane(9, 7, 30.0, a, b);
        let slope = run(&Slope::default(), &src);
        let pct = run(
            &Slope {
                units: SlopeUnits::Percent,
                ..Default::default()
            },
            &src,
        );
        let aspect = run(&Aspect::default(), &src);
        let want_slope = (a * a + b * b).sqrt().atan().to_degrees();
        let mut want_aspect = (-a).atan2(-b).to_degrees();
        if want_aspect < 0.0 {
            want_aspect += 360.0;
        }
        for y in 1..6 {
            for x in 1..8 {
                assert!(
                    (slope.get(x, y) as f64 - want_slope).abs() < 1e-4,
                    "slope {a} {b}"
                );
                assert!((pct.get(x, y) as f64 - 100.0 * (a * a + b * b).sqrt()).abs() < 1e-3);
                assert!(
                    (aspect.get(x, y) as f64 - want_aspect).abs() < 1e-3,
                    "aspect {a} {b}: {} vs {want_aspect}",
                    aspect.get(x, y)
                );
            }
        }
        // gdaldem's default: the outer ring has no full window -> nodata.
        assert!(slope.get(0, 0).is_nan() && slope.get(8, 3).is_nan() && slope.get(4, 6).is_nan());
    }
}

#[test]
fn aspect_cardinal_directions() {
    // Surface falling towards the east: downslope azimuth 90.
    let cases = [
        ((-0.1, 0.0), 90.0),
        ((0.1, 0.0), 270.0),
        ((0.0, -0.1), 0.0),
        ((0.0, 0.1), 180.0),
    ];
    for ((a, b), want) in cases {
        let asp = run(&Aspect::default(), &plane(5, 5, 10.0, a, b));
        assert!(
            (asp.get(2, 2) as f64 - want).abs() < 1e-6,
            "{a},{b}: {}",
            asp.get(2, 2)
        );
    }
}

#[test]
fn flat_aspect_is_nodata_or_zero() {
    let src = plane(5, 5, 10.0, 0.0, 0.0);
    assert!(run(&Aspect::default(), &src).get(2, 2).is_nan());
    let z = Aspect {
        zero_for_flat: true,
        ..Default::default()
    };
    assert_eq!(run(&z, &src).get(2, 2), 0.0);
    assert_eq!(run(&Slope::default(), &src).get(2, 2), 0.0);
}

#[test]
fn hillshade_closed_form() {
    // Flat ground: cos i = sin(alt) -> 1 + 254 sin(45°) = 180.6 -> 181.
    let flat = run(&Hillshade::default(), &plane(5, 5, 10.0, 0.0, 0.0));
    assert_eq!(
        flat.get(2, 2),
        (1.0 + 254.0 * 45f64.to_radians().sin()).round() as u8
    );
    // A slope facing the light (falling to the NW, i.e. rising to the SE):
    // normal tilted towards 315°; with slope = 45° - alt... choose gradient so the
    // surface normal points exactly at the sun: cos i = 1 -> 255.
    let alt = 45f64.to_radians();
    let az = 315f64.to_radians();
    // normal ∝ (-p, -q, 1) parallel to (sin az cos alt, cos az cos alt, sin alt)
    let p = -az.sin() * alt.cos() / alt.sin();
    let q = -az.cos() * alt.cos() / alt.sin();
    let lit = run(&Hillshade::default(), &plane(5, 5, 10.0, p, q));
    assert_eq!(lit.get(2, 2), 255);
    // Facing away, steeper than the sun: shade 1.
    let dark = run(
        &Hillshade::default(),
        &plane(5, 5, 10.0, -2.0 * p, -2.0 * q),
    );
    assert_eq!(dark.get(2, 2), 1);
    // Edges are nodata (0), or computed with compute_edges.
    assert_eq!(flat.get(0, 0), 0);
    let ce = Hillshade {
        edge: EdgeMode::Compute,
        ..Default::default()
    };
    assert_eq!(run(&ce, &plane(5, 5, 10.0, 0.0, 0.0)).get(0, 0), 181);
}

#[test]
fn geographic_cells_use_metric_sizes() {
    // A 3" grid at 46°N whose elevation rises 1 m per cell eastwards: the true
    // east-west cell is ~64 m there, so the slope is atan(1/64.4) not atan(1/92.6).
    let cell = 1.0 / 1200.0;
    let g = Grid::from_fn(5, 5, |x, _| x as f32);
    let src = MemRaster::from_grid(
        g,
        GeoRef::north_up(8.0, 46.0 + 2.5 * cell, cell, Crs::wgs84()),
    );
    let slope = run(&Slope::default(), &src);
    let ew = src.info().georef.cell_size_m(2).0;
    // WGS84 east-west size of a 3" cell at 46°N: N(φ)·cosφ·Δλ
    assert!((ew - 64.4).abs() < 0.2, "ew = {ew}");
    let want = (1.0 / ew).atan().to_degrees();
    assert!((slope.get(2, 2) as f64 - want).abs() < 1e-5);
}

#[test]
fn fast_atan_is_within_its_bound() {
    use orogen::metrics::terrain::atan_nonneg;
    let mut worst = 0f64;
    for i in 0..2_000_000u64 {
        // dense on [0, 4], then geometric up to 1e12
        let x = if i < 1_000_000 {
            i as f64 * 4e-6
        } else {
            4.0 * 1.00003f64.powi((i - 1_000_000) as i32)
        };
        worst = worst.max((atan_nonneg(x) - x.atan()).abs());
    }
    assert!(worst < 7e-9, "max error {worst}");
    assert!(atan_nonneg(f64::NAN).is_nan());
    assert_eq!(atan_nonneg(0.0), 0.0);
    assert!((atan_nonneg(f64::INFINITY) - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
}

#[test]
fn fast_atan2_matches_libm_in_every_octant() {
    use orogen::metrics::terrain::atan2_fast;
    let mut worst = 0f64;
    for i in 0..720 {
        for r in [1e-6, 0.3, 1.0, 7.5, 1e5] {
            let th = (i as f64 + 0.37) * std::f64::consts::PI / 360.0;
            let (y, x) = (r * th.sin(), r * th.cos());
            worst = worst.max((atan2_fast(y, x) - y.atan2(x)).abs());
        }
    }
    for (y, x) in [
        (0.0, 1.0),
        (1.0, 0.0),
        (0.0, -1.0),
        (-1.0, 0.0),
        (1.0, 1.0),
        (-2.0, -2.0),
    ] {
        worst = worst.max((atan2_fast(y, x) - f64::atan2(y, x)).abs());
    }
    assert!(worst < 1e-8, "max error {worst}");
}
