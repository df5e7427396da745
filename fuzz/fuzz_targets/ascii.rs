#![no_main]
//! Fuzz target: open a ascii file with `io::open_raster` and read windows.
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    fuzz_common::serial_rayon();
    let p = fuzz_common::file("ascii.asc", data);
    if let Ok(src) = orogen::io::open_raster(&p, &orogen::io::OpenOptions::default()) {
        fuzz_common::read_some(src.as_ref());
    }
});
