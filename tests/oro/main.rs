//! Orometry: the divide tree (hand-checked cases, brute-force prominence and
//! isolation, a reference peak list, tiled == in memory) and orometric
//! analysis, in the library and the CLI.

#[path = "../common/mod.rs"]
mod common;

mod analysis;
mod below_sea_level;
mod brute_force;
mod cli_analysis;
mod hand_checked;
mod reference;
mod tiled;
