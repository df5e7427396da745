#![no_main]
//! Fuzz target: a tile store with several tiles. The input is the manifest,
//! then tile files separated by lines `--TILE--`, given to tiles 0, 1, 2, …
//! in the manifest's row-major order (at most 64); the store is opened, every
//! tile verified, and windows read (first block, last block — the clipped
//! edge tiles — and one straddling the edge).
use libfuzzer_sys::fuzz_target;
use orogen::store::{tile_file, Manifest, TileStore, MANIFEST};

const SEP: &[u8] = b"\n--TILE--\n";

fuzz_target!(|data: &[u8]| {
    fuzz_common::serial_rayon();
    let mut parts = Vec::new();
    let mut rest = data;
    while let Some(i) = rest.windows(SEP.len()).position(|w| w == SEP) {
        parts.push(&rest[..i]);
        rest = &rest[i + SEP.len()..];
    }
    parts.push(rest);
    let dir = fuzz_common::scratch().join("m.tiles");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch dir");
    let mpath = dir.join(MANIFEST);
    std::fs::write(&mpath, parts[0]).expect("scratch write");
    if let Ok(m) = Manifest::read(&mpath) {
        let layout = m.layout();
        for (id, tile) in parts[1..].iter().enumerate().take(layout.count().min(64)) {
            let (tx, ty) = layout.coords(id);
            std::fs::write(tile_file(&dir, tx, ty), tile).expect("scratch write");
        }
    }
    if let Ok(st) = TileStore::open(&dir) {
        let _ = st.verify_all();
        fuzz_common::read_some(&st);
    }
});
