#![no_main]
//! Fuzz target: divide-tree files. Input starting with `S`: the rest is a
//! synthetic tree as `orogen synth divide-tree` writes and `synth from-tree`
//! reads (`SynthTree::load`, then prominences and GeoJSON); otherwise a
//! divide tree as `orogen peaks` writes (`divide_tree.json`,
//! `DivideTree::load_json`, then pruning and a JSON round trip that must
//! give the same tree).
use libfuzzer_sys::fuzz_target;
use orogen::oro::DivideTree;
use orogen::synth::orometric::tree_synth::SynthTree;

fuzz_target!(|data: &[u8]| {
    fuzz_common::serial_rayon();
    if let Some(rest) = data.strip_prefix(b"S") {
        let p = fuzz_common::file("tree.json", rest);
        if let Ok(t) = SynthTree::load(&p) {
            let prom = t.prominences();
            assert_eq!(prom.len(), t.peaks.len());
            let _ = t.edges();
            let _ = t.to_geojson();
        }
    } else {
        let p = fuzz_common::file("divide_tree.json", data);
        if let Ok(t) = DivideTree::load_json(&p) {
            let _ = t.pruned(10.0);
            let back = DivideTree::from_json(&t.to_json())
                .expect("a loaded tree serialises and loads back");
            assert_eq!(back, t, "JSON round trip changed the tree");
        }
    }
});
