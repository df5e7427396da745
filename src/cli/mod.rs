//! Subcommands that live in their own files. Each file holds a clap `Args`
//! struct per command and a `run` function; `main.rs` adds one `Cmd` variant
//! (`Name(cli::file::NameArgs)`) and one match arm per command. Each `run`
//! converts its arguments into the library's options, calls `orogen::ops`
//! and prints what was written. Shared arguments and helpers (`In`, `Out`,
//! `OutFmt`, `Run`, `engine`, `open`, `output_options`, `target`, `wrote`)
//! live in `args.rs` and are reachable as `crate::...`.

pub mod accumulate;
pub mod args;
pub mod breach;
pub mod compare;
pub mod convert;
pub mod demo;
pub mod erode;
pub mod erode_sp;
pub mod fill;
pub mod fill_epsilon;
pub mod fill_nodata;
pub mod flow;
pub mod hydro_net;
pub mod info;
pub mod job;
pub mod metric;
pub mod metric_table;
pub mod oro;
pub mod peaks;
pub mod render;
pub mod synth;
pub mod synth_noise;
pub mod synth_optimise;
pub mod synth_oro;
pub mod synth_rivers;
pub mod synth_tectonic;
pub mod terrain;
pub mod tiles;
pub mod view;
pub mod viewshed;
pub mod watersheds;
