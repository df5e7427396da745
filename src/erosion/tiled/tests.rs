//! Tests of the halo-exchange driver: tiled == untiled, ranks simulated by threads.
use super::*;
use crate::erosion::{
    CellSize, Diffusion, DiffusionParams, Hydraulic, HydraulicParams, Thermal, ThermalParams,
};
use crate::exec::mpi_halo::thread_ranks::chans;
use crate::raster::{GeoRef, MemRaster};

fn terrain(w: usize, h: usize) -> Grid<f64> {
    Grid::from_fn(w, h, |x, y| {
        if x == 4 && y == 6 {
            return f64::NAN;
        }
        let (fx, fy) = (x as f64, y as f64);
        let cone = 25.0 - (fx - 0.6 * w as f64).hypot(fy - 0.4 * h as f64) * 1.5;
        100.0
            + 8.0 * (fx * 0.37).sin() * (fy * 0.23).cos()
            + cone.max(0.0)
            + 3.0 * (fx * 1.7 + fy).sin()
    })
}

fn cfg(threads: usize) -> EngineConfig {
    EngineConfig {
        threads,
        memory_budget: 1 << 30,
        progress: false,
        observer: None,
        engine: Default::default(),
    }
}

/// Run on `ranks` simulated ranks; rank 0's emitted tiles as grids.
#[allow(clippy::too_many_arguments)]
fn ranked<M: LocalModel>(
    model: &M,
    src: &MemRaster,
    tile: usize,
    k: usize,
    ranks: usize,
    threads: usize,
    keep: Option<&[usize]>,
    narrow: bool,
    backend: impl Fn(usize) -> Backend + Sync,
) -> Vec<Grid<f64>> {
    let info = src.info();
    let (w, h) = (info.width, info.height);
    let layout = TileLayout::new(w, h, tile);
    let nf = model.field_names().len();
    std::thread::scope(|s| {
        let handles: Vec<_> = chans(ranks)
            .into_iter()
            .map(|mut c| {
                let backend = &backend;
                s.spawn(move || {
                    let me = c.me;
                    let mut grids: Vec<Grid<f64>> =
                        (0..nf).map(|_| Grid::new(w, h, -1.0)).collect();
                    let mut emitted = Vec::new();
                    let (backend, cfg) = (backend(me), cfg(threads));
                    let job = Tiled::new(model, src, layout, k, &backend, &cfg);
                    run_ranked(&job, &mut c, keep, narrow, |id, core, p| {
                        emitted.push(id);
                        for (g, f) in grids.iter_mut().zip(&p.fields) {
                            if !f.is_empty() {
                                g.paste(
                                    &Grid::from_vec(core.w, core.h, f.clone())?,
                                    core.x,
                                    core.y,
                                );
                            }
                        }
                        Ok(())
                    })
                    .unwrap();
                    if me == 0 {
                        assert_eq!(emitted, (0..layout.count()).collect::<Vec<_>>());
                    } else {
                        assert!(emitted.is_empty());
                    }
                    grids
                })
            })
            .collect();
        let mut all: Vec<Vec<Grid<f64>>> = handles.into_iter().map(|h| h.join().unwrap()).collect();
        all.swap_remove(0)
    })
}

fn same_bits(a: &Grid<f64>, b: &Grid<f64>, what: &str) {
    for (i, (x, y)) in a.data().iter().zip(b.data()).enumerate() {
        assert_eq!(x.to_bits(), y.to_bits(), "{what}: cell {i}: {x} vs {y}");
    }
}

fn check<M: LocalModel>(model: &M, dem: &Grid<f64>) {
    let reference = run_untiled(model, dem);
    let changed = reference[0]
        .data()
        .iter()
        .zip(dem.data())
        .filter(|(a, b)| a.is_finite() && (*a - *b).abs() > 1e-6)
        .count();
    assert!(
        changed > 50,
        "{}: only {changed} cells changed",
        model.name()
    );
    let src = MemRaster::from_grid(dem.clone(), GeoRef::pixel());
    for (tile, k) in [(7usize, 1usize), (11, 3), (8, 8)] {
        for ranks in 1..=4 {
            let threads = 1 + ranks % 2;
            let got = ranked(model, &src, tile, k, ranks, threads, None, false, |_| {
                Backend::Memory
            });
            for (f, (a, b)) in got.iter().zip(&reference).enumerate() {
                let what = format!(
                    "{} tile {tile} k {k} ranks {ranks}: field {f}",
                    model.name()
                );
                same_bits(a, b, &what);
            }
        }
    }
}

#[test]
fn ranks_equal_the_whole_grid_run() {
    let dem = terrain(37, 29);
    let p = HydraulicParams {
        rain: 0.05,
        rain_probability: 0.3,
        dt: 0.2,
        capacity: 0.05,
        settle: false,
        seed: 9,
        ..Default::default()
    };
    check(
        &Hydraulic::new(p, 14, CellSize { dx: 2.0, dy: 3.0 }).unwrap(),
        &dem,
    );
    let p = ThermalParams {
        talus: 25.0,
        rate: 0.4,
        cell: None,
    };
    check(
        &Thermal::new(p, 13, CellSize { dx: 1.0, dy: 1.5 }).unwrap(),
        &dem,
    );
    let p = DiffusionParams {
        diffusivity: 0.7,
        dt: 1.0,
        cell: None,
    };
    check(
        &Diffusion::new(p, 5, CellSize { dx: 1.0, dy: 1.2 }).unwrap(),
        &dem,
    );
}

/// Only the kept fields travel to rank 0; states on disk per rank.
#[test]
fn kept_fields_and_disk_states() {
    let dem = terrain(23, 31);
    let p = HydraulicParams {
        rain: 0.05,
        rain_probability: 0.5,
        dt: 0.2,
        capacity: 0.05,
        settle: false,
        seed: 3,
        ..Default::default()
    };
    let model = Hydraulic::new(p, 9, CellSize::square(2.0)).unwrap();
    let reference = run_untiled(&model, &dem);
    let src = MemRaster::from_grid(dem, GeoRef::pixel());
    let tmp = std::env::temp_dir().join(format!("orogen-halo-test-{}", std::process::id()));
    let keep = [0usize, 2];
    let got = ranked(&model, &src, 6, 2, 3, 2, Some(&keep), false, |r| {
        Backend::Disk(tmp.join(format!("rank{r}")))
    });
    let _ = std::fs::remove_dir_all(&tmp);
    for f in keep {
        same_bits(&got[f], &reference[f], &format!("disk, field {f}"));
    }
    // Fields not kept: tiles of other ranks never arrive (rank 0's own
    // tiles do); the last tile belongs to rank 2.
    let f = 1;
    assert_eq!(got[f].get(22, 30), -1.0);
}

/// `narrow`: remote tiles arrive rounded to f32, so every cell rounds to
/// the f32 of the whole-grid run (what an f32 output writes), and the
/// tiles of other ranks are really rounded (rank 0's own are not).
#[test]
fn narrow_tiles_give_the_f32_of_the_whole_grid_run() {
    let dem = terrain(23, 31);
    let p = ThermalParams {
        talus: 30.0,
        ..Default::default()
    };
    let model = Thermal::new(p, 12, CellSize::square(2.0)).unwrap();
    let reference = run_untiled(&model, &dem);
    let src = MemRaster::from_grid(dem, GeoRef::pixel());
    let got = ranked(&model, &src, 6, 2, 3, 1, Some(&[0]), true, |_| {
        Backend::Memory
    });
    let owner = partition(&TileLayout::new(23, 31, 6), 3);
    let (mut remote_rounded, mut own_exact) = (0usize, 0usize);
    for y in 0..31 {
        for x in 0..23 {
            let (a, b) = (got[0].get(x, y), reference[0].get(x, y));
            assert_eq!((a as f32).to_bits(), (b as f32).to_bits(), "cell {x},{y}");
            let id = (y / 6) * 23usize.div_ceil(6) + x / 6;
            if owner[id] == 0 {
                assert_eq!(a.to_bits(), b.to_bits(), "rank 0's own cell {x},{y}");
                own_exact += 1;
            } else {
                assert_eq!(a, f64::from(a as f32), "cell {x},{y} is not an f32");
                remote_rounded += usize::from(a != b);
            }
        }
    }
    assert!(
        own_exact > 0 && remote_rounded > 0,
        "{own_exact} {remote_rounded}"
    );
}
