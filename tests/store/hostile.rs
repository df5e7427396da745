//! Corrupt, hostile and unfinished stores give typed errors naming the file.

use crate::common::u16_store;
use orogen::raster::{MemRaster, RasterSource, Window};
use orogen::store::{Compression, TileStore};
use orogen::Error;
use std::path::{Path, PathBuf};

fn make(tmp: &Path, name: &str, compression: Compression) -> (PathBuf, MemRaster) {
    let dir = tmp.join(name);
    let src = u16_store(&dir, 40, 30, compression);
    (dir, src)
}

fn edit_manifest(dir: &Path, f: impl FnOnce(&mut serde_json::Value)) {
    let p = dir.join("manifest.json");
    let mut v: serde_json::Value = serde_json::from_slice(&std::fs::read(&p).unwrap()).unwrap();
    f(&mut v);
    std::fs::write(&p, serde_json::to_vec(&v).unwrap()).unwrap();
}

fn open_err(dir: &Path) -> Error {
    TileStore::open(dir).unwrap_err()
}

#[test]
fn missing_and_garbled_manifests() {
    let tmp = tempfile::tempdir().unwrap();
    let e = open_err(&tmp.path().join("nope.tiles"));
    assert!(
        matches!(e, Error::Store { .. }) && e.to_string().contains("nope.tiles"),
        "{e}"
    );
    let (dir, _) = make(tmp.path(), "a.tiles", Compression::None);
    std::fs::write(dir.join("manifest.json"), b"{\"format\": \"orogen-tile-st").unwrap();
    let e = open_err(&dir);
    assert!(
        matches!(e, Error::Corrupt { .. }) && e.to_string().contains("manifest.json"),
        "{e}"
    );
    std::fs::remove_file(dir.join("manifest.json")).unwrap();
    let e = open_err(&dir);
    assert!(e.to_string().contains("no manifest"), "{e}");
}

#[test]
fn absurd_or_inconsistent_manifest_values() {
    let tmp = tempfile::tempdir().unwrap();
    type Edit = Box<dyn Fn(&mut serde_json::Value)>;
    let cases: Vec<(&str, Edit, &str)> = vec![
        (
            "w",
            Box::new(|v| v["width"] = serde_json::json!(1u64 << 50)),
            "exceeds the limit",
        ),
        (
            "h0",
            Box::new(|v| v["height"] = serde_json::json!(0)),
            "empty raster",
        ),
        (
            "t",
            Box::new(|v| v["tile"] = serde_json::json!(0)),
            "tile size 0",
        ),
        (
            "n",
            Box::new(|v| v["tiles"].as_array_mut().unwrap().truncate(2)),
            "lists 2 tiles",
        ),
        (
            "f",
            Box::new(|v| v["format"] = serde_json::json!("zip")),
            "not an orogen tile-store",
        ),
        (
            "v",
            Box::new(|v| v["version"] = serde_json::json!(99)),
            "version 99",
        ),
        (
            "b",
            Box::new(|v| v["tiles"][0]["bytes"] = serde_json::json!(7)),
            "tile 0 is recorded as 7 bytes",
        ),
        (
            "d",
            Box::new(|v| v["dtype"] = serde_json::json!("u128")),
            "garbled",
        ),
        (
            "c",
            Box::new(|v| v["complete"] = serde_json::json!(false)),
            "rerun the command",
        ),
        (
            "nd",
            Box::new(|v| v["nodata"] = serde_json::json!(5.0)),
            "nodata",
        ),
    ];
    for (name, f, needle) in cases {
        let (dir, _) = make(tmp.path(), &format!("case-{name}.tiles"), Compression::None);
        edit_manifest(&dir, f);
        let e = open_err(&dir);
        let msg = e.to_string();
        assert!(msg.contains(needle), "{name}: {msg}");
        assert!(
            msg.contains(&format!("case-{name}.tiles")),
            "{name}: error does not name the store: {msg}"
        );
    }
}

#[test]
fn damaged_tiles_are_detected_when_read() {
    let tmp = tempfile::tempdir().unwrap();
    let (dir, src) = make(tmp.path(), "d.tiles", Compression::None);
    // Wrong size.
    let t = dir.join("t_1_2.bin");
    let good = std::fs::read(&t).unwrap();
    std::fs::write(&t, &good[..good.len() - 2]).unwrap();
    let st = TileStore::open(&dir).unwrap();
    let e = st.read_native(Window::full(40, 30)).unwrap_err();
    assert!(
        matches!(e, Error::Corrupt { .. }) && e.to_string().contains("t_1_2.bin"),
        "{e}"
    );
    // A tile the window does not touch is not read.
    assert_eq!(
        st.read_native(Window::new(0, 0, 16, 16)).unwrap(),
        src.grid().crop(Window::new(0, 0, 16, 16))
    );
    // Same size, flipped byte: checksum mismatch; with verification off the bytes come back as stored.
    let mut bad = good.clone();
    bad[10] ^= 1;
    std::fs::write(&t, &bad).unwrap();
    let e = st.read_native(Window::new(35, 20, 2, 2)).unwrap_err();
    assert!(
        e.to_string().contains("checksum mismatch") && e.to_string().contains("t_1_2.bin"),
        "{e}"
    );
    let mut st = TileStore::open(&dir).unwrap();
    st.set_verify(false);
    let g = st.read_native(Window::new(32, 16, 8, 14)).unwrap();
    assert_eq!(g.as_le_bytes(), &bad[..]);
    // Missing tile file.
    std::fs::remove_file(&t).unwrap();
    let e = st.read_native(Window::new(32, 16, 8, 14)).unwrap_err();
    assert!(
        matches!(e, Error::Io { .. }) && e.to_string().contains("t_1_2.bin"),
        "{e}"
    );
}

#[test]
fn damaged_zstd_tiles_are_detected() {
    let tmp = tempfile::tempdir().unwrap();
    let (dir, src) = make(tmp.path(), "z.tiles", Compression::Zstd { level: 3 });
    let st = TileStore::open(&dir).unwrap();
    assert_eq!(st.read_native(Window::full(40, 30)).unwrap(), *src.grid());
    let t = dir.join("t_0_0.bin");
    let n = std::fs::metadata(&t).unwrap().len() as usize;
    std::fs::write(&t, vec![0x55u8; n]).unwrap();
    // A handle keeps recently decoded tiles (the store is immutable once
    // finished), so the damage is seen by a new handle.
    let st = TileStore::open(&dir).unwrap();
    let e = st.read_native(Window::new(0, 0, 1, 1)).unwrap_err();
    assert!(
        matches!(e, Error::Corrupt { .. }) && e.to_string().contains("t_0_0.bin"),
        "{e}"
    );
}
