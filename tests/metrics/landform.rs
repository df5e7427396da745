//! Landform classes: geomorphons on hand-made grids whose landform is known,
//! against a brute-force line-of-sight scan and the (−, +) lookup table of
//! Jasiewicz & Stepinski 2013 (Fig. 4) written out here independently; Weiss
//! and Dikau classes from the separately computed NTPI, slope and curvature
//! outputs; tiled == untiled on a real DEM.

#![allow(clippy::needless_range_loop)] // index loops read like the definitions

use orogen::io::{open_raster, OpenOptions};
use orogen::metrics::parse_specs;
use std::path::Path;

use crate::common::{run, run_bits, source, CELL, COMPASS8};

/// The paper's landform table, written as (class number, name, the
/// (number of −, number of +) cells of Fig. 4 holding it).
/// (class, name, (minus, plus) cells).
type Fig4Row = (u8, &'static str, &'static [(usize, usize)]);

const FIG4: &[Fig4Row] = &[
    (1, "flat", &[(0, 0), (0, 1), (0, 2), (1, 0), (1, 1), (2, 0)]),
    (2, "peak", &[(8, 0)]),
    (
        3,
        "ridge",
        &[(5, 0), (5, 1), (6, 0), (6, 1), (6, 2), (7, 0), (7, 1)],
    ),
    (4, "shoulder", &[(2, 1), (3, 0), (3, 1), (4, 0), (4, 1)]),
    (5, "spur", &[(4, 2), (5, 2), (5, 3)]),
    (
        6,
        "slope",
        &[(2, 2), (2, 3), (3, 2), (3, 3), (3, 4), (4, 3), (4, 4)],
    ),
    (7, "hollow", &[(2, 4), (2, 5), (3, 5)]),
    (8, "footslope", &[(0, 3), (0, 4), (1, 2), (1, 3), (1, 4)]),
    (
        9,
        "valley",
        &[(0, 5), (0, 6), (0, 7), (1, 5), (1, 6), (1, 7), (2, 6)],
    ),
    (10, "pit", &[(0, 8)]),
];

#[test]
fn lookup_table_matches_figure() {
    use orogen::metrics::landform::geomorphon_class;
    let mut seen = 0;
    for &(class, name, cells) in FIG4 {
        for &(minus, plus) in cells {
            assert_eq!(
                geomorphon_class(plus, minus),
                class,
                "{name}: ({minus} -, {plus} +)"
            );
            seen += 1;
        }
    }
    // Every (−, +) with − + + ≤ 8 is listed exactly once: 45 combinations.
    assert_eq!(seen, 45);
    for minus in 0..=8 {
        for plus in 0..=8 - minus {
            let n = FIG4.iter().filter(|c| c.2.contains(&(minus, plus))).count();
            assert_eq!(n, 1, "({minus}, {plus})");
        }
    }
}

const N: usize = 21;
const C: usize = 10;

fn grid(f: impl Fn(f64, f64) -> f64) -> Vec<f32> {
    let mut v = vec![0f32; N * N];
    for y in 0..N {
        for x in 0..N {
            v[y * N + x] = f(x as f64 - C as f64, y as f64 - C as f64) as f32;
        }
    }
    v
}

/// Pattern code from digits listed N, NE, E, SE, S, SW, W, NW (0 flat, 1 '+', 2 '−').
fn code(d: [u32; 8]) -> f32 {
    d.iter().rev().fold(0u32, |a, &x| a * 3 + x) as f32
}

#[test]
fn hand_made_landforms() {
    // (name, surface z(dx, dy) in metres with dy growing south, class, pattern)
    type Case = (
        &'static str,
        Box<dyn Fn(f64, f64) -> f64>,
        u8,
        Option<[u32; 8]>,
    );
    let cases: Vec<Case> = vec![
        (
            "peak",
            Box::new(|x: f64, y: f64| 500.0 - 10.0 * x.hypot(y)),
            2,
            Some([2; 8]),
        ),
        (
            "pit",
            Box::new(|x: f64, y: f64| 10.0 * x.hypot(y)),
            10,
            Some([1; 8]),
        ),
        (
            "V valley along north-south",
            Box::new(|x: f64, _| 8.0 * x.abs()),
            9,
            Some([0, 1, 1, 1, 0, 1, 1, 1]),
        ),
        (
            "ridge along east-west",
            Box::new(|_, y: f64| 300.0 - 8.0 * y.abs()),
            3,
            Some([2, 2, 0, 2, 2, 2, 0, 2]),
        ),
        ("flat plane", Box::new(|_, _| 123.0), 1, Some([0; 8])),
        (
            "plane rising to the south",
            Box::new(|_, y: f64| 100.0 + 3.0 * y),
            6,
            Some([2, 2, 0, 1, 1, 1, 0, 2]),
        ),
        // 0.3° slope: Δ = 2·0.3° < t = 1° on every line: flat.
        (
            "gentle plane under the threshold",
            Box::new(|x: f64, _| 100.0 + CELL * 0.3f64.to_radians().tan() * x),
            1,
            Some([0; 8]),
        ),
        // 0.6° slope: Δ = 1.2° > 1° only along the axis east-west (the
        // diagonals see 0.42°, Δ = 0.85°): one '+', one '−' is still flat.
        (
            "gentle plane over the threshold on the axis only",
            Box::new(|x: f64, _| 100.0 + CELL * 0.6f64.to_radians().tan() * x),
            1,
            Some([0, 0, 1, 0, 0, 0, 2, 0]),
        ),
        // 2° slope: the diagonals see 1.41°, Δ = 2.8°: three '+', three '−'.
        (
            "2 degree plane rising east",
            Box::new(|x: f64, _| 100.0 + CELL * 2f64.to_radians().tan() * x),
            6,
            Some([0, 1, 1, 1, 0, 2, 2, 2]),
        ),
        // Summit of a plateau edge is a shoulder: flat behind, falling ahead.
        (
            "shoulder",
            Box::new(|_, y: f64| if y <= 0.0 { 200.0 } else { 200.0 - 10.0 * y }),
            4,
            Some([0, 0, 0, 2, 2, 2, 0, 0]),
        ),
        // Foot of a slope: rising ahead, flat behind.
        (
            "footslope",
            Box::new(|_, y: f64| if y >= 0.0 { 50.0 } else { 50.0 - 10.0 * y }),
            8,
            Some([1, 1, 0, 0, 0, 0, 0, 1]),
        ),
    ];
    for (name, f, class, pattern) in cases {
        let src = source(&grid(f), N, N);
        let out = run(
            &src,
            "geomorphon:radius=5c,geomorphon_pattern:radius=50m",
            7,
            1,
        );
        let c = C * N + C;
        assert_eq!(out[0][c], class as f32, "{name}: class");
        if let Some(p) = pattern {
            assert_eq!(out[1][c], code(p), "{name}: pattern");
        }
    }
}

fn random_grid(w: usize, h: usize, seed: u64) -> Vec<f32> {
    let mut s = seed;
    let mut next = move || {
        s = s.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = s;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    };
    let mut v = vec![0f32; w * h];
    for y in 0..h {
        for x in 0..w {
            let r = next();
            // smooth trend + noise, ~4% nodata holes
            v[y * w + x] = if r % 25 == 0 {
                f32::NAN
            } else {
                (20.0 * ((x as f64) * 0.3).sin()
                    + 15.0 * ((y as f64) * 0.2).cos()
                    + (r >> 40) as f64 / (1u64 << 24) as f64 * 6.0) as f32
            };
        }
    }
    v
}

/// Straight scan: for each direction step along whole cells while the
/// centre distance stays within the radius (metres), elevation angles by
/// atan2, the independent Fig. 4 table.
fn brute(d: &[f32], w: usize, h: usize, radius_m: f64, flat: f64) -> (Vec<f32>, Vec<f32>) {
    let mut cls = vec![f32::NAN; w * h];
    let mut pat = vec![f32::NAN; w * h];
    for y in 0..h as i64 {
        for x in 0..w as i64 {
            let z0 = d[(y * w as i64 + x) as usize] as f64;
            if z0.is_nan() {
                continue;
            }
            let mut digits = [0u32; 8];
            for (k, &(dx, dy)) in COMPASS8.iter().enumerate() {
                let mut angles = Vec::new();
                let mut s = 1i64;
                loop {
                    let dist = s as f64 * CELL * ((dx * dx + dy * dy) as f64).sqrt();
                    if dist > radius_m * (1.0 + 1e-9) {
                        break;
                    }
                    let (px, py) = (x + dx * s, y + dy * s);
                    if px >= 0 && py >= 0 && px < w as i64 && py < h as i64 {
                        let z = d[(py * w as i64 + px) as usize] as f64;
                        if !z.is_nan() {
                            angles.push((z - z0).atan2(dist).to_degrees());
                        }
                    }
                    s += 1;
                }
                if angles.is_empty() {
                    continue;
                }
                let hi = angles.iter().cloned().fold(f64::MIN, f64::max);
                let lo = angles.iter().cloned().fold(f64::MAX, f64::min);
                let zenith = 90.0 - hi;
                let nadir = 90.0 + lo;
                digits[k] = if nadir - zenith > flat {
                    1
                } else if zenith - nadir > flat {
                    2
                } else {
                    0
                };
            }
            let plus = digits.iter().filter(|&&v| v == 1).count();
            let minus = digits.iter().filter(|&&v| v == 2).count();
            let class = FIG4
                .iter()
                .find(|c| c.2.contains(&(minus, plus)))
                .map(|c| c.0)
                .unwrap();
            let i = (y * w as i64 + x) as usize;
            cls[i] = class as f32;
            pat[i] = code(digits);
        }
    }
    (cls, pat)
}

fn same(a: &[f32], b: &[f32]) -> bool {
    a.len() == b.len()
        && a.iter()
            .zip(b)
            .all(|(x, y)| x == y || (x.is_nan() && y.is_nan()))
}

#[test]
fn geomorphon_brute_force() {
    let (w, h) = (37, 29);
    for (seed, radius, flat) in [(1u64, 4usize, 1.0), (2, 7, 0.5), (3, 2, 5.0)] {
        let d = random_grid(w, h, seed);
        let src = source(&d, w, h);
        let specs = format!("geomorphon:radius={radius}c:flat={flat},geomorphon_pattern:radius={radius}c:flat={flat}");
        let (cls, pat) = brute(&d, w, h, radius as f64 * CELL, flat);
        for tile in [5, 64] {
            let out = run(&src, &specs, tile, 2);
            for i in 0..w * h {
                assert!(
                    same(&out[0][i..i + 1], &cls[i..i + 1])
                        && same(&out[1][i..i + 1], &pat[i..i + 1]),
                    "seed {seed} r {radius} tile {tile} cell ({}, {}): got {} {} want {} {}",
                    i % w,
                    i / w,
                    out[0][i],
                    out[1][i],
                    cls[i],
                    pat[i]
                );
            }
            // all ten classes are plausible on noise; at least several occur
            let mut kinds: Vec<u32> = cls
                .iter()
                .filter(|v| !v.is_nan())
                .map(|v| *v as u32)
                .collect();
            kinds.sort_unstable();
            kinds.dedup();
            assert!(kinds.len() >= 4, "seed {seed}: classes {kinds:?}");
        }
    }
}

/// Weiss's table written as a decision on (small, large) NTPI and slope.
fn weiss_oracle(sn: f32, ln: f32, slope: f32, t: f32) -> f32 {
    if sn.is_nan() || ln.is_nan() || slope.is_nan() {
        return f32::NAN;
    }
    let table = [[1, 2, 3], [4, 0, 7], [8, 9, 10]];
    let band = |v: f32| (v > -1.0) as usize + (v >= 1.0) as usize;
    let (a, b) = (band(sn), band(ln));
    if (a, b) == (1, 1) {
        if slope <= t {
            5.0
        } else {
            6.0
        }
    } else {
        table[a][b] as f32
    }
}

#[test]
fn weiss_from_ntpi_and_slope() {
    let (w, h) = (40, 33);
    let d = random_grid(w, h, 9);
    let src = source(&d, w, h);
    let out = run(
        &src,
        "weiss_landform:radius=2c:large=6c:slope=4,ntpi:radius=2c,ntpi:radius=6c,slope",
        7,
        2,
    );
    let mut kinds = Vec::new();
    for i in 0..w * h {
        let want = weiss_oracle(out[1][i], out[2][i], out[3][i], 4.0);
        assert!(
            same(&out[0][i..i + 1], &[want]),
            "cell {i}: {} vs {want}",
            out[0][i]
        );
        if !want.is_nan() {
            kinds.push(want as u32);
        }
    }
    kinds.sort_unstable();
    kinds.dedup();
    assert!(kinds.len() >= 5, "classes {kinds:?}");
    // Known forms at the centre of hand-made grids.
    for (name, f, want) in [
        (
            "peak",
            Box::new(|x: f64, y: f64| 500.0 - 10.0 * x.hypot(y)) as Box<dyn Fn(f64, f64) -> f64>,
            10.0,
        ),
        ("pit", Box::new(|x: f64, y: f64| 10.0 * x.hypot(y)), 1.0),
        ("flat", Box::new(|_, _| 7.0), 5.0),
        ("steep plane", Box::new(|x: f64, _| 5.0 * x), 6.0),
    ] {
        let src = source(&grid(f), N, N);
        let out = run(&src, "weiss_landform:radius=2c:large=8c", 64, 1);
        assert_eq!(out[0][C * N + C], want, "{name}");
    }
}

#[test]
fn dikau_from_curvatures() {
    let (w, h) = (30, 26);
    let d = random_grid(w, h, 5);
    let src = source(&d, w, h);
    let t = 0.002f32;
    for r in [1, 3] {
        let out = run(
            &src,
            &format!("dikau_form:radius={r}c:threshold={t},profile_curvature:radius={r}c,plan_curvature:radius={r}c"),
            6,
            2,
        );
        let s = |k: f32| {
            if k < -t {
                0
            } else if k > t {
                2
            } else {
                1
            }
        };
        let mut kinds = Vec::new();
        for i in 0..w * h {
            let want = if out[1][i].is_nan() {
                f32::NAN
            } else {
                (3 * s(out[1][i]) + s(out[2][i]) + 1) as f32
            };
            assert!(
                same(&out[0][i..i + 1], &[want]),
                "r {r} cell {i}: {} vs {want}",
                out[0][i]
            );
            if !want.is_nan() {
                kinds.push(want as u32);
            }
        }
        kinds.sort_unstable();
        kinds.dedup();
        assert!(kinds.len() >= 5, "r {r}: classes {kinds:?}");
    }
    // Dome off its apex: convex both ways; bowl: concave both ways; plane: straight.
    for (name, f, want) in [
        (
            "dome",
            Box::new(|x: f64, y: f64| 1000.0 - 0.5 * (x * x + y * y))
                as Box<dyn Fn(f64, f64) -> f64>,
            9.0,
        ),
        (
            "bowl",
            Box::new(|x: f64, y: f64| 0.5 * (x * x + y * y)),
            1.0,
        ),
        ("plane", Box::new(|x: f64, y: f64| 3.0 * x - 2.0 * y), 5.0),
    ] {
        let src = source(&grid(f), N, N);
        let out = run(&src, "dikau_form", 64, 1);
        // three cells east and two south of the centre
        assert_eq!(out[0][(C + 2) * N + C + 3], want, "{name}");
    }
}

#[test]
fn tiled_equals_untiled_bigtujunga() {
    let path = "tests/data/bigtujunga_crop.tif";
    let src = open_raster(Path::new(path), &OpenOptions::default()).unwrap();
    let src = src.as_ref();
    let specs = "geomorphon:radius=300m,geomorphon_pattern:radius=6c:flat=2,geomorphon_pattern:radius=300m,geomorphon_canonical:radius=5c,weiss_landform:radius=3c:large=400m,dikau_form,dikau_form:radius=2c:threshold=0.0005";
    let info = src.info().clone();
    let whole = run_bits(src, specs, info.width.max(info.height), 1);
    for g in &whole {
        assert!(g.iter().filter(|&&v| v != u32::MAX).count() > info.width * info.height / 2);
    }
    for (tile, threads) in [(1, 2), (7, 2), (64, 1), (64, 2)] {
        let got = run_bits(src, specs, tile, threads);
        for k in 0..whole.len() {
            assert!(got[k] == whole[k], "metric {k} differs with tile {tile}");
        }
    }
    // Each metric alone equals the multi pass.
    for (k, s) in specs.split(',').enumerate() {
        assert!(run_bits(src, s, 64, 1)[0] == whole[k], "{s} alone");
    }
}

#[test]
fn spec_parsing_and_labels() {
    let s = parse_specs("geomorphon,weiss_landform:radius=3c:large=1km:slope=3,dikau_form:threshold=0.001,geomorphon:flat=1").unwrap();
    assert_eq!(s[0].label(), "geomorphon_r10c");
    assert_eq!(s[1].label(), "weiss_landform_r3c_R1000m_t3");
    assert_eq!(s[2].label(), "dikau_form_t0.001");
    assert_eq!(s[3].label(), "geomorphon_r10c");
    for bad in [
        "geomorphon:flat=-1",
        "geomorphon:flat=NaN",
        "geomorphon:flat=x",
        "weiss_landform:large=0c",
        "dikau_form:threshold=inf",
    ] {
        assert!(parse_specs(bad).is_err(), "{bad}");
    }
}

/// Canonical codes by rotating and mirroring digit vectors explicitly: 498
/// classes over the 6561 patterns (Jasiewicz & Stepinski 2013), each the
/// smallest code of its orbit.
#[test]
fn canonical_patterns() {
    use orogen::metrics::landform::canonical_code;
    let enc = |d: &[u32]| d.iter().rev().fold(0u32, |a, &x| a * 3 + x);
    let mut canon = std::collections::BTreeSet::new();
    for c in 0..6561u32 {
        let d: Vec<u32> = (0..8).map(|i| c / 3u32.pow(i) % 3).collect();
        let mut orbit = Vec::new();
        for base in [d.clone(), d.iter().rev().cloned().collect::<Vec<u32>>()] {
            for r in 0..8 {
                let mut v = base.clone();
                v.rotate_left(r);
                orbit.push(enc(&v));
            }
        }
        let want = *orbit.iter().min().unwrap();
        assert_eq!(canonical_code(c), want, "code {c}");
        canon.insert(want);
    }
    assert_eq!(canon.len(), 498);
    // On a DEM: the canonical output is the canonical form of the pattern.
    let (w, h) = (31, 27);
    let d = random_grid(w, h, 11);
    let src = source(&d, w, h);
    let out = run(
        &src,
        "geomorphon_pattern:radius=4c,geomorphon_canonical:radius=4c",
        6,
        2,
    );
    for i in 0..w * h {
        let want = if out[0][i].is_nan() {
            f32::NAN
        } else {
            canonical_code(out[0][i] as u32) as f32
        };
        assert!(same(&out[1][i..i + 1], &[want]), "cell {i}");
    }
}

/// GRASS r.geomorphon 8.2.1's forms on the Big Tujunga crop
/// (tests/data/grass; `search=10 skip=0 flat=1 dist=0`): `rule=grass`
/// agrees on at least 99 % of the cells GRASS classifies and on which cells
/// are nodata (the outermost ring); the paper's rule (the default) differs
/// on several percent, mostly near the flatness threshold.
#[test]
fn grass_rule_agrees_with_r_geomorphon() {
    let dem = open_raster(
        Path::new("tests/data/bigtujunga_crop.tif"),
        &OpenOptions::default(),
    )
    .unwrap();
    let g = open_raster(
        Path::new("tests/data/grass/geomorphon_s10_bigtujunga_crop.tif"),
        &OpenOptions::default(),
    )
    .unwrap();
    let info = g.info().clone();
    let grass: orogen::raster::Grid<f32> = orogen::raster::read_window(
        g.as_ref(),
        orogen::raster::Window::new(0, 0, info.width, info.height),
    )
    .unwrap();
    let ours = run(
        dem.as_ref(),
        "geomorphon:radius=10c:flat=1:rule=grass,geomorphon:radius=10c:flat=1",
        64,
        2,
    );
    let agree = |o: &[f32]| {
        let (mut same, mut n, mut mask_differs) = (0usize, 0usize, 0usize);
        for (a, b) in o.iter().zip(grass.data()) {
            if a.is_nan() != b.is_nan() {
                mask_differs += 1;
            } else if !b.is_nan() {
                n += 1;
                same += usize::from(a == b);
            }
        }
        (same as f64 / n as f64, mask_differs, n)
    };
    let (rate, mask, n) = agree(&ours[0]);
    assert_eq!(mask, 0, "nodata cells differ from GRASS's");
    assert!(n > 55_000, "{n}");
    assert!(
        rate >= 0.99,
        "rule=grass agrees on {:.3} % of cells",
        100.0 * rate
    );
    let (paper, _, _) = agree(&ours[1]);
    assert!(
        paper < rate - 0.02,
        "the paper's rule agrees on {:.3} %, grass on {:.3} %",
        100.0 * paper,
        100.0 * rate
    );
}

/// The two line rules on one line of sight: rising 3° and falling 2.5°
/// (threshold 1°) is flat for the paper (Δ = 0.5°) and '+' for GRASS (the
/// larger angle wins); a tie is flat for GRASS.
#[test]
fn paper_and_grass_line_rules() {
    use orogen::metrics::landform::{ternary, ternary_grass, T_FLAT, T_MINUS, T_PLUS};
    assert_eq!(ternary(3.0, -2.5, 1.0), T_FLAT);
    assert_eq!(ternary_grass(3.0, -2.5, 1.0), T_PLUS);
    assert_eq!(ternary_grass(2.0, -2.0, 1.0), T_FLAT);
    assert_eq!(ternary_grass(-2.0, -5.0, 1.0), T_MINUS);
    assert_eq!(ternary(-2.0, -5.0, 1.0), T_MINUS);
    assert_eq!(ternary_grass(0.5, -0.9, 1.0), T_FLAT);
}
