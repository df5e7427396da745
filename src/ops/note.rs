//! What an operation tells its caller while it runs: the files it wrote,
//! warnings and one-line summaries, in the order they happen. The CLI prints
//! them (`wrote PATH`, `warning: ...`, summaries unless `--quiet`); a library
//! user may collect or ignore them.

use crate::error::Result;
use crate::io::{self, OpenOptions};
use crate::raster::RasterSource;
use std::path::{Path, PathBuf};

/// One event of a running operation.
#[derive(Debug, Clone, PartialEq)]
pub enum Note {
    /// A finished output file (or folder).
    Wrote(PathBuf),
    /// A warning; the text has no `warning: ` prefix.
    Warning(String),
    /// A summary line (the CLI prints it unless `--quiet`).
    Info(String),
    /// A message printed even with `--quiet` (statistics asked for, a
    /// job's step lines).
    Message(String),
    /// Text for standard output, as it is (the report of `info`).
    Print(String),
}

/// The callback an operation reports its [`Note`]s to.
pub type Notify<'a> = &'a mut dyn FnMut(Note);

/// Return early with [`crate::Error::InvalidArgument`] built by `format!`.
macro_rules! bail {
    ($($t:tt)*) => {
        return Err($crate::error::Error::invalid(format!($($t)*)))
    };
}
pub(crate) use bail;

/// Open the raster at `path`, with a warning when it has no georeferencing
/// (pixel coordinates, 1 x 1 cells).
pub fn open_input(
    path: &Path,
    opts: &OpenOptions,
    notify: Notify<'_>,
) -> Result<Box<dyn RasterSource>> {
    let src = io::open_raster(path, opts)?;
    warn_georef(src.as_ref(), notify);
    note_band(src.as_ref(), notify);
    Ok(src)
}

/// A note naming the band read when `src` has several (a multi-band file
/// is read one band at a time: `--band N` chooses it).
pub fn note_band(src: &dyn RasterSource, notify: Notify<'_>) {
    let (band, bands) = src.band();
    if bands > 1 {
        notify(Note::Warning(format!(
            "{} has {bands} bands; band {band} is read (choose another with --band N)",
            src.info().path.display()
        )));
    }
}

/// A warning when `src` has no georeferencing (pixel coordinates, 1 x 1
/// cells), and one naming what of its georeferencing is not used (GCPs,
/// RPCs).
pub fn warn_georef(src: &dyn RasterSource, notify: Notify<'_>) {
    let info = src.info();
    if let Some(what) = src.unused_georef() {
        notify(Note::Warning(format!(
            "{}: its {what} are not used (orogen reads a geotransform); georeference it first, e.g. `gdalwarp -r bilinear IN OUT.tif`",
            info.path.display()
        )));
    }
    if !info.georef.georeferenced {
        notify(Note::Warning(format!(
            "{} has no georeferencing; using pixel coordinates with 1 x 1 cells (slopes assume cells of 1 elevation unit)",
            info.path.display()
        )));
    }
}

/// How the GeoJSON outputs of `src` are written (`crs`, see
/// [`crate::io::geojson`]), resolved before anything is computed or
/// written; the warning for a raster without a known CRS goes to `notify`.
pub fn geojson_coords(
    crs: crate::io::geojson::GeoJsonCrs,
    src: &dyn RasterSource,
    notify: Notify<'_>,
) -> Result<crate::io::geojson::GeoJsonCoords> {
    let info = src.info();
    let c = crs.coords(&info.georef, &info.path)?;
    if let Some(w) = c.warning() {
        notify(Note::Warning(w.to_string()));
    }
    Ok(c)
}

/// Render the hillshaded preview of `src` to `path` and note it.
pub(crate) fn preview(
    src: &dyn RasterSource,
    path: &Path,
    opts: &crate::tiles::render::RenderOptions,
    notify: Notify<'_>,
) -> Result<()> {
    crate::tiles::render::render_preview(src, path, opts)?;
    notify(Note::Wrote(path.to_path_buf()));
    Ok(())
}
