//! Inputs of the hydrology tests: random DEMs for proptest and the raw f32
//! DEMs of `tests/data/hydro`.

use orogen::raster::Grid;
use proptest::prelude::*;
use std::path::Path;

/// Random DEMs of 1..`max` x 1..`max` cells: mostly small integers (many
/// ties and flats), some reals, some nodata.
pub fn dem(max: usize) -> impl Strategy<Value = Grid<f32>> {
    (1usize..max, 1usize..max).prop_flat_map(|(w, h)| {
        let cell = prop_oneof![
            12 => (-4i32..7).prop_map(|v| v as f32),
            3 => -400.0f32..900.0,
            2 => Just(f32::NAN),
        ];
        proptest::collection::vec(cell, w * h)
            .prop_map(move |v| Grid::from_vec(w, h, v).expect("sized"))
    })
}

/// Read a raw little-endian f32 file of `tests/data/hydro` (written by
/// `gdal_translate -of ENVI -ot Float32`, see SOURCES.md there); `nodata`
/// becomes NaN.
pub fn read_raw(name: &str, w: usize, h: usize, nodata: f32) -> Grid<f32> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/hydro")
        .join(name);
    let bytes = std::fs::read(&p).expect("test data present");
    assert_eq!(bytes.len(), w * h * 4);
    let v = bytes
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .map(|z| if z == nodata { f32::NAN } else { z })
        .collect();
    Grid::from_vec(w, h, v).unwrap()
}
