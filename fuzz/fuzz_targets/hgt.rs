#![no_main]
//! Fuzz target: SRTM .hgt files. The reader accepts only the three exact
//! SRTM sizes, so when the first byte is odd the input is repeated to the
//! 3" size (1201x1201 cells) and the decoder runs; otherwise the input is
//! written as is (size checks).
use libfuzzer_sys::fuzz_target;

const SIZE3: usize = 1201 * 1201 * 2;

fuzz_target!(|data: &[u8]| {
    let bytes: Vec<u8> = match data.first() {
        Some(b) if b & 1 == 1 => data.iter().copied().cycle().take(SIZE3).collect(),
        _ => data.to_vec(),
    };
    let p = fuzz_common::file("N43E006.hgt", &bytes);
    if let Ok(src) = orogen::io::open_raster(&p, &orogen::io::OpenOptions::default()) {
        fuzz_common::read_some(src.as_ref());
    }
});
