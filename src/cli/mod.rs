//! Subcommands that live in their own files. Each file holds a clap `Args`
//! struct per command and a `run` function; `main.rs` adds one `Cmd` variant
//! (`Name(cli::file::NameArgs)`) and one match arm per command. Shared helpers
//! (`In`, `Out`, `OutFmt`, `Run`, `engine`, `open`, `output_options`,
//! `local1`, `global1`, `wrote`) are reachable as `crate::...`.

pub mod job;
pub mod tiles;
pub mod view;
pub mod hydro_net;
pub mod breach;
pub mod viewshed;
pub mod oro;
pub mod metric_table;
pub mod fill_epsilon;
pub mod watersheds;
