//! Timings on a large real DEM (a bench binary, run in release):
//!
//! ```text
//! gdal_translate -of ENVI -ot Float32 poland_N49-55_E014-025.tif /tmp/poland.f32
//! OROGEN_HYDRO_PERF_DEM=/tmp/poland.f32:13201:7201:-32768 \
//!   cargo bench --bench hydro_perf
//! ```
//! With `OROGEN_HYDRO_RICHDEM` set (by `tools/richdem_compare.py`) it compares
//! orogen's fill with RichDEM's output instead.
//! The DEM is a raw little-endian f32 file `path:width:height:nodata`.
//!
//! Without either variable it runs criterion benches of the accumulation
//! kernels (one thread) on a filled DEM: `OROGEN_HYDRO_BENCH_DEM` (any raster
//! orogen reads, e.g. `../shared/data/srtm3_S33W071.tif`), else a seeded
//! 2048 x 2048 fBm terrain:
//!
//! ```text
//! OROGEN_HYDRO_BENCH_DEM=../shared/data/srtm3_S33W071.tif cargo bench --bench hydro_perf
//! ```
//! Each step is also checked against the next (tiled fill == fill, D8 acyclic,
//! accumulation conserves cells) so the timings are of correct runs.

use criterion::{Criterion, Throughput};
use orogen::exec::GlobalStep;
use orogen::hydro::dinf::dinf;
use orogen::hydro::mfd::{accumulate_cells, mfd_flow, MfdMethod};
use orogen::hydro::tiled::{TiledAccumulation, TiledD8, TiledFill};
use orogen::hydro::{accumulate, d8_directions, fill, fill_epsilon, NODATA_DIR};
use orogen::raster::Window;
use orogen::raster::{read_view, GeoRef, Grid, MemRaster, RasterSource, TileLayout};
use orogen::synth::FbmSource;
use std::path::Path;
use std::time::Instant;

fn tiled<S: GlobalStep<In = f32>>(step: &S, src: &dyn RasterSource, tile: usize) -> Grid<S::Out> {
    let info = src.info();
    let layout = TileLayout::new(info.width, info.height, tile);
    let mut sums = Vec::new();
    for id in 0..layout.count() {
        let v = read_view::<f32>(src, &layout, id, step.halo()).unwrap();
        sums.push(step.map(&[v]).unwrap());
    }
    let sol = step.reduce(&layout, sums).unwrap();
    let mut out = Grid::new(
        info.width,
        info.height,
        <S::Out as orogen::raster::Cell>::from_f64(0.0),
    );
    for id in 0..layout.count() {
        let v = read_view::<f32>(src, &layout, id, step.halo()).unwrap();
        let core = layout.window(id);
        let mut o = vec![Grid::new(
            core.w,
            core.h,
            <S::Out as orogen::raster::Cell>::from_f64(0.0),
        )];
        step.apply(&[v], &step.slice(&sol, id), &mut o).unwrap();
        out.paste(&o[0], core.x, core.y);
    }
    out
}

fn perf_large_dem() {
    let spec =
        std::env::var("OROGEN_HYDRO_PERF_DEM").expect("set OROGEN_HYDRO_PERF_DEM=path:w:h:nodata");
    let parts: Vec<&str> = spec.split(':').collect();
    let (w, h): (usize, usize) = (parts[1].parse().unwrap(), parts[2].parse().unwrap());
    let nodata: f32 = parts[3].parse().unwrap();
    let bytes = std::fs::read(parts[0]).unwrap();
    let v = bytes
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .map(|z| if z == nodata { f32::NAN } else { z })
        .collect();
    let g = Grid::from_vec(w, h, v).unwrap();
    let mc = (w * h) as f64 / 1e6;
    let time = |name: &str, t: Instant| {
        let s = t.elapsed().as_secs_f64();
        eprintln!("{name:>24}: {s:7.3} s  {:7.1} Mcells/s", mc / s);
    };
    eprintln!("DEM {w}x{h} = {mc:.1} Mcells");
    let t = Instant::now();
    let f = fill(&g).unwrap();
    time("fill", t);
    let t = Instant::now();
    let e = fill_epsilon(&g).unwrap();
    time("fill_epsilon", t);
    drop(e);
    let t = Instant::now();
    let d = d8_directions(&f);
    time("d8 (with flats)", t);
    let t = Instant::now();
    let a = accumulate(&d).unwrap();
    time("accumulate", t);
    let valid = d.data().iter().filter(|&&c| c != NODATA_DIR).count();
    assert!(a.data().iter().all(|&x| x as usize <= valid));
    let src = MemRaster::from_grid(g.clone(), GeoRef::pixel());
    let t = Instant::now();
    let tf = tiled(&TiledFill, &src, 1024);
    time("tiled fill (1024, 1 thr)", t);
    assert!(tf
        .data()
        .iter()
        .zip(f.data())
        .all(|(p, q)| p.to_bits() == q.to_bits() || (p.is_nan() && q.is_nan())));
    drop(tf);
    let dsrc = MemRaster::from_grid(
        d.map(|c| if c == NODATA_DIR { f32::NAN } else { c as f32 }),
        GeoRef::pixel(),
    );
    let t = Instant::now();
    let ta = tiled(
        &TiledAccumulation {
            weighted: false,
            sca: false,
        },
        &dsrc,
        1024,
    );
    time("tiled accum (1024, 1 thr)", t);
    assert!(ta
        .data()
        .iter()
        .zip(a.data())
        .all(|(p, &q)| p.is_nan() || *p == q as f64));
    // TiledD8's map costs O(portals x flat area) per tile (see its docs):
    // its tile size is set apart, OROGEN_HYDRO_PERF_D8_TILE (default 1024)
    let d8_tile: usize = std::env::var("OROGEN_HYDRO_PERF_D8_TILE")
        .map(|v| v.parse().unwrap())
        .unwrap_or(1024);
    let fsrc = MemRaster::from_grid(f.clone(), GeoRef::pixel());
    let t = Instant::now();
    let td = tiled(&TiledD8, &fsrc, d8_tile);
    time(&format!("tiled d8 ({d8_tile}, 1 thr)"), t);
    assert_eq!(td.data(), d.data());
}

/// Used by `tools/richdem_compare.py`: times orogen's fill on a raw DEM and
/// compares it with RichDEM's filled output, bit for bit.
fn richdem_fill_matches() {
    let spec = std::env::var("OROGEN_HYDRO_RICHDEM").expect("set by tools/richdem_compare.py");
    let parts: Vec<&str> = spec.split(':').collect();
    let (w, h): (usize, usize) = (parts[1].parse().unwrap(), parts[2].parse().unwrap());
    let nodata: f32 = parts[3].parse().unwrap();
    let read = |p: &str| -> Vec<f32> {
        std::fs::read(p)
            .unwrap()
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect()
    };
    let raw = read(parts[0]);
    let theirs = read(parts[4]);
    let g = Grid::from_vec(
        w,
        h,
        raw.iter()
            .map(|&z| if z == nodata { f32::NAN } else { z })
            .collect(),
    )
    .unwrap();
    let t = Instant::now();
    let f = fill(&g).unwrap();
    let s = t.elapsed().as_secs_f64();
    // valid cells whose filled value differs; nodata cells one side has a
    // value for; differing cells where RichDEM's surface is higher
    let mut differ = 0;
    let mut nodata_differ = 0;
    let mut richdem_higher = 0;
    for (&a, &b) in f.data().iter().zip(&theirs) {
        let b_nodata = b == nodata || b.is_nan();
        if a.is_nan() != b_nodata {
            nodata_differ += 1;
        } else if !a.is_nan() && a.to_bits() != b.to_bits() {
            differ += 1;
            if b > a {
                richdem_higher += 1;
            }
        }
    }
    eprintln!(
        "richdem-compare cells={} differ={differ} nodata_differ={nodata_differ} richdem_higher={richdem_higher} orogen_s={s}",
        w * h
    );
}

/// The pre-session D8 accumulation kernel, kept as the same-run baseline:
/// receivers as a `u32` array built with per-cell bounds tests, then the
/// same downstream walk.
fn baseline_accumulate(dirs: &Grid<u8>) -> Vec<u64> {
    let (w, h) = (dirs.width(), dirs.height());
    let d = dirs.data();
    let n = d.len();
    let mut acc: Vec<u64> = d.iter().map(|&c| u64::from(c != NODATA_DIR)).collect();
    let mut recv = vec![u32::MAX; n];
    let mut indeg = vec![0u8; n];
    for y in 0..h {
        for x in 0..w {
            let c = y * w + x;
            let code = d[c];
            if code == NODATA_DIR || code == 0 {
                continue;
            }
            let k = code.trailing_zeros() as usize;
            let nx = x as i64 + orogen::hydro::DX[k];
            let ny = y as i64 + orogen::hydro::DY[k];
            if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                continue;
            }
            let r = ny as usize * w + nx as usize;
            if d[r] != NODATA_DIR {
                recv[c] = r as u32;
                indeg[r] += 1;
            }
        }
    }
    let mut order = Vec::with_capacity(n);
    for c0 in 0..n {
        if indeg[c0] != 0 || d[c0] == NODATA_DIR {
            continue;
        }
        let mut c = c0;
        loop {
            indeg[c] = u8::MAX;
            order.push(c as u32);
            let r = recv[c];
            if r == u32::MAX {
                break;
            }
            let r = r as usize;
            acc[r] += acc[c];
            indeg[r] -= 1;
            if indeg[r] != 0 {
                break;
            }
            c = r;
        }
    }
    acc
}

fn bench_dem() -> Grid<f32> {
    match std::env::var("OROGEN_HYDRO_BENCH_DEM") {
        Ok(p) => {
            let src = orogen::io::open_raster(Path::new(&p), &Default::default()).unwrap();
            let (w, h) = (src.info().width, src.info().height);
            orogen::raster::read_window::<f32>(src.as_ref(), Window::full(w, h)).unwrap()
        }
        Err(_) => {
            let n = 2048;
            let src = FbmSource::new(Default::default(), n, n, 30.0).unwrap();
            orogen::raster::read_window::<f32>(&src, Window::full(n, n)).unwrap()
        }
    }
}

/// CPU time of this thread in seconds (Linux schedstat; wall time elsewhere
/// is meaningless on a shared machine, CPU time is what "per core-second"
/// means).
fn thread_cpu_s() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    let ns: f64 = s.split_whitespace().next()?.parse().ok()?;
    Some(ns * 1e-9)
}

/// Mcells per CPU-second of `f` over `reps` runs.
fn cpu_rate(name: &str, cells: usize, reps: usize, mut f: impl FnMut()) {
    let (Some(t0), w0) = (thread_cpu_s(), Instant::now()) else {
        return;
    };
    for _ in 0..reps {
        f();
    }
    let cpu = thread_cpu_s().unwrap_or(t0) - t0;
    let wall = w0.elapsed().as_secs_f64();
    eprintln!(
        "{name:>28}: {:7.1} Mcells per CPU-second ({reps} runs, {cpu:.2} s CPU, {wall:.2} s wall)",
        (cells * reps) as f64 / cpu / 1e6
    );
}

fn criterion_benches() {
    let mut c = Criterion::default().configure_from_args().sample_size(10);
    let f = fill(&bench_dem()).unwrap();
    let d = d8_directions(&f);
    let (w, h) = (f.width(), f.height());
    let want = accumulate(&d).unwrap();
    assert_eq!(baseline_accumulate(&d), want.data());
    let quinn = mfd_flow(&f, MfdMethod::Quinn).unwrap();
    let dflow = dinf(&f).unwrap().flow;
    cpu_rate("d8", w * h, 20, || drop(accumulate(&d).unwrap()));
    cpu_rate("d8 baseline", w * h, 20, || drop(baseline_accumulate(&d)));
    cpu_rate("mfd quinn fixed point", w * h, 3, || {
        drop(accumulate_cells(&quinn).unwrap())
    });
    cpu_rate("dinf fixed point", w * h, 3, || {
        drop(accumulate_cells(&dflow).unwrap())
    });
    let mut g = c.benchmark_group(format!("accumulate_{w}x{h}"));
    g.throughput(Throughput::Elements((w * h) as u64));
    g.bench_function("d8", |b| b.iter(|| accumulate(&d).unwrap()));
    g.bench_function("d8_baseline", |b| b.iter(|| baseline_accumulate(&d)));
    g.bench_function("mfd_quinn_fixed_point", |b| {
        b.iter(|| accumulate_cells(&quinn).unwrap())
    });
    g.bench_function("dinf_fixed_point", |b| {
        b.iter(|| accumulate_cells(&dflow).unwrap())
    });
    g.finish();
    c.final_summary();
}

fn main() {
    if std::env::var("OROGEN_HYDRO_RICHDEM").is_ok() {
        richdem_fill_matches();
    } else if std::env::var("OROGEN_HYDRO_PERF_DEM").is_ok() {
        perf_large_dem();
    } else {
        criterion_benches();
    }
}
