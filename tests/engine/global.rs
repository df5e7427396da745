//! Global steps through `LocalEngine`: the `Stats` step against brute force,
//! a map/reduce/apply step against the whole-grid computation, summary
//! round trips, and errors.

use orogen::exec::output::OutputSpec;
use orogen::exec::stats::{Stats, StatsSummary};
use orogen::exec::{roundtrip_summary, Engine, GlobalStep, MemSink, Run};
use orogen::raster::{DType, GeoRef, Grid, MemRaster, RasterSource, TileId, TileLayout, TileView};
use orogen::{Error, Result};

use crate::common::engine::{engine, tile_min};
use crate::common::Rng;

fn grid(w: usize, h: usize, seed: u64) -> Vec<f64> {
    let mut rng = Rng(seed);
    (0..w * h)
        .map(|_| {
            let z = rng.next();
            match z % 50 {
                0 => f64::NAN,
                1 => -120.0,                  // below the histogram range
                2 => 250.0,                   // above it
                _ => ((z >> 8) % 101) as f64, // 0..=100, integers: exact sums
            }
        })
        .collect()
}

#[test]
fn stats_tiled_equal_brute_force() {
    let (w, h) = (123, 77);
    let data = grid(w, h, 42);
    let src = MemRaster::from_grid(Grid::from_vec(w, h, data.clone()).unwrap(), GeoRef::pixel());
    // Brute force with explicit bin edges 0, 10, ..., 100 (last bin closed).
    let mut hist = vec![0u64; 10];
    let (mut below, mut above, mut nodata, mut count) = (0, 0, 0, 0);
    let (mut min, mut max, mut sum) = (f64::MAX, f64::MIN, 0.0);
    for &v in &data {
        if v.is_nan() {
            nodata += 1;
            continue;
        }
        count += 1;
        sum += v;
        min = min.min(v);
        max = max.max(v);
        if v < 0.0 {
            below += 1;
        } else if v > 100.0 {
            above += 1;
        } else {
            let mut b = 9;
            for i in 0..10 {
                if v >= (i * 10) as f64 && v < ((i + 1) * 10) as f64 {
                    b = i;
                    break;
                }
            }
            hist[b] += 1;
        }
    }
    let step = Stats::new(0.0, 100.0, 10).unwrap();
    for tile in [1, 7, 64, 1024] {
        for threads in [1, 2] {
            let s: StatsSummary = engine(threads)
                .run_global(
                    &step,
                    Run::new(
                        &[&src as &dyn RasterSource],
                        TileLayout::new(w, h, tile),
                        vec![],
                    ),
                )
                .unwrap();
            assert_eq!(s.hist, hist, "tile {tile}");
            assert_eq!(
                (s.below, s.above, s.nodata, s.count),
                (below, above, nodata, count)
            );
            assert_eq!((s.min, s.max), (Some(min), Some(max)));
            assert_eq!(s.sum, sum);
            assert_eq!(s.mean(), Some(sum / count as f64));
        }
    }
}

/// Subtract the global minimum (needs every tile's minimum: map = tile min,
/// reduce = min of mins, apply = v - min).
struct MinusMin;
impl GlobalStep for MinusMin {
    type In = f32;
    type Out = f32;
    type Summary = Option<f32>;
    type Solution = f32;
    type Slice = f32;
    fn name(&self) -> String {
        "minus-min".into()
    }
    fn params(&self) -> serde_json::Value {
        serde_json::Value::Null
    }
    fn outputs(&self) -> Vec<OutputSpec> {
        vec![OutputSpec::continuous(DType::F32, 0.0)]
    }
    fn map(&self, inputs: &[TileView<f32>]) -> Result<Option<f32>> {
        Ok(tile_min(inputs))
    }
    fn reduce(&self, layout: &TileLayout, summaries: Vec<Option<f32>>) -> Result<f32> {
        assert_eq!(summaries.len(), layout.count());
        summaries
            .into_iter()
            .flatten()
            .reduce(f32::min)
            .ok_or_else(|| Error::invalid("all nodata"))
    }
    fn slice(&self, solution: &f32, _id: TileId) -> f32 {
        *solution
    }
    fn apply(&self, inputs: &[TileView<f32>], slice: &f32, out: &mut [Grid<f32>]) -> Result<()> {
        out[0] = inputs[0].grid.map(|v| v - slice);
        Ok(())
    }
}

#[test]
fn map_reduce_apply_equals_whole_grid() {
    let (w, h) = (90, 61);
    let data: Vec<f32> = grid(w, h, 9).iter().map(|&v| v as f32).collect();
    let src = MemRaster::from_grid(Grid::from_vec(w, h, data.clone()).unwrap(), GeoRef::pixel());
    let min = data
        .iter()
        .copied()
        .filter(|v| !v.is_nan())
        .fold(f32::INFINITY, f32::min);
    let want: Vec<u8> = data.iter().flat_map(|v| (v - min).to_le_bytes()).collect();
    for tile in [1, 7, 64] {
        for threads in [1, 2] {
            let (sink, handle) = MemSink::new(w, h, DType::F32, None);
            let m = engine(threads)
                .run_global(
                    &MinusMin,
                    Run::new(
                        &[&src as &dyn RasterSource],
                        TileLayout::new(w, h, tile),
                        vec![Box::new(sink)],
                    ),
                )
                .unwrap();
            assert_eq!(m, min);
            assert!(
                handle.take().unwrap().as_le_bytes() == &want[..],
                "tile {tile}"
            );
        }
    }
}

#[test]
fn summaries_survive_serde_and_non_serialisable_ones_are_reported() {
    let s = StatsSummary {
        count: 3,
        nodata: 1,
        min: Some(-2.5),
        max: Some(7.0),
        sum: 1.25,
        below: 0,
        above: 2,
        hist: vec![1, 0, 2],
    };
    assert_eq!(roundtrip_summary("stats", &s).unwrap(), s);
    let e = roundtrip_summary("bad", &f64::NAN).unwrap_err();
    assert!(
        e.to_string().contains("bad") && e.to_string().contains("round trip"),
        "{e}"
    );
}

#[test]
fn stats_rejects_bad_parameters() {
    assert!(Stats::new(1.0, 1.0, 10).is_err());
    assert!(Stats::new(0.0, f64::NAN, 10).is_err());
    assert!(Stats::new(0.0, 1.0, 0).is_err());
}
