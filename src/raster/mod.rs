//! Raster core: cell types, grids, windows, georeferencing, tile layouts and
//! the `RasterSource` abstraction every reader and the tile store implement.

mod adjacency;
mod dtype;
mod georef;
mod grid;
pub mod neighbours;
pub mod proj;
mod source;
mod tiling;
mod union_find;
mod window;

pub use adjacency::Adjacency;
pub use dtype::{Cell, DType, OutputKind};
pub use georef::{Crs, GeoKeys, GeoRef, RasterType};
pub use grid::{AnyGrid, Grid, IntoAny};
pub use source::{
    read_view, read_window, read_window_native, MemRaster, RasterInfo, RasterSource, Scaling,
    SliceRaster,
};
pub use tiling::{
    cross_tile_pairs, perimeter_cells, perimeter_index, perimeter_len, TileId, TileLayout, TileView,
};
pub use union_find::{SetIndex, UnionFind};
pub use window::Window;
