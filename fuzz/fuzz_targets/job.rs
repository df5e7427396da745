#![no_main]
//! Fuzz target: parse and plan a job file (`job::load`) against a small
//! fixed command table.
use libfuzzer_sys::fuzz_target;
use orogen::ops::job::CommandTable;

struct Table;

impl CommandTable for Table {
    fn has(&self, name: &str) -> bool {
        matches!(name, "fill" | "slope" | "convert" | "synth" | "prominence")
    }
    fn names(&self) -> Vec<String> {
        ["fill", "slope", "convert", "synth", "prominence"]
            .iter()
            .map(|s| s.to_string())
            .collect()
    }
    fn accepts(&self, _command: &str, opt: &str) -> bool {
        matches!(opt, "epsilon" | "units" | "size" | "seed" | "method")
    }
    fn methods(&self, command: &str) -> Vec<String> {
        if command == "synth" {
            vec!["noise".into(), "tectonic".into()]
        } else {
            vec![]
        }
    }
}

fuzz_target!(|data: &[u8]| {
    fuzz_common::serial_rayon();
    let p = fuzz_common::file("job.toml", data);
    let _ = orogen::ops::job::load(&p, &Table, None, None);
});
