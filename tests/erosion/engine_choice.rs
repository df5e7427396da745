//! The engine a config names is the engine an erosion run uses: a config
//! naming MPI in a process where MPI does not run is refused with a clear
//! error, never run in-process as if the config had said `local`; the same
//! options with `local` run. (The choice used to be read from a process-wide
//! flag, which ignored the value.)

use orogen::exec::{EngineConfig, EngineKind};
use orogen::io::{OpenOptions, OutputOptions};
use orogen::ops::erode::{run, ErodeOptions, Model};
use std::path::Path;

fn options(model: Model, tiled: bool, input: &Path, output: &Path) -> ErodeOptions {
    ErodeOptions {
        input: input.to_path_buf(),
        model,
        steps: Some(2),
        tiled,
        tile: Some(13),
        output: output.to_path_buf(),
        ..Default::default()
    }
}

fn erode(opts: &ErodeOptions, engine: EngineKind) -> orogen::Result<()> {
    let cfg = EngineConfig {
        engine,
        threads: 1,
        ..Default::default()
    };
    run(
        opts,
        &OpenOptions::default(),
        &OutputOptions::default(),
        &cfg,
        &mut |_| {},
    )
}

#[test]
fn a_config_naming_mpi_is_not_run_in_process() {
    let dir = tempfile::tempdir().unwrap();
    let input = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/bigtujunga_crop.tif");
    for (model, tiled) in [(Model::StreamPower, true), (Model::Thermal, false)] {
        let out = dir.path().join(format!("{model:?}.tif"));
        let opts = options(model, tiled, &input, &out);
        let err = erode(&opts, EngineKind::Mpi)
            .expect_err("an MPI config must not run in a process without MPI")
            .to_string();
        assert!(err.contains("MPI"), "{model:?}: the error names MPI: {err}");
        assert!(
            !out.exists(),
            "{model:?}: nothing written on the refused run"
        );
        erode(&opts, EngineKind::Local).unwrap();
        assert!(out.exists(), "{model:?}: the local run writes its output");
    }
}
