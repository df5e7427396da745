//! Shared helpers of the fuzz targets: write the input to a scratch file
//! (the readers take paths), and read pixel windows so decoders run.

use orogen::raster::{read_window_native, RasterSource, Window};
use std::path::PathBuf;
use std::sync::OnceLock;

/// Make the calling thread the one worker of a one-thread rayon pool, once.
/// Readers decode several blocks with `par_iter`; on the default pool the
/// work stealing between threads varies from run to run, and so did the
/// edges libFuzzer counted (the GeoTIFF target's seeds gave 3054-3064 `cov`
/// on three replays), which makes a coverage plateau unmeasurable. Here the
/// parallel iterators run in order on the fuzzing thread itself
/// (`use_current_thread`: no hand-off to another thread). Call it first in
/// every target.
pub fn serial_rayon() {
    static POOL: OnceLock<rayon::ThreadPool> = OnceLock::new();
    POOL.get_or_init(|| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .use_current_thread()
            .build()
            .expect("a one-thread rayon pool")
    });
}

/// A per-process scratch directory (in /dev/shm when present: fast).
pub fn scratch() -> PathBuf {
    let base = if std::path::Path::new("/dev/shm").is_dir() {
        PathBuf::from("/dev/shm")
    } else {
        std::env::temp_dir()
    };
    let d = base.join(format!("orogen-fuzz-{}", std::process::id()));
    let _ = std::fs::create_dir_all(&d);
    d
}

/// Write `data` to `name` in the scratch directory and return its path.
pub fn file(name: &str, data: &[u8]) -> PathBuf {
    let p = scratch().join(name);
    std::fs::write(&p, data).expect("scratch write");
    p
}

/// Read a few bounded windows: the first block, the last block, and a
/// window straddling the raster's edge (padding path). Errors are fine;
/// panics and huge allocations are the findings.
pub fn read_some(src: &dyn RasterSource) {
    let info = src.info();
    let (w, h) = (info.width, info.height);
    if w == 0 || h == 0 {
        return;
    }
    let (bw, bh) = info.block;
    let bw = bw.clamp(1, 256).min(w);
    let bh = bh.clamp(1, 256).min(h);
    let _ = read_window_native(src, Window::new(0, 0, bw, bh));
    let _ = read_window_native(src, Window::new((w - bw) as i64, (h - bh) as i64, bw, bh));
    let _ = orogen::raster::read_window::<f32>(src, Window::new(w as i64 - 3, h as i64 - 3, 6, 6));
}
