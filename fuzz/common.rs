//! Shared helpers of the fuzz targets: write the input to a scratch file
//! (the readers take paths), and read pixel windows so decoders run.

use orogen::raster::{read_window_native, RasterSource, Window};
use std::path::PathBuf;

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
