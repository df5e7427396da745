//! Type-map C_T borders blended over a band (issue 10): across a straight
//! border between the Mont Blanc and the Dallas profiles the blended map
//! ramps linearly over the band (oracle: the box filter's closed form,
//! counted on a lattice), and each profile's peaks reach across the border
//! within the band and only there (oracle: the peaks' elevations; the two
//! profiles' ranges, 876–4810 m and 165–298 m, do not overlap).

use crate::oro_common::shipped;
use orogen::raster::Grid;
use orogen::synth::orometric::*;

fn two_halves() -> (SynthProfile, TypeMap) {
    let alps = shipped("alps_montblanc.json");
    let dallas = shipped("lowrelief_dallas.json");
    // Left half label 1 (the main profile, Alps: region 0), right half
    // label 2 (Dallas: region 1).
    let labels = Grid::from_vec(2, 1, vec![1.0, 2.0]).unwrap();
    (alps, TypeMap::new(labels, vec![(2, dallas)]).unwrap())
}

const W: usize = 1200;
const H: usize = 300;
const CELL: f64 = 90.0;

#[test]
fn blended_regions_ramp_across_the_band() {
    // The mosaic's Alps share in eight 5 km strips across a 40 km band
    // centred on the border follows the box filter's linear ramp
    // 0.5 − d / 40 km (d: the strip centre's offset from the border),
    // counted on a 50 m lattice; outside the band it is pure.
    let (_, tm) = two_halves();
    let (wm, hm) = (W as f64 * CELL, H as f64 * CELL);
    let band = 40_000.0;
    let border = 0.5 * wm;
    let mut shares = Vec::new();
    for k in 0..10 {
        let x0 = border - 25_000.0 + 5_000.0 * k as f64;
        let (mut a, mut n) = (0usize, 0usize);
        let mut y = 25.0;
        while y < hm {
            let mut x = x0 + 25.0;
            while x < x0 + 5_000.0 {
                let r = tm.region_blended(x / wm, y / hm, band / wm, band / hm, 7);
                n += 1;
                a += usize::from(r == Some(0));
                x += 50.0;
            }
            y += 50.0;
        }
        let d = x0 + 2_500.0 - border;
        let want = (0.5 - d / band).clamp(0.0, 1.0);
        let got = a as f64 / n as f64;
        shares.push(got);
        assert!(
            (got - want).abs() <= 0.1,
            "strip at {d} m: Alps share {got} vs {want}"
        );
    }
    println!("mosaic Alps share per 5 km strip: {shares:.3?}");
    assert_eq!(shares[0], 1.0);
    assert_eq!(shares[9], 0.0);
    for k in 1..9 {
        assert!(shares[k] < shares[k - 1], "not decreasing: {shares:?}");
    }
}

/// (Alps peaks right of the border, Dallas peaks left of it) within 20 km
/// of it and beyond 20 km.
fn crossings(band_m: f64) -> ([usize; 2], [usize; 2]) {
    let (alps, tm) = two_halves();
    let mut o = TreeOptions::new(W, H, CELL, 7);
    o.type_map = Some(tm);
    o.type_blend_m = band_m;
    let t = synthesize_tree(&alps, &o).unwrap();
    let border = 0.5 * W as f64 * CELL;
    let (mut near, mut far) = ([0usize; 2], [0usize; 2]);
    for p in &t.peaks {
        // The two profiles' elevation ranges do not overlap.
        let is_alps = p.elevation > 600.0;
        let d = p.x - border;
        let crossed = if is_alps { d >= 0.0 } else { d < 0.0 };
        if crossed {
            let k = usize::from(!is_alps);
            if d.abs() < 20_000.0 {
                near[k] += 1;
            } else {
                far[k] += 1;
            }
        }
    }
    (near, far)
}

#[test]
fn type_map_borders_blend_over_the_band() {
    // Band 40 km: each profile's peaks reach across the border, but not
    // beyond the band's half width.
    let (near, far) = crossings(40_000.0);
    println!("band 40 km: crossing peaks within 20 km {near:?}, beyond {far:?}");
    assert!(near[0] >= 5 && near[1] >= 5, "{near:?}");
    assert_eq!(far, [0, 0]);
    // Sharp borders (band 0): none cross.
    let (near0, far0) = crossings(0.0);
    assert_eq!((near0, far0), ([0, 0], [0, 0]));
}

#[test]
fn blend_weight_is_a_box_filter_of_the_regions() {
    // Regions 1 | 2 | nodata over three equal columns.
    let labels = Grid::from_vec(3, 1, vec![1.0, 2.0, f32::NAN]).unwrap();
    let tm = TypeMap::new(labels, vec![(2, shipped("lowrelief_dallas.json"))]).unwrap();
    // Label 1 is the main profile: region 0; label 2: region 1.
    let third = 1.0 / 3.0;
    // Sharp: the cell's own region.
    assert_eq!(tm.blend_weight(0.2, 0.5, 0, 0.0, 0.0), 1.0);
    assert_eq!(tm.blend_weight(0.2, 0.5, 1, 0.0, 0.0), 0.0);
    // On the border, a band of 0.3: the lattice is split 4 | 5 columns
    // (points at −0.15 + 0.3 (i + ½)/9 from it, i = 0..8, are left of it
    // for i < 4.5, i.e. 5 of 9: i = 0..4) — 5/9 in region 0 at x just left.
    let x = third - 1e-9;
    let a = tm.blend_weight(x, 0.5, 0, 0.3, 0.0);
    let b = tm.blend_weight(x, 0.5, 1, 0.3, 0.0);
    assert!(
        (a - 5.0 / 9.0).abs() < 1e-12 && (b - 4.0 / 9.0).abs() < 1e-12,
        "{a} {b}"
    );
    // Nodata does not dilute: at the 2 | nodata border region 1 is all the
    // labelled share; on nodata itself no region holds a peak.
    assert_eq!(tm.blend_weight(2.0 * third - 1e-9, 0.5, 1, 0.3, 0.0), 1.0);
    assert_eq!(tm.blend_weight(2.0 * third + 1e-9, 0.5, 1, 0.3, 0.0), 0.0);
    // Bad band widths are refused by the synthesis.
    let mut o = TreeOptions::new(100, 100, 90.0, 1);
    o.type_blend_m = f64::NAN;
    let e = synthesize_tree(&shipped("alps_montblanc.json"), &o).unwrap_err();
    assert!(e.to_string().contains("type_blend_m"), "{e}");
}
