//! `synth`: terrain synthesis as library operations, one module per method
//! (the CLI's `orogen synth <method>`): seeded noise ([`noise`]), river
//! networks ([`rivers`]), tectonic folds ([`tectonic`]), example-based
//! optimisation ([`optimise`]) and orometric synthesis ([`orometric`]:
//! profile, divide tree, terrain). Each has an Options struct with the CLI's
//! names and defaults and a `run` that writes the outputs.

pub mod noise;
pub mod optimise;
pub mod orometric;
pub mod rivers;
pub mod tectonic;

use crate::error::{Error, Result};
use crate::ops::note::{bail, Notify};
use crate::raster::RasterSource;
use crate::tiles::render::{RenderKind, RenderOptions};
use std::path::Path;

/// Parse a size `WxH` or `N` (a square) in cells.
pub fn parse_size(s: &str) -> Result<(usize, usize)> {
    let parse = |t: &str| -> Result<usize> {
        t.trim().parse::<usize>().map_err(|e| {
            Error::invalid(format!("--size: '{t}' is not a whole number of cells: {e}"))
        })
    };
    let (w, h) = match s.split_once(['x', 'X']) {
        Some((w, h)) => (parse(w)?, parse(h)?),
        None => {
            let n = parse(s)?;
            (n, n)
        }
    };
    if w == 0 || h == 0 {
        bail!("--size must be at least 1x1 (got {s})");
    }
    Ok((w, h))
}

/// Parse a point `X,Y`; `what` names the option in errors.
pub fn parse_xy(s: &str, what: &str) -> Result<(f64, f64)> {
    let Some((a, b)) = s.split_once(',') else {
        bail!("{what} {s:?}: expected X,Y");
    };
    let p = |t: &str| -> Result<f64> {
        let v: f64 = t
            .trim()
            .parse()
            .map_err(|e| Error::invalid(format!("{what} {s:?}: {t:?} is not a number: {e}")))?;
        if !v.is_finite() {
            bail!("{what} {s:?}: coordinates must be finite");
        }
        Ok(v)
    };
    Ok((p(a)?, p(b)?))
}

/// A preview with a legend of `src` at `path`.
fn preview(
    src: &dyn RasterSource,
    path: &Path,
    kind: RenderKind,
    notify: Notify<'_>,
) -> Result<()> {
    let opts = RenderOptions {
        kind,
        legend: true,
        ..Default::default()
    };
    crate::ops::note::preview(src, path, &opts, notify)
}
