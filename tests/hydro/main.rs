//! Hydrology: fill, breach, D8/Rho8/D∞/MFD routing and accumulation, basins,
//! streams and indices, in memory against independent oracles and tiled
//! against in memory, and the hydrology commands of the CLI.

#[path = "../common/mod.rs"]
mod common;

/// The 8 neighbour offsets (dx, dy) in D8 code order E, SE, S, SW, W, NW, N,
/// NE (code `1 << k`): the oracles' own, independent of `orogen::raster`.
#[rustfmt::skip]
const NB: [(i64, i64); 8] = [(1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1)];

mod breach;
mod cli_breach;
mod cli_fill_nodata;
mod cli_fill_watersheds;
mod cli_sea_level;
mod cli_sinks;
mod divergent;
mod divergent_tiled;
mod fill_nodata;
mod fill_region_growing;
mod flow_graph;
mod geographic;
mod in_memory;
mod network;
mod tiled;
