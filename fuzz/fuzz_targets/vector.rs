#![no_main]
//! Fuzz target: read a GeoJSON vector map (`synth::vector::VectorMap`) and
//! exercise its geometry (bbox, ring self-intersection, masks).
use libfuzzer_sys::fuzz_target;
use orogen::synth::vector::{ring_self_intersection, RingMask, VectorMap};

fuzz_target!(|data: &[u8]| {
    fuzz_common::serial_rayon();
    let p = fuzz_common::file("map.geojson", data);
    if let Ok(m) = VectorMap::read(&p) {
        let _ = m.bbox();
        for r in m.coasts.iter().take(4) {
            if r.len() <= 2000 {
                let _ = ring_self_intersection(r);
            }
        }
        if !m.coasts.is_empty() {
            let mask = RingMask::new(&m.coasts, 16);
            let _ = mask.at(0.5, 0.5);
        }
    }
});
