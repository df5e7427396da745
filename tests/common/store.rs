//! A small tile store for the tests of its writer's lock, leftovers and
//! layout checks.

use orogen::raster::{DType, GeoRef};
use orogen::store::{Provenance, StoreOptions, StoreWriter};
use std::path::Path;

/// `StoreWriter::create` of a 10 x 10 u8 store without georeferencing at
/// `dir`, with `opts`.
pub fn small_writer(dir: &Path, opts: StoreOptions) -> orogen::Result<StoreWriter> {
    StoreWriter::create(
        dir,
        10,
        10,
        DType::U8,
        &GeoRef::pixel(),
        opts,
        Provenance::default(),
    )
}
