//! Example-based synthesis (`orogen::synth::optimise`, `orogen synth
//! optimise`): energy decreases, guided structure, pit statistics with and
//! without pit removal, determinism across thread counts, bad inputs.
//! Oracles are independent of the code under test: block means and Pearson
//! correlation written here, depression counts by a flood-labelling written
//! here over the hydrology fill.

use orogen::io::{open_raster, OpenOptions};
use orogen::raster::{read_window, Grid, Window};
use orogen::synth::optimise::{
    synthesise, FinestPits, OptimiseOptions, PitRemoval, SearchSpace, Weighting,
};
use orogen::synth::{Fbm, FbmSource};
use std::path::{Path, PathBuf};
use std::process::Command;

fn data(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(p)
}

fn read(p: &Path) -> Grid<f32> {
    let src = open_raster(p, &OpenOptions::default()).unwrap();
    let (w, h) = (src.info().width, src.info().height);
    read_window::<f32>(src.as_ref(), Window::full(w, h)).unwrap()
}

/// bigtujunga_crop (301x203, 30 m SRTM, no nodata).
fn source() -> Grid<f32> {
    let g = read(&data("bigtujunga_crop.tif"));
    assert!(g.data().iter().all(|v| v.is_finite()));
    g
}

/// Means of f x f blocks (complete blocks only).
fn block_mean(g: &Grid<f32>, f: usize) -> Grid<f32> {
    let (w, h) = (g.width() / f, g.height() / f);
    Grid::from_fn(w, h, |x, y| {
        let mut s = 0f64;
        for yy in 0..f {
            for xx in 0..f {
                s += g.get(x * f + xx, y * f + yy) as f64;
            }
        }
        (s / (f * f) as f64) as f32
    })
}

fn correlation(a: &Grid<f32>, b: &Grid<f32>) -> f64 {
    let n = a.len() as f64;
    let ma = a.data().iter().map(|&v| v as f64).sum::<f64>() / n;
    let mb = b.data().iter().map(|&v| v as f64).sum::<f64>() / n;
    let (mut sab, mut saa, mut sbb) = (0f64, 0f64, 0f64);
    for (&x, &y) in a.data().iter().zip(b.data()) {
        let (dx, dy) = (x as f64 - ma, y as f64 - mb);
        sab += dx * dy;
        saa += dx * dx;
        sbb += dy * dy;
    }
    sab / (saa * sbb).sqrt()
}

/// (count, count at least 1 m deep, volume in DEM units x cells, depth of
/// the shallowest): 8-connected regions the priority-flood fill raises,
/// labelled here by a plain BFS.
fn depressions(g: &Grid<f32>) -> (usize, usize, f64, f32) {
    let f = orogen::hydro::fill(g).unwrap();
    let (w, h) = (g.width(), g.height());
    let mut label = vec![0u32; w * h];
    let (mut count, mut deep) = (0, 0);
    let mut vol = 0f64;
    let mut shallowest = f32::INFINITY;
    for y in 0..h {
        for x in 0..w {
            let raised = |x: usize, y: usize| f.get(x, y) > g.get(x, y);
            if !raised(x, y) || label[y * w + x] != 0 {
                continue;
            }
            count += 1;
            let mut depth = 0f32;
            let mut queue = std::collections::VecDeque::from([(x, y)]);
            label[y * w + x] = count as u32;
            while let Some((cx, cy)) = queue.pop_front() {
                vol += (f.get(cx, cy) - g.get(cx, cy)) as f64;
                depth = depth.max(f.get(cx, cy) - g.get(cx, cy));
                for ny in cy.saturating_sub(1)..(cy + 2).min(h) {
                    for nx in cx.saturating_sub(1)..(cx + 2).min(w) {
                        if raised(nx, ny) && label[ny * w + nx] == 0 {
                            label[ny * w + nx] = count as u32;
                            queue.push_back((nx, ny));
                        }
                    }
                }
            }
            if depth >= 1.0 {
                deep += 1;
            }
            shallowest = shallowest.min(depth);
        }
    }
    (count, deep, vol, shallowest)
}

fn fbm_guide(w: usize, h: usize, seed: u64) -> Grid<f32> {
    let fbm = Fbm {
        seed,
        octaves: 4,
        lacunarity: 2.0,
        gain: 0.5,
        wavelength: 30.0,
        base: 1200.0,
        amplitude: 700.0,
        warp: 4.0,
    };
    let src = FbmSource::new(fbm, w, h, 120.0).unwrap();
    read_window::<f32>(&src, Window::full(w, h)).unwrap()
}

fn opts(w: usize, h: usize) -> OptimiseOptions {
    OptimiseOptions {
        width: w,
        height: h,
        ..Default::default()
    }
}

fn nonincreasing(e: &[f64]) -> bool {
    e.windows(2).all(|p| p[1] <= p[0] * (1.0 + 1e-5))
}

#[test]
fn energy_decreases_across_em_iterations() {
    let src = source();
    let guide = block_mean(&src, 4);
    // Guide weight 0 and no pit removal: each M- and E-step minimises the
    // same energy, at every level.
    let mut o = opts(120, 84);
    o.weighting = Weighting::Zero;
    o.pit = PitRemoval::None;
    o.iterations = 3;
    let s = synthesise(&src, &guide, None, &o).unwrap();
    assert!(s.levels.len() >= 2);
    for r in &s.levels {
        assert_eq!(r.energies.len(), 1 + 2 * 3);
        assert!(
            nonincreasing(&r.energies),
            "level {}: {:?}",
            r.level,
            r.energies
        );
        let (first, last) = (r.energies[0], r.energies[r.energies.len() - 1]);
        assert!(last < 0.8 * first, "level {}: {:?}", r.level, r.energies);
    }
    // Default options: the finest level has guide weight 0 and no pit
    // removal, so its energy decreases too.
    let s = synthesise(&src, &guide, None, &opts(120, 84)).unwrap();
    let fine = s.levels.last().unwrap();
    assert_eq!(fine.level, 0);
    assert_eq!(fine.guide_weight, 0.0);
    assert!(nonincreasing(&fine.energies), "{:?}", fine.energies);
}

#[test]
fn guide_from_the_source_reproduces_its_large_scale_structure() {
    let src = source();
    let guide = block_mean(&src, 4); // 75 x 50
    let s = synthesise(&src, &guide, None, &opts(300, 200)).unwrap();
    assert!(s.output.data().iter().all(|v| v.is_finite()));
    let r = correlation(&block_mean(&s.output, 4), &guide);
    eprintln!("correlation of the 4x4 block means with the guide: {r:.4}");
    assert!(r > 0.95, "{r}");
    // A different guide (the source upside down) gives a different output
    // that follows it instead.
    let flipped = Grid::from_fn(75, 50, |x, y| guide.get(x, 49 - y));
    let s2 = synthesise(&src, &flipped, None, &opts(300, 200)).unwrap();
    let r2 = correlation(&block_mean(&s2.output, 4), &flipped);
    assert!(r2 > 0.95, "{r2}");
    assert!(correlation(&block_mean(&s2.output, 4), &guide) < 0.5);
}

/// Pit statistics of the output with and without pit removal (same inputs,
/// same seed; measured in docs/design/example-based-synthesis.md). With the default pit
/// removal (breach at every level but the finest, then the finest level's
/// shallow-pit pass, depth limit 2 x the source's detail RMS = 9.1 m here)
/// both the number of depressions and their volume are a small fraction of
/// the no-removal run's: asserted count < 0.3 and volume < 0.3 (measured
/// 0.19 / 0.15), and every depression left is deeper than the limit. Fill:
/// count < 0.4, volume < 0.1 (measured 0.26 / 0.04). The paper's own
/// schedule (`FinestPits::Keep`) cuts the volume (< 0.35; measured 0.15)
/// but not the count (measured 1.26): the finest level re-creates small
/// pits where overlapping patches are averaged. With `pit_finest` no
/// depression is left at all.
#[test]
fn pit_removal_leaves_a_fraction_of_the_depressions() {
    let src = source();
    let guide = fbm_guide(60, 40, 11);
    let (gc, _, _, _) = depressions(&guide);
    assert!(gc > 0, "the guide must have depressions for this test");
    let mut o = opts(240, 160);
    o.seed = 5;
    let run = |pit: PitRemoval, finest: FinestPits, step: f32| {
        let mut o = o.clone();
        o.pit = pit;
        o.finest = finest;
        o.drain_step = step;
        let s = synthesise(&src, &guide, None, &o).unwrap();
        let d = depressions(&s.output);
        eprintln!(
            "{pit:?} {finest:?} step {step}: {} depressions ({} at least 1 m deep), volume {:.4e} m x cells; finest pass depth {:?}",
            d.0, d.1, d.2, s.finest_depth
        );
        (d, s)
    };
    let def = OptimiseOptions::default();
    assert_eq!(def.pit, PitRemoval::Breach);
    assert_eq!(def.finest, FinestPits::Detail(2.0));
    let (none, _) = run(PitRemoval::None, def.finest, 0.0);
    let ratios = |d: (usize, usize, f64, f32)| (d.0 as f64 / none.0 as f64, d.2 / none.2);
    let (breach, sb) = run(PitRemoval::Breach, def.finest, 0.0);
    let (cr, vr) = ratios(breach);
    eprintln!("breach (default): count ratio {cr:.3}, volume ratio {vr:.3}");
    assert!(cr < 0.3 && vr < 0.3, "breach: count {cr}, volume {vr}");
    let (fill, _) = run(PitRemoval::Fill, def.finest, 0.0);
    let (cr, vr) = ratios(fill);
    eprintln!("fill: count ratio {cr:.3}, volume ratio {vr:.3}");
    assert!(cr < 0.4 && vr < 0.1, "fill: count {cr}, volume {vr}");
    // The paper's schedule: volume down, count not.
    let (keep, sk) = run(PitRemoval::Breach, FinestPits::Keep, 0.0);
    let (cr, vr) = ratios(keep);
    eprintln!("breach, finest level kept: count ratio {cr:.3}, volume ratio {vr:.3}");
    assert!(vr < 0.35, "{vr}");
    assert!(sk.finest_depth.is_none());
    // The finest pass moves no cell by more than its depth limit (the runs
    // differ only by that pass), and that limit is 2 x the detail RMS.
    let lim = sb.finest_depth.unwrap();
    assert!((lim - 2.0 * orogen::synth::optimise::detail_rms(&src)).abs() < 1e-4);
    let moved = sb
        .output
        .data()
        .iter()
        .zip(sk.output.data())
        .map(|(a, b)| (a - b).abs())
        .fold(0f32, f32::max);
    assert!(
        moved > 0.0 && moved <= lim * (1.0 + 1e-6),
        "{moved} vs {lim}"
    );
    // and every depression it leaves is deeper than that limit
    assert!(breach.3 > lim, "{} <= {lim}", breach.3);
    let (drained, _) = run(PitRemoval::Breach, FinestPits::Keep, 0.3);
    assert!(ratios(drained).1 < 0.35);
    o.pit = PitRemoval::Breach;
    o.pit_finest = true;
    let s = synthesise(&src, &guide, None, &o).unwrap();
    assert_eq!(depressions(&s.output).0, 0);
}

/// `remove_shallow_pits` on a built surface: a plane falling to the south
/// edge with three bowls, about 1.1, 2.6 and 11.6 deep (cones 1.5, 3 and 12
/// deep on the tilted plane). Limit 4: the two shallow ones go (breach and
/// fill), the deep one stays cell for cell, no cell moves by more than 3, a
/// fill only raises (inside the bowls), a breach only lowers (its channels
/// may run beyond the bowls).
#[test]
fn shallow_pits_go_deep_ones_stay() {
    use orogen::synth::optimise::remove_shallow_pits;
    let (w, h) = (60usize, 40usize);
    let bowls = [
        (12.0f32, 12.0f32, 1.5f32),
        (30.0, 20.0, 3.0),
        (48.0, 14.0, 12.0),
    ];
    let g = Grid::from_fn(w, h, |x, y| {
        let mut z = 100.0 + 0.1 * (h - 1 - y) as f32;
        for &(cx, cy, d) in &bowls {
            let r2 = (x as f32 - cx).powi(2) + (y as f32 - cy).powi(2);
            // a cone of radius 4 whose rim (r = 4) is d above its centre
            z -= (d * (1.0 - r2.sqrt() / 4.0)).max(0.0);
        }
        z
    });
    let before = depressions(&g);
    assert_eq!(before.0, 3, "three bowls");
    for how in [PitRemoval::Breach, PitRemoval::Fill] {
        let r = remove_shallow_pits(&g, 4.0, how, None).unwrap();
        let after = depressions(&r);
        assert_eq!(after.0, 1, "{how:?}");
        for y in 0..h {
            for x in 0..w {
                let (a, b) = (g.get(x, y), r.get(x, y));
                let near = |i: usize| {
                    let (cx, cy, _) = bowls[i];
                    (x as f32 - cx).abs() <= 6.0 && (y as f32 - cy).abs() <= 6.0
                };
                if near(2) {
                    assert_eq!(a, b, "{how:?}: the deep bowl is untouched at ({x}, {y})");
                }
                // no cell moves by more than the deeper shallow bowl's depth;
                // a fill only raises, a breach only lowers
                assert!((a - b).abs() <= 3.0, "{how:?} ({x}, {y}): {a} -> {b}");
                match how {
                    PitRemoval::Fill => {
                        assert!(b >= a);
                        if !near(0) && !near(1) {
                            assert_eq!(a, b, "fill: ({x}, {y}) is outside every bowl");
                        }
                    }
                    _ => assert!(b <= a),
                }
            }
        }
    }
    // limit 0: unchanged; a negative or NaN limit is an error
    assert_eq!(
        remove_shallow_pits(&g, 0.0, PitRemoval::Breach, None)
            .unwrap()
            .data(),
        g.data()
    );
    assert!(remove_shallow_pits(&g, -1.0, PitRemoval::Breach, None).is_err());
    assert!(remove_shallow_pits(&g, f32::NAN, PitRemoval::Fill, None).is_err());
}

#[test]
fn same_bytes_for_one_and_two_threads() {
    let src = source();
    let guide = fbm_guide(50, 40, 3);
    let run = |threads: usize, seed: u64| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let mut o = opts(150, 120);
        o.seed = seed;
        o.search.height_offset = true;
        pool.install(|| synthesise(&src, &guide, None, &o)).unwrap()
    };
    let a = run(1, 9);
    let b = run(2, 9);
    let bits = |g: &Grid<f32>| g.data().iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&a.output), bits(&b.output));
    assert_eq!(a.levels, b.levels);
    let c = run(2, 10);
    assert_ne!(bits(&a.output), bits(&c.output));
}

#[test]
fn every_search_space_and_pit_mode_runs() {
    let src = source();
    let guide = block_mean(&src, 4);
    for (rot, refl, sub, off) in [
        (false, false, false, false),
        (true, false, false, false),
        (false, true, true, false),
        (true, true, true, true),
    ] {
        let mut o = opts(96, 64);
        o.search = SearchSpace {
            rotation: rot,
            reflection: refl,
            subpixel: sub,
            height_offset: off,
        };
        o.pit = PitRemoval::Hybrid {
            max_depth: 20.0,
            max_length: 10,
        };
        o.falloff = None;
        let s = synthesise(&src, &guide, None, &o).unwrap();
        assert!(s.output.data().iter().all(|v| v.is_finite()));
        let r = correlation(
            &block_mean(&s.output, 4),
            &block_mean(&guide_resized(&guide, 96, 64), 4),
        );
        assert!(r > 0.8, "{rot} {refl} {sub} {off}: {r}");
    }
}

/// Nearest-neighbour resize (for comparing a guide with a smaller output).
fn guide_resized(g: &Grid<f32>, w: usize, h: usize) -> Grid<f32> {
    Grid::from_fn(w, h, |x, y| g.get(x * g.width() / w, y * g.height() / h))
}

#[test]
fn a_sink_mask_keeps_its_depression() {
    // A bowl guide: without sinks every level drains it to the border; a
    // sink at the centre lets the coarse levels keep the bowl.
    let src = source();
    let guide = Grid::from_fn(40, 40, |x, y| {
        let (dx, dy) = (x as f32 - 19.5, y as f32 - 19.5);
        1500.0 - 300.0 * (-(dx * dx + dy * dy) / 120.0).exp()
    });
    let mut o = opts(120, 120);
    o.weighting = Weighting::Constant;
    o.alpha = 0.9;
    o.keep_levels = true;
    let mask = Grid::from_fn(120, 120, |x, y| {
        (58..62).contains(&x) && (58..62).contains(&y)
    });
    let with = synthesise(&src, &guide, Some(&mask), &o).unwrap();
    let without = synthesise(&src, &guide, None, &o).unwrap();
    // Level 1 (pit removal applied): centre depth below the border minimum.
    let lvl1 = |s: &orogen::synth::optimise::Synthesis| {
        let i = s.levels.iter().position(|r| r.level == 1).unwrap();
        let g = &s.level_grids[i];
        let (w, h) = (g.width(), g.height());
        let border = (0..w)
            .flat_map(|x| [g.get(x, 0), g.get(x, h - 1)])
            .chain((0..h).flat_map(|y| [g.get(0, y), g.get(w - 1, y)]))
            .fold(f32::INFINITY, f32::min);
        (g.get(w / 2, h / 2), border)
    };
    let (cw, bw) = lvl1(&with);
    let (cn, bn) = lvl1(&without);
    assert!(
        cw < bw - 50.0,
        "with a sink the bowl stays: {cw} vs border {bw}"
    );
    assert!(
        cn >= bn - 1e-3,
        "without a sink the bowl drains: {cn} vs border {bn}"
    );
}

#[test]
fn source_nodata_is_avoided() {
    // The source with its left third and a hole as nodata: no output cell
    // may come from them (the output stays within the valid range; the
    // nodata cells are made extreme-free by being NaN).
    let mut src = source();
    for y in 0..src.height() {
        for x in 0..src.width() {
            let hole = (150..170).contains(&x) && (90..110).contains(&y);
            if x < 100 || hole {
                src.set(x, y, f32::NAN);
            }
        }
    }
    let valid: Vec<f32> = src
        .data()
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .collect();
    let lo = valid.iter().copied().fold(f32::INFINITY, f32::min);
    let hi = valid.iter().copied().fold(f32::NEG_INFINITY, f32::max);
    let guide = Grid::from_fn(30, 30, |x, y| lo + (hi - lo) * (x + y) as f32 / 60.0);
    let s = synthesise(&src, &guide, None, &opts(90, 90)).unwrap();
    assert!(s
        .output
        .data()
        .iter()
        .all(|v| v.is_finite() && *v >= lo - 1e-3 && *v <= hi + 1e-3));
    // A source that is all nodata cannot be used.
    let empty = Grid::new(50, 50, f32::NAN);
    let e = synthesise(&empty, &guide, None, &opts(90, 90))
        .unwrap_err()
        .to_string();
    assert!(e.contains("nodata"), "{e}");
}

#[test]
fn bad_inputs_are_clear_errors() {
    let src = source();
    let guide = block_mean(&src, 4);
    let err = |s: &Grid<f32>, g: &Grid<f32>, o: &OptimiseOptions| {
        synthesise(s, g, None, o).unwrap_err().to_string()
    };
    // guide larger than the output
    let e = err(&src, &src, &opts(100, 100));
    assert!(e.contains("larger than the output"), "{e}");
    // source smaller than a patch
    let tiny = Grid::new(6, 6, 1.0f32);
    let e = err(&tiny, &guide, &opts(100, 100));
    assert!(e.contains("smaller than one patch"), "{e}");
    // guide with nodata
    let mut g2 = guide.clone();
    g2.set(3, 3, f32::NAN);
    assert!(err(&src, &g2, &opts(100, 100)).contains("nodata"));
    // absurd sizes are refused before allocating
    let e = err(&src, &guide, &opts(1 << 20, 1 << 20));
    assert!(e.contains("cells"), "{e}");
    // bad parameters
    let mut o = opts(100, 100);
    o.patch = 2;
    assert!(err(&src, &guide, &o).contains("patch size"));
    let mut o = opts(100, 100);
    o.alpha = f32::NAN;
    assert!(err(&src, &guide, &o).contains("alpha"));
    let mut o = opts(100, 100);
    o.levels = Some(9);
    assert!(err(&src, &guide, &o).contains("levels"));
}

#[test]
fn cli_writes_output_and_previews() {
    let dir = tempfile::tempdir().unwrap();
    let guide = dir.path().join("guide.tif");
    // the guide: orogen's own noise generator through the CLI
    let bin = env!("CARGO_BIN_EXE_orogen");
    let st = Command::new(bin)
        .args([
            "synth",
            "noise",
            "--size",
            "40x30",
            "--cell",
            "120",
            "--wavelength",
            "20",
            "--octaves",
            "5",
            "-q",
            "-o",
        ])
        .arg(&guide)
        .status()
        .unwrap();
    assert!(st.success());
    let out = dir.path().join("out.tif");
    let prev = dir.path().join("prev");
    let o = Command::new(bin)
        .args(["synth", "optimise", "--source"])
        .arg(data("bigtujunga_crop.tif"))
        .arg("--guide")
        .arg(&guide)
        .args([
            "--size",
            "120x90",
            "--pit",
            "fill",
            "--stats",
            "--threads",
            "2",
            "--previews",
        ])
        .arg(&prev)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("output depressions"), "{err}");
    assert!(err.contains("finest level: depressions at most"), "{err}");
    let g = read(&out);
    assert_eq!((g.width(), g.height()), (120, 90));
    let src = open_raster(&out, &OpenOptions::default()).unwrap();
    // the guide's extent at the output size: 40*120/120 = 40 m cells
    let t = src.info().georef.transform;
    assert!(
        (t[1] - 40.0).abs() < 1e-9 && (t[5] + 40.0).abs() < 1e-9,
        "{t:?}"
    );
    let levels = std::fs::read_dir(&prev).unwrap().count();
    assert!(levels >= 2);
    // One preview per level, the size of that level (halving, rounding up:
    // 120x90, 60x45, 30x23, ...), opaque; level 0 shows the output with the
    // hypsometric tint: its lowest tenth greener than its highest tenth
    // (green lowlands to grey and white summits).
    let decode = |p: &Path| {
        let d = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(p).unwrap()));
        let mut r = d.read_info().unwrap();
        let mut buf = vec![0; r.output_buffer_size().unwrap()];
        let info = r.next_frame(&mut buf).unwrap();
        assert_eq!(info.color_type, png::ColorType::Rgba);
        (info.width as usize, info.height as usize, buf)
    };
    for k in 0..levels {
        let (w, h, px) = decode(&prev.join(format!("level_{k}.png")));
        let (mut ew, mut eh) = (120usize, 90usize);
        for _ in 0..k {
            (ew, eh) = (ew.div_ceil(2), eh.div_ceil(2));
        }
        assert_eq!((w, h), (ew, eh), "level {k}");
        assert!(
            px.chunks(4).all(|c| c[3] == 255),
            "level {k}: a transparent pixel"
        );
    }
    let (_, _, px) = decode(&prev.join("level_0.png"));
    let mut by_height: Vec<(f32, usize)> = g.data().iter().copied().zip(0..).collect();
    by_height.sort_by(|a, b| a.0.total_cmp(&b.0));
    let green = |ks: &[(f32, usize)]| {
        ks.iter()
            .map(|&(_, k)| px[4 * k + 1] as f64 - (px[4 * k] as f64 + px[4 * k + 2] as f64) / 2.0)
            .sum::<f64>()
            / ks.len() as f64
    };
    let tenth = by_height.len() / 10;
    let (low, high) = (
        green(&by_height[..tenth]),
        green(&by_height[by_height.len() - tenth..]),
    );
    assert!(
        low > high + 10.0,
        "lowest tenth greenness {low}, highest {high}"
    );
    // a guide larger than the output: one clear sentence, non-zero exit
    let o = Command::new(bin)
        .args(["synth", "optimise", "--source"])
        .arg(data("bigtujunga_crop.tif"))
        .arg("--guide")
        .arg(data("bigtujunga_crop.tif"))
        .args(["--size", "100x100", "-q", "-o"])
        .arg(dir.path().join("bad.tif"))
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("larger than the output"), "{err}");
    assert!(!dir.path().join("bad.tif").exists());
}

/// `drain_strictly` against a brute-force check: every cell off the border
/// has a neighbour at least `step` lower, no cell is lowered, and cells
/// that already fall by `step` or more towards the border keep their value.
#[test]
fn drain_strictly_leaves_no_flat() {
    use orogen::synth::optimise::drain_strictly;
    let (w, h) = (60usize, 40usize);
    // a filled noise surface: depressions become flats
    let g = fbm_guide(w, h, 11);
    let filled = orogen::hydro::fill(&g).unwrap();
    let flats = (0..w * h)
        .filter(|&c| {
            let (x, y) = (c % w, c / w);
            x > 0 && y > 0 && x + 1 < w && y + 1 < h && {
                let z = filled.data();
                (y - 1..y + 2).all(|ny| (x - 1..x + 2).all(|nx| z[ny * w + nx] >= z[c]))
            }
        })
        .count();
    assert!(flats > 0, "the test surface must have flats");
    let step = 0.25f32;
    let d = drain_strictly(&filled, step, None).unwrap();
    for y in 0..h {
        for x in 0..w {
            let c = d.get(x, y);
            assert!(c >= filled.get(x, y));
            if x == 0 || y == 0 || x + 1 == w || y + 1 == h {
                assert_eq!(c, filled.get(x, y));
                continue;
            }
            let mut ok = false;
            for ny in y - 1..y + 2 {
                for nx in x - 1..x + 2 {
                    ok |= d.get(nx, ny) + step <= c;
                }
            }
            assert!(ok, "({x}, {y}) has no neighbour {step} lower");
        }
    }
    // a cone falling 1 per cell towards the border is left alone
    let cone = Grid::from_fn(21, 21, |x, y| {
        100.0 - (x as f32 - 10.0).abs().max((y as f32 - 10.0).abs())
    });
    assert_eq!(
        drain_strictly(&cone, step, None).unwrap().data(),
        cone.data()
    );
    assert_eq!(
        drain_strictly(&filled, 0.0, None).unwrap().data(),
        filled.data()
    );
}
