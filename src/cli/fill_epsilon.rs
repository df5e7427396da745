//! `orogen fill-epsilon`: depression filling with a strictly draining
//! epsilon surface, exact across tiles (two global passes: `TiledFill` into
//! a temporary tile store next to the output, then `TiledEpsilon`).

use crate::{engine, open, output_options, wrote, In, Out, Run};
use anyhow::{Context, Result};
use clap::Args;
use orogen::raster::DType;

/// Arguments of `orogen fill-epsilon`.
#[derive(Args)]
pub struct FillEpsilonArgs {
    #[command(flatten)]
    pub input: In,
    #[command(flatten)]
    pub out: Out,
    #[command(flatten)]
    pub run: Run,
}

/// Fill, then raise every flat cell by k ULPs (k = its distance to the
/// flat's exit); the temporary filled store is removed afterwards.
pub fn run(a: FillEpsilonArgs) -> Result<()> {
    let src = open(&a.input)?;
    let cfg = engine(&a.run)?;
    let oo = output_options(&a.out.fmt)?;
    let mut name = a.out.output.file_name().unwrap_or_default().to_os_string();
    name.push(".fill-tmp.tiles");
    let tmp = a.out.output.with_file_name(name);
    let mut too = orogen::io::OutputOptions::default();
    too.store.overwrite = true;
    too.store.sync = false;
    too.store.tile = orogen::ops::choose_tile(src.as_ref(), a.run.tile);
    let ty = (
        DType::F32,
        Some(orogen::hydro::out_nodata::elevation_nodata(src.as_ref())?),
    );
    let result = (|| -> Result<()> {
        orogen::ops::run_global_to(
            &orogen::hydro::tiled::TiledFill,
            &[src.as_ref()],
            &tmp,
            ty,
            &too,
            a.run.tile,
            &cfg,
        )?;
        let filled = orogen::io::open_raster(&tmp, &orogen::io::OpenOptions::default())?;
        orogen::ops::run_global_to(
            &orogen::hydro::tiled::TiledEpsilon,
            &[filled.as_ref()],
            &a.out.output,
            ty,
            &oo,
            a.run.tile,
            &cfg,
        )?;
        Ok(())
    })();
    // Under MPI only rank 0 created the store; the others removing it too would race.
    if orogen::exec::rank().0 == 0 && tmp.exists() {
        std::fs::remove_dir_all(&tmp)
            .with_context(|| format!("removing the temporary store {}", tmp.display()))?;
    }
    result?;
    wrote(&a.out.output);
    Ok(())
}
