#![no_main]
//! Fuzz target: a tile store. The input is the manifest, then (after a
//! line `--TILE--`) the bytes of tile file t_0_0.bin; the store is opened
//! and windows read (so the tile decoder runs too).
use libfuzzer_sys::fuzz_target;

const SEP: &[u8] = b"\n--TILE--\n";

fuzz_target!(|data: &[u8]| {
    fuzz_common::serial_rayon();
    let (manifest, tile) = match data.windows(SEP.len()).position(|w| w == SEP) {
        Some(i) => (&data[..i], &data[i + SEP.len()..]),
        None => (data, &[][..]),
    };
    let dir = fuzz_common::scratch().join("s.tiles");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch dir");
    std::fs::write(dir.join("manifest.json"), manifest).expect("scratch write");
    std::fs::write(dir.join("t_0_0.bin"), tile).expect("scratch write");
    if let Ok(src) = orogen::io::open_raster(&dir, &orogen::io::OpenOptions::default()) {
        fuzz_common::read_some(src.as_ref());
    }
});
