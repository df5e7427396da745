//! Orometric synthesis (issue 10): profiles, divide-tree synthesis, terrain.

use orogen::io::{open_raster, OpenOptions};
use orogen::raster::{read_window, GeoRef, Grid, Window};
use orogen::synth::orometric::*;
use std::path::PathBuf;

fn shared(name: &str) -> Option<PathBuf> {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data")
        .join(name);
    if p.exists() {
        Some(p)
    } else {
        println!("note: {} absent, real-data check skipped", p.display());
        None
    }
}

fn load(name: &str) -> Option<(Grid<f32>, GeoRef)> {
    let p = shared(name)?;
    let src = open_raster(&p, &OpenOptions::default()).unwrap();
    let (w, h) = (src.info().width, src.info().height);
    let g = read_window::<f32>(&*src, Window::full(w, h)).unwrap();
    Some((g, src.info().georef.clone()))
}

#[test]
fn explore() {
    for (name, minp) in [
        ("terraindescriptors_alps_montblanc.tif", 30.0),
        ("pysheds_dem.tif", 5.0),
        ("bigtujunga_srtm30m_utm11.tif", 30.0),
        ("qgis_dem25.tif", 30.0),
    ] {
        let Some((g, geo)) = load(name) else { continue };
        let prof = SynthProfile::from_dem(&g, &geo, minp, name, name).unwrap();
        println!("{name}: density {} /km2, elev {:?}", prof.peak_density_per_km2, prof.elevation.edges);
        println!("  prom {:?}\n  p {:?}", prof.prominence.edges, prof.prominence.p);
        println!("  iso {:?}\n  p {:?}", prof.isolation_km.edges, prof.isolation_km.p);
        for stretch in [1.0, 1.5] {
            let t0 = std::time::Instant::now();
            let mut o = TreeOptions::new(800, 800, 60.0, 7);
            o.isolation_stretch = stretch;
            let tree = synthesize_tree(&prof, &o).unwrap();
            let t1 = t0.elapsed();
            let np = tree.prominences().iter().filter(|&&p| p >= prof.min_prominence).count();
            println!("  synth peaks with prominence >= threshold: {np}");
            let ter = OroTerrain::new(&tree, &TerrainOptions::default()).unwrap();
            let dem = ter.render();
            let t2 = t0.elapsed();
            let s = PeakSamples::of_dem(&dem, ter.georef(), prof.min_prominence).unwrap();
            println!("  stretch {stretch}: {} peaks synth, {} measured; tree {:?} total {:?}", tree.peaks.len(), s.elevation.len(), t1, t2);
            println!("  errors {:?}", prof.errors(&s));
        }
    }
}
