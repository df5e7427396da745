//! Hydrology: fill, breach, D8/Rho8/D∞/MFD routing and accumulation, basins,
//! streams and indices, in memory against independent oracles and tiled
//! against in memory, and the hydrology commands of the CLI.

#[path = "../common/mod.rs"]
mod common;

mod breach;
mod cli_breach;
mod cli_fill_watersheds;
mod divergent;
mod divergent_tiled;
mod fill_region_growing;
mod flow_graph;
mod in_memory;
mod network;
mod tiled;
