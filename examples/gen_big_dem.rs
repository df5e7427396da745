//! Seeded synthetic DEM of any size, written straight to a tile store in
//! bounded memory (tile by tile through the engine): fBm terrain
//! (`orogen::synth::Fbm`, domain-warped, ridged upper octaves), a sea at
//! elevation 0 (everything the fBm puts below 0: one large flat, as the
//! Baltic in the Poland mosaic), closed depressions (paraboloid bowls,
//! a few per 128x128 block, 2–40 m deep, 6–48 cells wide, placed by a
//! counter-based hash so any window is computed independently), and
//! elevations rounded to `quantum` metres (1 m like SRTM/Copernicus int16:
//! many small flats). Used by `tools/hydro_scale.sh`.
//!
//! `cargo run --release --example gen_big_dem -- WIDTH HEIGHT SEED OUT.tiles [quantum] [memory]`

use orogen::exec::EngineConfig;
use orogen::io::OutputOptions;
use orogen::raster::{AnyGrid, Grid, RasterInfo, RasterSource, Window};
use orogen::synth::{Fbm, FbmSource};
use std::path::PathBuf;

/// splitmix64 (Steele, Lea & Flood 2014): a counter-based hash, so each
/// block's pits depend only on (seed, block) and tiles are independent.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

fn unit(h: u64) -> f64 {
    (h >> 11) as f64 / (1u64 << 53) as f64
}

const BLOCK: i64 = 128;
const PITS_PER_BLOCK: u64 = 3;
const MAX_R: f64 = 24.0;

struct Pitted {
    fbm: Fbm,
    seed: u64,
    quantum: f64,
    info: RasterInfo,
}

impl Pitted {
    /// Pits of block (bx, by): (cx, cy, radius, depth).
    fn pits(&self, bx: i64, by: i64, out: &mut Vec<(f64, f64, f64, f64)>) {
        let b = mix(self.seed ^ mix((bx as u64) << 32 ^ (by as u64 & 0xFFFF_FFFF)));
        for p in 0..PITS_PER_BLOCK {
            let h = mix(b.wrapping_add(p));
            if unit(h) < 0.4 {
                continue;
            }
            let cx = (bx * BLOCK) as f64 + unit(mix(h ^ 1)) * BLOCK as f64;
            let cy = (by * BLOCK) as f64 + unit(mix(h ^ 2)) * BLOCK as f64;
            let r = 3.0 + unit(mix(h ^ 3)) * (MAX_R - 3.0);
            let d = 2.0 + unit(mix(h ^ 4)) * 38.0;
            out.push((cx, cy, r, d));
        }
    }
}

impl RasterSource for Pitted {
    fn info(&self) -> &RasterInfo {
        &self.info
    }
    fn read_native(&self, win: Window) -> orogen::Result<AnyGrid> {
        let mut pits = Vec::new();
        let (bx0, by0) = (
            (win.x - MAX_R as i64).div_euclid(BLOCK),
            (win.y - MAX_R as i64).div_euclid(BLOCK),
        );
        let bx1 = (win.x + win.w as i64 + MAX_R as i64).div_euclid(BLOCK);
        let by1 = (win.y + win.h as i64 + MAX_R as i64).div_euclid(BLOCK);
        for by in by0..=by1 {
            for bx in bx0..=bx1 {
                self.pits(bx, by, &mut pits);
            }
        }
        let (x0, y0) = (win.x as usize, win.y as usize);
        Ok(AnyGrid::F32(Grid::from_fn(win.w, win.h, |x, y| {
            let (gx, gy) = (x0 + x, y0 + y);
            let mut z = self.fbm.elevation(gx, gy) as f64;
            if z <= 0.0 {
                return 0.0;
            }
            for &(cx, cy, r, d) in &pits {
                let dx = gx as f64 + 0.5 - cx;
                let dy = gy as f64 + 0.5 - cy;
                let q = (dx * dx + dy * dy) / (r * r);
                if q < 1.0 {
                    z -= d * (1.0 - q);
                }
            }
            ((z / self.quantum).round() * self.quantum).max(self.quantum) as f32
        })))
    }
}

fn main() -> anyhow::Result<()> {
    let a: Vec<String> = std::env::args().collect();
    if a.len() < 5 {
        anyhow::bail!(
            "usage: gen_big_dem WIDTH HEIGHT SEED OUT.tiles [quantum=1] [memory_MiB=512]"
        );
    }
    let (w, h): (usize, usize) = (a[1].parse()?, a[2].parse()?);
    let seed: u64 = a[3].parse()?;
    let out = PathBuf::from(&a[4]);
    let quantum: f64 = a.get(5).map(|s| s.parse()).transpose()?.unwrap_or(1.0);
    let mem: u64 = a.get(6).map(|s| s.parse()).transpose()?.unwrap_or(512);
    if !(quantum.is_finite() && quantum > 0.0) {
        anyhow::bail!("quantum must be a positive number of metres");
    }
    let fbm = Fbm {
        seed,
        wavelength: 4096.0,
        base: 250.0,
        amplitude: 900.0,
        ..Fbm::default()
    };
    let base = FbmSource::new(fbm.clone(), w, h, 30.0)?;
    let mut info = base.info().clone();
    info.path = format!("<gen_big_dem seed {seed}>").into();
    let src = Pitted {
        fbm,
        seed,
        quantum,
        info,
    };
    let mut oo = OutputOptions::default();
    oo.store.overwrite = true;
    oo.store.sync = false;
    let cfg = EngineConfig {
        threads: 0,
        memory_budget: mem << 20,
        progress: false,
        observer: None,
        engine: Default::default(),
    };
    orogen::ops::convert(&src, &out, &oo, Some(1024), &cfg)?;
    println!("wrote {} ({w} x {h}, seed {seed})", out.display());
    Ok(())
}
