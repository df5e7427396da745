#![no_main]
//! Fuzz target: SRTM .hgt files. The reader accepts only the three exact
//! SRTM sizes, so when the first byte is odd the input is repeated to the
//! 3" size (1201x1201 cells) and the decoder runs; otherwise the input is
//! written as is (size checks).
use libfuzzer_sys::fuzz_target;

const SIZE3: usize = 1201 * 1201 * 2;

fuzz_target!(|data: &[u8]| {
    fuzz_common::serial_rayon();
    let bytes: Vec<u8> = match data.first() {
        Some(b) if b & 1 == 1 => {
            // Whole-slice copies: an iterator chain is too slow unoptimised.
            let mut v = Vec::with_capacity(SIZE3 + data.len());
            while v.len() < SIZE3 {
                v.extend_from_slice(data);
            }
            v.truncate(SIZE3);
            v
        }
        _ => data.to_vec(),
    };
    let p = fuzz_common::file("N43E006.hgt", &bytes);
    if let Ok(src) = orogen::io::open_raster(&p, &orogen::io::OpenOptions::default()) {
        fuzz_common::read_some(src.as_ref());
    }
});
