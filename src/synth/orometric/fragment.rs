//! Pasting a fragment of a real divide tree (Argudo, Galin, Peytavie,
//! Paris, Gain & Guérin 2019, "Orometry-based terrain analysis and
//! synthesis", ACM TOG 38(6), §7: a part of a real range is kept and the
//! surroundings are synthesised around it).
//!
//! The fragment comes from the `peaks.csv` that `orogen peaks` writes for a
//! real DEM: the peaks whose cell lies in a window of that DEM, each with
//! its elevation, and the ridges (peak → key saddle → parent) whose two
//! peaks and saddle lie in the window, with the saddle's elevation. They are
//! kept verbatim, in the DEM's cell layout (the synthesis should use the
//! DEM's cell size), shifted to where the user pastes the window; the
//! synthesis fixes them, keeps its own peaks out of the window and joins the
//! fragment's parts and the rest by its minimum spanning tree.

use super::tree_synth::{FixedRidge, SynthPeak};
use crate::error::{Error, Result};
use crate::raster::Window;
use std::path::Path;

/// Largest peaks.csv read.
const MAX_CSV_BYTES: u64 = 512 << 20;

/// Peaks and ridges of a window of a real divide tree, in metres from the
/// window's top-left corner (x east, y down).
#[derive(Debug, Clone, PartialEq)]
pub struct Fragment {
    pub peaks: Vec<SynthPeak>,
    /// Ridges between `peaks` (indices into it) with their saddles.
    pub ridges: Vec<FixedRidge>,
    /// Window size, m.
    pub width_m: f64,
    pub height_m: f64,
}

fn col_index(header: &[&str], names: &[&str], path: &Path) -> Result<usize> {
    header
        .iter()
        .position(|h| names.contains(&h.trim()))
        .ok_or_else(|| {
            Error::corrupt(
                path,
                format!(
                    "no column {} : expected the peaks.csv written by `orogen peaks`",
                    names.join(" or ")
                ),
            )
        })
}

impl Fragment {
    /// Read the peaks of `orogen peaks`'s peaks.csv whose cell lies in
    /// `window` (cells of the source DEM), with `cell` metres per cell.
    /// Saddle cells are recovered from the saddle coordinates by the
    /// north-up affine relation of the peaks' coordinates and cells (fitted
    /// on the peaks of extreme column and row); a rotated source is refused.
    pub fn from_peaks_csv(path: &Path, window: Window, cell: f64) -> Result<Fragment> {
        if !(cell.is_finite() && cell > 0.0) {
            return Err(Error::invalid("fragment: the cell size must be > 0 m"));
        }
        if window.w == 0 || window.h == 0 || window.w > 1 << 20 || window.h > 1 << 20 {
            return Err(Error::invalid(
                "fragment: the window must be 1..1048576 cells on each side",
            ));
        }
        let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
        if meta.len() > MAX_CSV_BYTES {
            return Err(Error::too_large(path, "a peaks.csv over 512 MiB"));
        }
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let mut lines = text.lines();
        let header: Vec<&str> = lines
            .next()
            .ok_or_else(|| Error::corrupt(path, "empty file; expected a peaks.csv"))?
            .split(',')
            .collect();
        let ix = col_index(&header, &["x", "lon"], path)?;
        let iy = col_index(&header, &["y", "lat"], path)?;
        let ie = col_index(&header, &["elevation"], path)?;
        let isx = col_index(&header, &["saddle_x", "saddle_lon"], path)?;
        let isy = col_index(&header, &["saddle_y", "saddle_lat"], path)?;
        let ise = col_index(&header, &["saddle_elevation"], path)?;
        let ic = col_index(&header, &["col"], path)?;
        let ir = col_index(&header, &["row"], path)?;
        let ip = col_index(&header, &["parent"], path)?;
        struct Row {
            x: f64,
            y: f64,
            z: f64,
            sx: Option<f64>,
            sy: Option<f64>,
            sz: Option<f64>,
            col: i64,
            row: i64,
            parent: Option<usize>,
        }
        let mut rows = Vec::new();
        for (ln, line) in lines.enumerate() {
            if line.trim().is_empty() {
                continue;
            }
            let f: Vec<&str> = line.split(',').collect();
            let bad = || Error::corrupt(path, format!("line {}: malformed peak row", ln + 2));
            let num = |i: usize| -> Result<Option<f64>> {
                let s = f.get(i).ok_or_else(bad)?.trim();
                if s.is_empty() {
                    return Ok(None);
                }
                s.parse::<f64>().map(Some).map_err(|_| bad())
            };
            let req =
                |i: usize| -> Result<f64> { num(i)?.filter(|v| v.is_finite()).ok_or_else(bad) };
            let parent = match num(ip)? {
                Some(v) if v >= 0.0 && v.fract() == 0.0 => Some(v as usize),
                Some(_) => return Err(bad()),
                None => None,
            };
            rows.push(Row {
                x: req(ix)?,
                y: req(iy)?,
                z: req(ie)?,
                sx: num(isx)?,
                sy: num(isy)?,
                sz: num(ise)?,
                col: req(ic)? as i64,
                row: req(ir)? as i64,
                parent,
            });
        }
        if rows.is_empty() {
            return Err(Error::corrupt(path, "no peak rows"));
        }
        // North-up affine fit: x = ax + bx (col + ½), y = ay + by (row + ½).
        let fit = |key: &dyn Fn(&Row) -> (i64, f64)| -> Option<(f64, f64)> {
            let lo = rows.iter().min_by_key(|r| key(r).0)?;
            let hi = rows.iter().max_by_key(|r| key(r).0)?;
            let ((c0, v0), (c1, v1)) = (key(lo), key(hi));
            if c1 == c0 {
                return None;
            }
            let b = (v1 - v0) / (c1 - c0) as f64;
            Some((v0 - b * (c0 as f64 + 0.5), b))
        };
        let (ax, bx) = fit(&|r: &Row| (r.col, r.x)).ok_or_else(|| {
            Error::corrupt(
                path,
                "all peaks share one column: cannot locate the saddles",
            )
        })?;
        let (ay, by) = fit(&|r: &Row| (r.row, r.y)).ok_or_else(|| {
            Error::corrupt(path, "all peaks share one row: cannot locate the saddles")
        })?;
        // A rotated or irregular grid: the fit does not reproduce the peaks.
        for r in &rows {
            let (ex, ey) = (
                ax + bx * (r.col as f64 + 0.5),
                ay + by * (r.row as f64 + 0.5),
            );
            if (ex - r.x).abs() > 0.01 * bx.abs() || (ey - r.y).abs() > 0.01 * by.abs() {
                return Err(Error::unsupported(
                    path,
                    "the peaks' coordinates are not a north-up grid of their cells (rotated DEM?)",
                ));
            }
        }
        let (c0, r0) = (window.x, window.y);
        let (c1, r1) = (c0 + window.w as i64, r0 + window.h as i64);
        let in_win = |c: i64, r: i64| c >= c0 && c < c1 && r >= r0 && r < r1;
        let at = |c: i64| ((c - c0) as f64 + 0.5) * cell;
        let aty = |r: i64| ((r - r0) as f64 + 0.5) * cell;
        let mut idx = vec![usize::MAX; rows.len()];
        let mut peaks = Vec::new();
        for (i, r) in rows.iter().enumerate() {
            if in_win(r.col, r.row) {
                if r.z <= 0.0 {
                    return Err(Error::invalid(format!(
                        "fragment peak at cell ({}, {}) is at {} m; the synthesis needs peaks above 0 m",
                        r.col, r.row, r.z
                    )));
                }
                idx[i] = peaks.len();
                peaks.push(SynthPeak {
                    x: at(r.col),
                    y: aty(r.row),
                    elevation: r.z,
                    fixed: true,
                });
            }
        }
        if peaks.is_empty() {
            return Err(Error::invalid(format!(
                "no peak of {} lies in the window {}x{} at ({}, {})",
                path.display(),
                window.w,
                window.h,
                c0,
                r0
            )));
        }
        let mut ridges = Vec::new();
        for (i, r) in rows.iter().enumerate() {
            let (Some(p), Some(sx), Some(sy), Some(sz)) = (r.parent, r.sx, r.sy, r.sz) else {
                continue;
            };
            if idx[i] == usize::MAX || p >= rows.len() || idx[p] == usize::MAX {
                continue;
            }
            let sc = ((sx - ax) / bx - 0.5).round() as i64;
            let sr = ((sy - ay) / by - 0.5).round() as i64;
            let lo = r.z.min(rows[p].z);
            if !(in_win(sc, sr) && sz.is_finite() && sz >= 0.0 && sz < lo) {
                continue;
            }
            ridges.push(FixedRidge {
                peaks: [idx[i], idx[p]],
                x: at(sc),
                y: aty(sr),
                elevation: sz,
            });
        }
        Ok(Fragment {
            peaks,
            ridges,
            width_m: window.w as f64 * cell,
            height_m: window.h as f64 * cell,
        })
    }

    /// The fragment shifted so that its window's top-left corner lies at
    /// (x, y) m of the synthesis domain: fixed peaks, kept ridges (peak
    /// indices offset by `first_peak`, the number of fixed peaks before
    /// them) and the keep-out rectangle of its footprint.
    pub fn placed(
        &self,
        x: f64,
        y: f64,
        first_peak: usize,
    ) -> (Vec<SynthPeak>, Vec<FixedRidge>, [f64; 4]) {
        let peaks = self
            .peaks
            .iter()
            .map(|p| SynthPeak {
                x: p.x + x,
                y: p.y + y,
                ..p.clone()
            })
            .collect();
        let ridges = self
            .ridges
            .iter()
            .map(|r| FixedRidge {
                peaks: [r.peaks[0] + first_peak, r.peaks[1] + first_peak],
                x: r.x + x,
                y: r.y + y,
                elevation: r.elevation,
            })
            .collect();
        (peaks, ridges, [x, y, x + self.width_m, y + self.height_m])
    }
}
