//! Large ingest under a small memory budget. Run with
//! `/usr/bin/time -v cargo bench --bench ingest_big` (or the built bench binary)
//! to measure peak RSS; `OROGEN_BIG_SIDE`, `OROGEN_BIG_DIR`, `OROGEN_BIG_ZSTD` adjust it. The source generates cells on
//! the fly, so the process holds no copy of the raster.

use orogen::exec::{ingest, EngineConfig};
use orogen::raster::{AnyGrid, DType, GeoRef, Grid, RasterInfo, RasterSource, Window};
use orogen::store::{Compression, StoreOptions, TileStore};
use orogen::Result;

/// Cell value of the synthetic raster (a cheap integer hash, as f32).
fn value(x: usize, y: usize) -> f32 {
    let mut z = (x as u64) << 32 | y as u64;
    z = (z ^ (z >> 33)).wrapping_mul(0xff51_afd7_ed55_8ccd);
    z ^= z >> 33;
    (z % 100_000) as f32 * 0.01 + (x as f32 * 0.001).sin() * 50.0
}

struct Synthetic(RasterInfo);
impl RasterSource for Synthetic {
    fn info(&self) -> &RasterInfo {
        &self.0
    }
    fn read_native(&self, win: Window) -> Result<AnyGrid> {
        Ok(AnyGrid::F32(Grid::from_fn(win.w, win.h, |x, y| {
            value(win.x as usize + x, win.y as usize + y)
        })))
    }
}

fn side() -> usize {
    std::env::var("OROGEN_BIG_SIDE")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(20_000)
}

fn main() {
    let n = side();
    let src = Synthetic(RasterInfo {
        width: n,
        height: n,
        dtype: DType::F32,
        georef: GeoRef::pixel(),
        block: (n, 1),
        path: "synthetic".into(),
    });
    let base = std::env::var("OROGEN_BIG_DIR")
        .unwrap_or_else(|_| std::env::temp_dir().display().to_string());
    let dir = std::path::Path::new(&base).join(format!("orogen-big-{}.tiles", std::process::id()));
    let opts = StoreOptions {
        tile: 1024,
        compression: if std::env::var("OROGEN_BIG_ZSTD").is_ok() {
            Compression::Zstd { level: 1 }
        } else {
            Compression::None
        },
        overwrite: true,
        sync: true,
    };
    let cfg = EngineConfig {
        threads: 2,
        memory_budget: 32 << 20,
        progress: false,
        observer: None,
        engine: Default::default(),
    };
    let t = std::time::Instant::now();
    ingest(&src, &dir, opts, &cfg).unwrap();
    eprintln!("ingest {n}x{n} f32: {:.1} s", t.elapsed().as_secs_f64());
    let t = std::time::Instant::now();
    let st = TileStore::open(&dir).unwrap();
    let layout = st.layout();
    for id in 0..layout.count() {
        let win = layout.window(id);
        let g = st.read_native(win).unwrap();
        let AnyGrid::F32(g) = g else { panic!("dtype") };
        for y in (0..win.h).step_by(97) {
            for x in (0..win.w).step_by(89) {
                assert_eq!(g.get(x, y), value(win.x as usize + x, win.y as usize + y));
            }
        }
    }
    eprintln!(
        "read back {} tiles: {:.1} s",
        layout.count(),
        t.elapsed().as_secs_f64()
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
