//! `orogen._orogen`: the Rust half of the Python package. It calls the
//! library's operations (`orogen::ops`) and nothing below them but the
//! raster types an array is wrapped in (`orogen::raster`) and the reader of
//! input paths the CLI uses too (`orogen::io::open_raster`). The pure-Python
//! layer (`orogen/__init__.py`) turns numpy / xarray inputs into the
//! `(array, georef)` pairs taken here and the results back.
//!
//! Every operation's options arrive as JSON text and are read into the ops
//! `XxxOptions` struct with serde, so the names and defaults are the CLI's,
//! kept in one place. Work runs with the GIL released; a panic becomes an
//! `OrogenError` instead of ending the interpreter.

use numpy::{
    IntoPyArray, PyArrayDescrMethods, PyArrayMethods, PyUntypedArray, PyUntypedArrayMethods,
};
use orogen::error::Error;
use orogen::exec::{EngineConfig, Observer};
use orogen::ops::{self, parse::FormatOptions, parse::RunOptions, Target};
use orogen::raster::{read_window_native, AnyGrid, Crs, GeoRef, RasterSource, SliceRaster, Window};
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

pyo3::create_exception!(
    orogen,
    OrogenError,
    PyException,
    "An error of the orogen library."
);
pyo3::create_exception!(
    orogen,
    InvalidInputError,
    OrogenError,
    "A bad argument or input (a wrong parameter, a raster of the wrong type or size)."
);
pyo3::create_exception!(
    orogen,
    MemoryBudgetError,
    OrogenError,
    "The operation needs more memory than the budget (`memory=`) allows."
);
pyo3::create_exception!(
    orogen,
    UnsupportedFormatError,
    OrogenError,
    "A file format or a feature of one that orogen does not read."
);
pyo3::create_exception!(
    orogen,
    CorruptInputError,
    OrogenError,
    "An input file is damaged."
);
pyo3::create_exception!(
    orogen,
    StorageError,
    OrogenError,
    "Reading or writing a file or tile store failed."
);
pyo3::create_exception!(
    orogen,
    InternalError,
    OrogenError,
    "A bug in orogen (a Rust panic), caught before it ended the interpreter."
);

/// The Python exception for a library error, by its kind.
fn to_py(e: Error) -> PyErr {
    let msg = e.to_string();
    let mut kind = &e;
    while let Error::Tile { inner, .. } = kind {
        kind = inner;
    }
    match kind {
        Error::OverBudget(_) => MemoryBudgetError::new_err(msg),
        // A declared size beyond what orogen reads (a hostile or broken header).
        Error::TooLarge { .. } => CorruptInputError::new_err(msg),
        Error::InvalidArgument(_) => InvalidInputError::new_err(msg),
        Error::Unsupported { .. } => UnsupportedFormatError::new_err(msg),
        Error::Corrupt { .. } => CorruptInputError::new_err(msg),
        Error::Io { .. } | Error::Store { .. } => StorageError::new_err(msg),
        Error::Tile { .. } => OrogenError::new_err(msg),
    }
}

/// Run `f` without the GIL; a library error or a panic becomes a Python
/// exception.
fn detached<T: Send>(
    py: Python<'_>,
    f: impl FnOnce() -> orogen::error::Result<T> + Send,
) -> PyResult<T> {
    let out = py.detach(|| std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)));
    match out {
        Ok(r) => r.map_err(to_py),
        Err(p) => {
            let what = p
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_else(|| "unknown panic".into());
            Err(InternalError::new_err(format!(
                "internal error (please report): {what}"
            )))
        }
    }
}

/// serde_json text into an ops Options struct; unknown names are refused
/// by the structs themselves (`deny_unknown_fields`).
fn options<T: serde::de::DeserializeOwned>(json: &str, what: &str) -> PyResult<T> {
    serde_json::from_str(json).map_err(|e| InvalidInputError::new_err(format!("{what}: {e}")))
}

/// A georeference from the Python layer's dict: `transform` (GDAL order),
/// `epsg`, `geographic`, `nodata` (all optional).
fn georef_from(d: Option<&Bound<'_, PyDict>>) -> PyResult<GeoRef> {
    let mut g = GeoRef::pixel();
    let Some(d) = d else { return Ok(g) };
    if let Some(t) = d.get_item("transform")? {
        if !t.is_none() {
            let v: Vec<f64> = t.extract()?;
            if v.len() != 6 {
                return Err(InvalidInputError::new_err(
                    "transform: give the 6 GDAL coefficients (x0, dx, rx, y0, ry, dy)",
                ));
            }
            g.transform.copy_from_slice(&v);
            g.georeferenced = true;
        }
    }
    let mut crs = Crs::default();
    if let Some(e) = d.get_item("epsg")? {
        crs.epsg = e.extract::<Option<u32>>()?;
    }
    if let Some(geo) = d.get_item("geographic")? {
        crs.geographic = geo.extract::<Option<bool>>()?.unwrap_or(false);
    }
    if let Some(u) = d.get_item("linear_unit_m")? {
        if let Some(u) = u.extract::<Option<f64>>()? {
            crs.linear_unit_m = u;
        }
    }
    g.crs = crs;
    if let Some(n) = d.get_item("nodata")? {
        g.nodata = n.extract::<Option<f64>>()?;
    }
    Ok(g)
}

/// The Python layer's dict of a georeference.
fn georef_dict<'py>(py: Python<'py>, g: &GeoRef) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("transform", g.transform.to_vec())?;
    d.set_item("georeferenced", g.georeferenced)?;
    d.set_item("epsg", g.crs.epsg)?;
    d.set_item("geographic", g.crs.geographic)?;
    d.set_item("linear_unit_m", g.crs.linear_unit_m)?;
    d.set_item("nodata", g.nodata)?;
    Ok(d)
}

/// Run `f` on a C-contiguous 2-D numpy array read in place (no copy: a
/// [`SliceRaster`] borrows the array's buffer while `f` runs; numpy's
/// borrow flag keeps it from being written meanwhile).
fn with_array<R>(
    a: &Bound<'_, PyUntypedArray>,
    georef: GeoRef,
    f: impl FnOnce(&dyn RasterSource) -> PyResult<R>,
) -> PyResult<R> {
    if a.ndim() != 2 {
        return Err(InvalidInputError::new_err(format!(
            "a DEM is a 2-D array; this one has {} dimensions",
            a.ndim()
        )));
    }
    let py = a.py();
    let dt = a.dtype();
    macro_rules! first_matching {
        ($($t:ty),*) => {
            $(
                if dt.is_equiv_to(&numpy::dtype::<$t>(py)) {
                    let typed = a.cast::<numpy::PyArray2<$t>>()?.readonly();
                    let shape = typed.shape();
                    let (h, w) = (shape[0], shape[1]);
                    let cells = typed
                        .as_slice()
                        .map_err(|_| InvalidInputError::new_err("the array must be C-contiguous"))?;
                    let src = SliceRaster::new(cells, w, h, georef, "<array>").map_err(to_py)?;
                    return f(&src);
                }
            )*
        };
    }
    first_matching!(f32, f64, u8, i8, u16, i16, u32, i32);
    Err(InvalidInputError::new_err(format!(
        "arrays of {dt} are not supported: use float32, float64 or an integer type of up to 32 bits"
    )))
}

/// A grid as a flat numpy array (the Python layer reshapes it), moved
/// without a copy.
fn array_from(py: Python<'_>, g: AnyGrid) -> Py<PyAny> {
    match g {
        AnyGrid::U8(g) => g.into_vec().into_pyarray(py).into_any().unbind(),
        AnyGrid::I8(g) => g.into_vec().into_pyarray(py).into_any().unbind(),
        AnyGrid::U16(g) => g.into_vec().into_pyarray(py).into_any().unbind(),
        AnyGrid::I16(g) => g.into_vec().into_pyarray(py).into_any().unbind(),
        AnyGrid::U32(g) => g.into_vec().into_pyarray(py).into_any().unbind(),
        AnyGrid::I32(g) => g.into_vec().into_pyarray(py).into_any().unbind(),
        AnyGrid::F32(g) => g.into_vec().into_pyarray(py).into_any().unbind(),
        AnyGrid::F64(g) => g.into_vec().into_pyarray(py).into_any().unbind(),
    }
}

/// Run `f` on an operation's input: a path (opened as the CLI opens it)
/// or an array with its georeference (read in place, see [`with_array`]).
fn with_source<R>(
    input: &Bound<'_, PyAny>,
    georef: Option<&Bound<'_, PyDict>>,
    f: impl FnOnce(&dyn RasterSource) -> PyResult<R>,
) -> PyResult<R> {
    // `sea_level` (and for a path, `nodata`) as the CLI's --sea-level / --nodata
    let key = |k: &str| -> PyResult<Option<f64>> {
        match georef.map(|d| d.get_item(k)).transpose()?.flatten() {
            Some(v) => v.extract::<Option<f64>>(),
            None => Ok(None),
        }
    };
    let sea_level = key("sea_level")?;
    let mask: Option<PathBuf> = match georef.map(|d| d.get_item("mask")).transpose()?.flatten() {
        Some(v) => v.extract::<Option<PathBuf>>()?,
        None => None,
    };
    if let Ok(a) = input.cast::<PyUntypedArray>() {
        return with_array(a, georef_from(georef)?, |src| {
            let mask = match &mask {
                Some(m) => Some(
                    orogen::io::open_raster(m, &Default::default()).map_err(to_py)?,
                ),
                None => None,
            };
            let r = orogen::io::reassign::reassign(
                Box::new(orogen::io::reassign::Borrowed(src)),
                None,
                sea_level,
                mask,
            )
            .map_err(to_py)?;
            f(r.as_ref())
        });
    }
    let path: PathBuf = input.extract()?;
    let allow_sparse = match georef
        .map(|d| d.get_item("allow_sparse"))
        .transpose()?
        .flatten()
    {
        Some(v) => v.extract::<Option<bool>>()?.unwrap_or(false),
        None => false,
    };
    let opts = orogen::io::OpenOptions {
        nodata: key("nodata")?,
        sea_level,
        mask,
        allow_sparse,
        ..Default::default()
    };
    let src = orogen::io::open_raster(&path, &opts).map_err(to_py)?;
    f(src.as_ref())
}

/// The observer of a run: checks for Ctrl-C (a `KeyboardInterrupt` stops
/// the run) and calls `callback(name, done, total)` after every tile or
/// round; an exception it raises, or a return of `False`, stops the run.
/// The exception is kept in `raised` for [`finish`] to raise in its place.
fn observer(callback: Option<Py<PyAny>>, raised: &Arc<Mutex<Option<PyErr>>>) -> Observer {
    let raised = Arc::clone(raised);
    Observer(Arc::new(move |name: &str, done: u64, total: u64| {
        Python::attach(|py| {
            let keep = |e: PyErr| {
                if let Ok(mut slot) = raised.lock() {
                    slot.get_or_insert(e);
                }
                false
            };
            if let Err(e) = py.check_signals() {
                return keep(e);
            }
            match &callback {
                None => true,
                Some(cb) => match cb.call1(py, (name, done, total)) {
                    Ok(v) => !matches!(v.extract::<bool>(py), Ok(false)),
                    Err(e) => keep(e),
                },
            }
        })
    }))
}

/// A run's result, with the exception its observer kept (Ctrl-C, a
/// callback's own) raised in place of the library's "cancelled".
fn finish<T>(r: PyResult<T>, raised: &Arc<Mutex<Option<PyErr>>>) -> PyResult<T> {
    match r {
        Err(e) => match raised.lock().ok().and_then(|mut s| s.take()) {
            Some(kept) => Err(kept),
            None => Err(e),
        },
        ok => ok,
    }
}

/// The engine settings and work tile of the `run` JSON (ops `RunOptions`),
/// with the run's observer (see [`observer`]).
fn run_settings(
    run_json: &str,
    progress: Option<Py<PyAny>>,
    raised: &Arc<Mutex<Option<PyErr>>>,
) -> PyResult<(EngineConfig, Option<usize>)> {
    let run: RunOptions = options(run_json, "run settings")?;
    let mut cfg = run.engine_config(false).map_err(to_py)?;
    cfg.observer = Some(observer(progress, raised));
    Ok((cfg, run.tile))
}

/// A raster result: `(flat array, width, height, georef dict)`.
type RasterResult = (Py<PyAny>, usize, usize, Py<PyDict>);

fn raster_result(py: Python<'_>, (grid, georef): (AnyGrid, GeoRef)) -> PyResult<RasterResult> {
    let (w, h) = (grid.width(), grid.height());
    let d = georef_dict(py, &georef)?.unbind();
    Ok((array_from(py, grid), w, h, d))
}

/// The target of a one-raster result: the file `output` written with the
/// `format` settings (JSON of `FormatOptions`), else in memory with
/// intermediates in `scratch`.
fn target_for(
    output: &Option<PathBuf>,
    scratch: &Option<PathBuf>,
    format: &str,
) -> PyResult<Target> {
    match (output, scratch) {
        (Some(p), _) => {
            let fmt: FormatOptions = self::options(format, "format settings")?;
            let mut t = Target::new(p);
            t.options = fmt.output_options().map_err(to_py)?;
            Ok(t)
        }
        (None, Some(dir)) => Ok(Target::memory(dir)),
        (None, None) => Err(InvalidInputError::new_err(
            "give an output path or a scratch folder",
        )),
    }
}

/// Run the one-raster operation `op` on `input` with `options` (JSON of
/// its ops Options). With `output` (a path) the result is written there
/// and `None` returned; without, it is kept in memory (intermediates, if
/// the operation has any, go to the folder `scratch`) and returned as
/// `(flat array, width, height, georef dict)`.
#[pyfunction]
#[pyo3(signature = (op, input, georef, options, run, format, output, scratch, progress=None))]
#[allow(clippy::too_many_arguments)]
fn run_raster(
    py: Python<'_>,
    op: &str,
    input: &Bound<'_, PyAny>,
    georef: Option<&Bound<'_, PyDict>>,
    options: &str,
    run: &str,
    format: &str,
    output: Option<PathBuf>,
    scratch: Option<PathBuf>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Option<RasterResult>> {
    let raised = Arc::new(Mutex::new(None));
    let (cfg, tile) = run_settings(run, progress, &raised)?;
    let mut target = target_for(&output, &scratch, format)?;
    target.tile = tile;
    let ran = with_source(input, georef, |src| {
        run_raster_on(py, op, src, options, &target, &cfg)
    });
    finish(ran, &raised)?;
    result_of(py, &target, op)
}

/// [`run_raster`]'s call of the operation `op` on `src`.
fn run_raster_on(
    py: Python<'_>,
    op: &str,
    src: &dyn RasterSource,
    options: &str,
    target: &Target,
    cfg: &EngineConfig,
) -> PyResult<()> {
    let op_name = op.to_string();
    macro_rules! call {
        ($m:ident, $o:ty) => {{
            let o: $o = self::options(options, &op_name)?;
            detached(py, move || ops::$m::run(src, &o, target, cfg).map(|_| ()))?
        }};
    }
    match op {
        "fill" => call!(fill, ops::fill::FillOptions),
        "fill_epsilon" => call!(fill_epsilon, ops::fill_epsilon::FillEpsilonOptions),
        "breach" => call!(breach, ops::breach::BreachOptions),
        "flow" => call!(flow, ops::flow::FlowOptions),
        "accumulate" => call!(accumulate, ops::accumulate::AccumulateOptions),
        "slope" => call!(slope, ops::slope::SlopeOptions),
        "aspect" => call!(aspect, ops::aspect::AspectOptions),
        "hillshade" => call!(hillshade, ops::hillshade::HillshadeOptions),
        "watersheds" => call!(watersheds, ops::watersheds::WatershedsOptions),
        "export" => detached(py, move || ops::convert::run(src, target, cfg, &mut |_| {}))?,
        _ => {
            return Err(InvalidInputError::new_err(format!(
                "unknown operation {op:?}"
            )))
        }
    }
    Ok(())
}

/// What a run into `target` returns to Python: `None` for a file target,
/// else the raster it left in memory (see [`raster_result`]).
fn result_of(py: Python<'_>, target: &Target, what: &str) -> PyResult<Option<RasterResult>> {
    if target.options.memory.is_none() {
        return Ok(None);
    }
    let res = target
        .take_memory()
        .ok_or_else(|| OrogenError::new_err(format!("{what}: no output was produced")))?;
    Ok(Some(raster_result(py, res)?))
}

/// Terrain metrics (`orogen metrics`): `options` is the JSON of ops
/// `MetricOptions` (`metric`: comma-separated specs). With `output` (a
/// folder) the files are written there and their paths returned; without,
/// a list of `(name, flat array, width, height, georef dict)`.
#[pyfunction]
#[pyo3(signature = (input, georef, options, run, format, output, scratch, progress=None))]
#[allow(clippy::too_many_arguments)]
fn metrics<'py>(
    py: Python<'py>,
    input: &Bound<'py, PyAny>,
    georef: Option<&Bound<'py, PyDict>>,
    options: &str,
    run: &str,
    format: &str,
    output: Option<PathBuf>,
    scratch: Option<PathBuf>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyList>> {
    let raised = Arc::new(Mutex::new(None));
    let (cfg, tile) = run_settings(run, progress, &raised)?;
    let ran = with_source(input, georef, |src| {
        metrics_on(py, src, options, format, output, scratch, tile, &cfg)
    });
    finish(ran, &raised)
}

/// [`metrics`] on an opened `src`.
#[allow(clippy::too_many_arguments)]
fn metrics_on<'py>(
    py: Python<'py>,
    src: &dyn RasterSource,
    options: &str,
    format: &str,
    output: Option<PathBuf>,
    scratch: Option<PathBuf>,
    tile: Option<usize>,
    cfg: &EngineConfig,
) -> PyResult<Bound<'py, PyList>> {
    let opts: ops::metric::MetricOptions = self::options(options, "metrics")?;
    let fmt: FormatOptions = self::options(format, "format settings")?;
    let out = PyList::empty(py);
    if let Some(dir) = output {
        let oo = fmt.output_options().map_err(to_py)?;
        let files = detached(py, || ops::metric::run(src, &dir, &opts, &oo, tile, cfg))?;
        for f in files {
            out.append(f)?;
        }
        return Ok(out);
    }
    let dir = scratch
        .ok_or_else(|| InvalidInputError::new_err("give an output folder or a scratch folder"))?;
    let paths = ops::metric::output_paths(&dir, &opts).map_err(to_py)?;
    let memory = orogen::store::sink::MemoryOutputs::default();
    for p in &paths {
        memory.claim(p);
    }
    let oo = orogen::io::OutputOptions {
        memory: Some(memory.clone()),
        ..Default::default()
    };
    detached(py, || ops::metric::run(src, &dir, &opts, &oo, tile, cfg))?;
    for p in &paths {
        let res = memory.take(p).ok_or_else(|| {
            OrogenError::new_err(format!("{}: no output was produced", p.display()))
        })?;
        let name = file_stem(p);
        let (a, w, h, d) = raster_result(py, res)?;
        out.append((name, a, w, h, d))?;
    }
    Ok(out)
}

fn file_stem(p: &Path) -> String {
    p.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// Peaks with prominence (`orogen peaks`): `options` is the JSON of ops
/// `PeaksOptions`. With `output` (a folder) the files are written there
/// and their paths returned as a list; without, the peaks table as the
/// text of `peaks.csv`.
#[pyfunction]
#[pyo3(signature = (input, georef, options, run, output, progress=None))]
fn peaks<'py>(
    py: Python<'py>,
    input: &Bound<'py, PyAny>,
    georef: Option<&Bound<'py, PyDict>>,
    options: &str,
    run: &str,
    output: Option<PathBuf>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let raised = Arc::new(Mutex::new(None));
    let (cfg, _) = run_settings(run, progress, &raised)?;
    let opts: ops::peaks::PeaksOptions = self::options(options, "peaks")?;
    let (opts, cfg) = (&opts, &cfg);
    let ran = with_source(input, georef, |src| {
        if let Some(dir) = output {
            let found = detached(py, || ops::peaks::run(src, &dir, opts, cfg))?;
            return Ok(PyList::new(py, found.files)?.into_any());
        }
        let text = detached(py, || ops::peaks::table(src, opts, cfg))?;
        Ok(text.into_pyobject(py)?.into_any())
    });
    finish(ran, &raised)
}

/// A raster file or tile store opened for window reads (`orogen.open`).
#[pyclass(name = "RasterFile", module = "orogen._orogen", frozen)]
struct RasterFile {
    src: Box<dyn RasterSource>,
}

#[pymethods]
impl RasterFile {
    /// `(width, height)` in cells.
    #[getter]
    fn size(&self) -> (usize, usize) {
        let i = self.src.info();
        (i.width, i.height)
    }
    /// Native cell type, as a numpy dtype name.
    #[getter]
    fn dtype(&self) -> &'static str {
        use orogen::raster::DType;
        match self.src.info().dtype {
            DType::U8 => "uint8",
            DType::I8 => "int8",
            DType::U16 => "uint16",
            DType::I16 => "int16",
            DType::U32 => "uint32",
            DType::I32 => "int32",
            DType::F32 => "float32",
            DType::F64 => "float64",
        }
    }
    /// The georeference dict (transform, epsg, geographic, nodata, …).
    fn georef<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        georef_dict(py, &self.src.info().georef)
    }
    /// The path it was opened from.
    #[getter]
    fn path(&self) -> PathBuf {
        self.src.info().path.clone()
    }
    /// Read the window of `w` x `h` cells at column `x`, row `y` in the
    /// native type: `(flat array, w, h)`; cells beyond the edge are nodata.
    fn read(
        &self,
        py: Python<'_>,
        x: i64,
        y: i64,
        w: usize,
        h: usize,
    ) -> PyResult<(Py<PyAny>, usize, usize)> {
        let src = &self.src;
        let g = detached(py, move || {
            read_window_native(src.as_ref(), Window::new(x, y, w, h))
        })?;
        Ok((array_from(py, g), w, h))
    }
}

/// Open a raster (GeoTIFF, tile store, .hgt, ASCII grid, PNG heightmap)
/// for window reads; nothing is read until `read`.
#[pyfunction]
fn open(py: Python<'_>, path: PathBuf) -> PyResult<RasterFile> {
    let src = detached(py, move || {
        orogen::io::open_raster(&path, &Default::default())
    })?;
    Ok(RasterFile { src })
}

/// The defaults of an operation's options (the CLI's), as JSON text.
#[pyfunction]
fn defaults(op: &str) -> PyResult<String> {
    fn j<T: serde::Serialize + Default>() -> String {
        serde_json::to_string(&T::default()).unwrap_or_default()
    }
    Ok(match op {
        "fill" => j::<ops::fill::FillOptions>(),
        "fill_epsilon" => j::<ops::fill_epsilon::FillEpsilonOptions>(),
        "breach" => j::<ops::breach::BreachOptions>(),
        "flow" => j::<ops::flow::FlowOptions>(),
        "accumulate" => j::<ops::accumulate::AccumulateOptions>(),
        "slope" => j::<ops::slope::SlopeOptions>(),
        "aspect" => j::<ops::aspect::AspectOptions>(),
        "hillshade" => j::<ops::hillshade::HillshadeOptions>(),
        "watersheds" => j::<ops::watersheds::WatershedsOptions>(),
        "metrics" => j::<ops::metric::MetricOptions>(),
        "peaks" => j::<ops::peaks::PeaksOptions>(),
        "run" => j::<RunOptions>(),
        "format" => j::<FormatOptions>(),
        _ => {
            return Err(InvalidInputError::new_err(format!(
                "unknown operation {op:?}"
            )))
        }
    })
}

/// `synth noise` (`ops::synth::noise`) with `options` (JSON of its
/// `NoiseOptions`, the CLI's kebab-case names; `output` is set here):
/// written to `output`, or kept in memory under `scratch` and returned as
/// `(flat array, width, height, georef dict)`.
#[pyfunction]
#[pyo3(signature = (options, run, format, output, scratch, progress=None))]
fn synth_noise(
    py: Python<'_>,
    options: &str,
    run: &str,
    format: &str,
    output: Option<PathBuf>,
    scratch: Option<PathBuf>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Option<RasterResult>> {
    let mut opts: ops::synth::noise::NoiseOptions = self::options(options, "synth noise")?;
    let raised = Arc::new(Mutex::new(None));
    let (cfg, tile) = run_settings(run, progress, &raised)?;
    let target = target_for(&output, &scratch, format)?;
    opts.output = target.path.clone();
    opts.tile = opts.tile.or(tile);
    let (o, oo, c) = (&opts, &target.options, &cfg);
    finish(
        detached(py, move || ops::synth::noise::run(o, oo, c, &mut |_| {})),
        &raised,
    )?;
    result_of(py, &target, "synth noise")
}

/// Erosion (`orogen erode`): `options` is the JSON of ops `ErodeOptions`
/// (the CLI's kebab-case names; `input` and `output` are set here). With
/// `output` (a path) the result is written there (and `water` /
/// `sediment`, paths, when given) and `None` returned; without, the
/// rasters are kept in memory under `scratch` and returned as a list of
/// `(name, flat array, width, height, georef dict)`: `elevation`, then
/// `water` and `sediment` when `extras` names them.
#[pyfunction]
#[pyo3(signature = (input, georef, options, run, format, output, scratch, extras, progress=None))]
#[allow(clippy::too_many_arguments)]
fn erode<'py>(
    py: Python<'py>,
    input: &Bound<'py, PyAny>,
    georef: Option<&Bound<'py, PyDict>>,
    options: &str,
    run: &str,
    format: &str,
    output: Option<PathBuf>,
    scratch: Option<PathBuf>,
    extras: Vec<String>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Option<Bound<'py, PyList>>> {
    let mut opts: ops::erode::ErodeOptions = self::options(options, "erode")?;
    let raised = Arc::new(Mutex::new(None));
    let (cfg, tile) = run_settings(run, progress, &raised)?;
    opts.tile = opts.tile.or(tile);
    let fmt: FormatOptions = self::options(format, "format settings")?;
    let mut oo = fmt.output_options().map_err(to_py)?;
    let mut named = vec![];
    match (&output, &scratch) {
        (Some(p), _) => opts.output = p.clone(),
        (None, Some(dir)) => {
            let memory = orogen::store::sink::MemoryOutputs::default();
            opts.output = dir.join("elevation.tif");
            named.push(("elevation".to_string(), opts.output.clone()));
            for e in &extras {
                let p = dir.join(format!("{e}.tif"));
                match e.as_str() {
                    "water" => opts.water = Some(p.clone()),
                    "sediment" => opts.sediment = Some(p.clone()),
                    other => {
                        return Err(InvalidInputError::new_err(format!(
                            "erode: no output {other:?} (water, sediment)"
                        )))
                    }
                }
                named.push((e.clone(), p));
            }
            for (_, p) in &named {
                memory.claim(p);
            }
            oo.memory = Some(memory);
        }
        (None, None) => {
            return Err(InvalidInputError::new_err(
                "give an output path or a scratch folder",
            ))
        }
    }
    ops::erode::check(&opts).map_err(to_py)?;
    let (o, oo_ref, c) = (&opts, &oo, &cfg);
    let ran = with_source(input, georef, |src| {
        detached(py, move || {
            ops::erode::run_on(o, src, oo_ref, c, &mut |_| {})
        })
    });
    finish(ran, &raised)?;
    let Some(memory) = &oo.memory else {
        return Ok(None);
    };
    let out = PyList::empty(py);
    for (name, p) in named {
        let res = memory
            .take(&p)
            .ok_or_else(|| OrogenError::new_err(format!("erode: no {name} output was produced")))?;
        let (a, w, h, d) = raster_result(py, res)?;
        out.append((name, a, w, h, d))?;
    }
    Ok(Some(out))
}

/// A JSON value as the TOML value a job step's `args` holds.
fn toml_value(v: serde_json::Value, key: &str) -> PyResult<toml::Value> {
    use serde_json::Value as J;
    Ok(match v {
        J::Bool(b) => toml::Value::Boolean(b),
        J::Number(n) => match n.as_i64() {
            Some(i) => toml::Value::Integer(i),
            None => toml::Value::Float(n.as_f64().unwrap_or(f64::NAN)),
        },
        J::String(t) => toml::Value::String(t),
        J::Array(items) => toml::Value::Array(
            items
                .into_iter()
                .map(|i| toml_value(i, key))
                .collect::<PyResult<_>>()?,
        ),
        J::Null | J::Object(_) => {
            return Err(InvalidInputError::new_err(format!(
                "{key}: give a string, number, boolean or a list of them"
            )))
        }
    })
}

/// Run any command of the library's registry by name (`"basins"`,
/// `"synth tectonic"`, …; `ops::job::run_command`) on file paths:
/// `inputs` its positional inputs, `output` its `-o`, `args` the JSON of
/// its options by their long names. Returns the notes it made as
/// `(kind, text)` pairs (`wrote`, `warning`, `info`, `message`, `print`).
#[pyfunction]
#[pyo3(signature = (command, inputs, output, args, progress=None))]
fn command(
    py: Python<'_>,
    command: &str,
    inputs: Vec<PathBuf>,
    output: Option<PathBuf>,
    args: &str,
    progress: Option<Py<PyAny>>,
) -> PyResult<Vec<(String, String)>> {
    let raw: serde_json::Map<String, serde_json::Value> = self::options(args, command)?;
    let mut table = std::collections::BTreeMap::new();
    for (k, v) in raw {
        let v = toml_value(v, &k)?;
        table.insert(k, v);
    }
    let raised = Arc::new(Mutex::new(None));
    let watch = Some(observer(progress, &raised));
    let mut notes = vec![];
    let ran = detached(py, || {
        ops::job::run_command(
            command,
            &inputs,
            output.as_deref(),
            table,
            watch,
            &mut |n| notes.push(n),
        )
    });
    finish(ran, &raised)?;
    use orogen::ops::note::Note;
    Ok(notes
        .into_iter()
        .map(|n| match n {
            Note::Wrote(p) => ("wrote".to_string(), p.display().to_string()),
            Note::Warning(t) => ("warning".to_string(), t),
            Note::Info(t) => ("info".to_string(), t),
            Note::Message(t) => ("message".to_string(), t),
            Note::Print(t) => ("print".to_string(), t),
        })
        .collect())
}

/// Run the batch job at `path` (`orogen run`; ops `job::prepare` and
/// `job::run`): every step checked first, then run in order, resumable.
/// Returns the job's step lines; with `dry_run`, each step's command line
/// and typed options, and nothing runs.
#[pyfunction]
#[pyo3(signature = (path, memory, threads, dry_run))]
fn run_job(
    py: Python<'_>,
    path: PathBuf,
    memory: Option<String>,
    threads: Option<usize>,
    dry_run: bool,
) -> PyResult<Vec<String>> {
    let opts = ops::job::JobOptions {
        memory,
        threads,
        quiet: true,
        ..Default::default()
    };
    let job = detached(py, || ops::job::prepare(&path, &opts))?;
    if dry_run {
        let mut lines = vec![];
        for s in &job.steps {
            let typed = ops::job::typed_options(s).map_err(to_py)?;
            lines.push(format!("{}: orogen {}\n{typed}", s.name, s.argv.join(" ")));
        }
        return Ok(lines);
    }
    let mut lines = vec![];
    detached(py, || {
        ops::job::run(&job, &opts, &mut |n| {
            if let orogen::ops::note::Note::Message(t) | orogen::ops::note::Note::Info(t) = n {
                lines.push(t)
            }
        })
    })?;
    Ok(lines)
}

#[pymodule]
fn _orogen(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("OrogenError", py.get_type::<OrogenError>())?;
    m.add("InvalidInputError", py.get_type::<InvalidInputError>())?;
    m.add("MemoryBudgetError", py.get_type::<MemoryBudgetError>())?;
    m.add(
        "UnsupportedFormatError",
        py.get_type::<UnsupportedFormatError>(),
    )?;
    m.add("CorruptInputError", py.get_type::<CorruptInputError>())?;
    m.add("StorageError", py.get_type::<StorageError>())?;
    m.add("InternalError", py.get_type::<InternalError>())?;
    m.add_function(wrap_pyfunction!(run_raster, m)?)?;
    m.add_function(wrap_pyfunction!(metrics, m)?)?;
    m.add_function(wrap_pyfunction!(peaks, m)?)?;
    m.add_function(wrap_pyfunction!(open, m)?)?;
    m.add_function(wrap_pyfunction!(defaults, m)?)?;
    m.add_function(wrap_pyfunction!(synth_noise, m)?)?;
    m.add_function(wrap_pyfunction!(erode, m)?)?;
    m.add_function(wrap_pyfunction!(command, m)?)?;
    m.add_function(wrap_pyfunction!(run_job, m)?)?;
    m.add_class::<RasterFile>()?;
    Ok(())
}
