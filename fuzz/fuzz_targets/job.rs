#![no_main]
//! Fuzz target: read, plan and check a job file (`job::prepare`: the TOML
//! schema, dependency order and every step's typed options against the
//! library's command registry). Nothing runs and nothing is written.
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    fuzz_common::serial_rayon();
    let p = fuzz_common::file("job.toml", data);
    let _ = orogen::ops::job::prepare(&p, &orogen::ops::job::JobOptions::default());
});
