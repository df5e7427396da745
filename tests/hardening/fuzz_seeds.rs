//! Fuzzing (issue 12): the committed seed corpora stay valid inputs, and
//! every finding of `cargo fuzz` (see docs/RELIABILITY.md) is replayed here
//! from its minimised input in `tests/data/fuzz/`: it must give a typed
//! error (or a valid raster), never a panic or an unbounded allocation.

use crate::common::u16_store;
use orogen::io::{open_raster, OpenOptions};
use orogen::raster::{read_window, Window};
use orogen::store::Compression;
use std::path::{Path, PathBuf};

const SEP: &[u8] = b"\n--TILE--\n";

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The store seeds of the `store` fuzz target: a manifest, then `SEP`, then
/// the single tile file. Built here with the store writer; with
/// `OROGEN_WRITE_SEEDS=1` they are (re)written into fuzz/corpus/store/.
fn store_seed(tmp: &Path, compression: Compression) -> Vec<u8> {
    let dir = tmp.join("seed.tiles");
    let _ = std::fs::remove_dir_all(&dir);
    u16_store(&dir, 12, 10, compression);
    let mut out = std::fs::read(dir.join("manifest.json")).unwrap();
    out.extend_from_slice(SEP);
    out.extend_from_slice(&std::fs::read(dir.join("t_0_0.bin")).unwrap());
    out
}

/// Rebuild a store directory from a `store` fuzz input (as the target does).
fn unpack_store(tmp: &Path, data: &[u8]) -> PathBuf {
    let i = data
        .windows(SEP.len())
        .position(|w| w == SEP)
        .unwrap_or(data.len());
    let dir = tmp.join("s.tiles");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("manifest.json"), &data[..i]).unwrap();
    let tile = data.get(i + SEP.len()..).unwrap_or(&[]);
    std::fs::write(dir.join("t_0_0.bin"), tile).unwrap();
    dir
}

#[test]
fn store_seeds_are_valid_stores() {
    let tmp = tempfile::tempdir().unwrap();
    for (name, c) in [
        ("raw", Compression::None),
        ("zstd", Compression::Zstd { level: 3 }),
    ] {
        let seed = store_seed(tmp.path(), c);
        if std::env::var_os("OROGEN_WRITE_SEEDS").is_some() {
            let d = root().join("fuzz/corpus/store");
            std::fs::create_dir_all(&d).unwrap();
            std::fs::write(d.join(format!("seed_{name}")), &seed).unwrap();
        }
        let dir = unpack_store(tmp.path(), &seed);
        let src = open_raster(&dir, &OpenOptions::default()).unwrap();
        let g = read_window::<f64>(src.as_ref(), Window::new(0, 0, 12, 10)).unwrap();
        // Oracle: the generating formula.
        assert_eq!(g.get(7, 3), 703.0, "{name}");
        assert_eq!(g.get(11, 9), 1109.0, "{name}");
    }
}
