#![no_main]
//! Fuzz target: open a PNG heightmap with `io::open_raster` and read windows.
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    fuzz_common::serial_rayon();
    let p = fuzz_common::file("height.png", data);
    let opts = orogen::io::OpenOptions {
        png_scale: Some(0.5),
        png_offset: Some(-10.0),
        ..Default::default()
    };
    if let Ok(src) = orogen::io::open_raster(&p, &opts) {
        fuzz_common::read_some(src.as_ref());
    }
});
