//! Subcommands that live in their own files. Each file holds a clap `Args`
//! struct per command and a `run` function; `main.rs` adds one `Cmd` variant
//! (`Name(cli::file::NameArgs)`) and one match arm per command. Shared helpers
//! (`In`, `Out`, `OutFmt`, `Run`, `engine`, `open`, `output_options`,
//! `local1`, `global1`, `wrote`) are reachable as `crate::...`.

pub mod breach;
pub mod compare;
pub mod erode;
pub mod erode_sp;
pub mod fill_epsilon;
pub mod hydro_net;
pub mod job;
pub mod metric_table;
pub mod oro;
pub mod synth;
pub mod synth_noise;
pub mod synth_optimise;
pub mod synth_oro;
pub mod synth_rivers;
pub mod synth_tectonic;
pub mod tiles;
pub mod view;
pub mod viewshed;
pub mod watersheds;
