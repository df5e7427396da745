"""orogen from Python: elevation-model analysis on numpy arrays, xarray
DataArrays and files too large for memory.

Every function calls one operation of the orogen library (``orogen::ops``,
the same code the ``orogen`` command runs) with the command's parameter
names and defaults. An input is

* a 2-D numpy array (``transform=`` a GDAL 6-tuple or an ``affine.Affine``,
  ``crs=`` an EPSG code, ``"EPSG:n"`` or WKT, ``nodata=``; NaN is nodata),
* an xarray DataArray (rioxarray's ``rio.transform()``, ``rio.crs`` and
  ``rio.nodata`` are honoured when rioxarray is installed, else regular
  ``x``/``y`` coordinates and ``attrs``; coordinates and attributes are
  kept on the result), or
* a path (GeoTIFF, tile store ``.tiles``, ``.hgt``, ``.asc``, PNG
  heightmap) or a :class:`Raster` from :func:`open`.

Without ``output=`` the result comes back in memory as an array of the
input's kind (float results carry NaN for nodata). With ``output=`` a path,
the operation runs out of core, tile by tile within ``memory=``, writes the
file and returns a lazy :class:`Raster` on it.

>>> import numpy as np, orogen
>>> dem = np.full((5, 5), 10.0, dtype=np.float32); dem[2, 2] = 2.0
>>> float(orogen.fill(dem)[2, 2])
10.0
"""

from __future__ import annotations

import json
import os
import re
import tempfile
from typing import Any, Dict, Iterable, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _orogen
from ._orogen import (
    CorruptInputError,
    InternalError,
    InvalidInputError,
    MemoryBudgetError,
    OrogenError,
    StorageError,
    UnsupportedFormatError,
)

__all__ = [
    "OrogenError",
    "InvalidInputError",
    "MemoryBudgetError",
    "UnsupportedFormatError",
    "CorruptInputError",
    "StorageError",
    "InternalError",
    "Raster",
    "open",
    "fill",
    "fill_epsilon",
    "fill_nodata",
    "breach",
    "flow",
    "accumulate",
    "watersheds",
    "slope",
    "aspect",
    "hillshade",
    "export",
    "metrics",
    "peaks",
    "defaults",
    "synth",
    "erode",
    "basins",
    "streams",
    "hydro_index",
    "viewshed",
    "render",
    "tiles",
    "ridges",
    "orostats",
    "compare",
    "ingest",
    "info",
    "run_job",
    "run_command",
]

__version__ = "0.1.0"

# EPSG codes of common geographic (degree) CRSs, used when pyproj is absent.
_GEOGRAPHIC_EPSG = {4326, 4258, 4269, 4267, 4283, 4617, 4979, 4230, 4612, 6318, 7844}


def defaults(op: str) -> Dict[str, Any]:
    """The default options of operation ``op`` (the CLI's), e.g.
    ``defaults("slope")`` -> ``{"units": "degrees", "z_factor": 1.0, ...}``;
    ``"run"`` and ``"format"`` give the run and output-format settings."""
    return json.loads(_orogen.defaults(op))


# --------------------------------------------------------------------------
# Georeferencing


def _gdal_transform(t: Any) -> Optional[Tuple[float, ...]]:
    """A GDAL 6-tuple from a GDAL tuple or an ``affine.Affine``."""
    if t is None:
        return None
    if hasattr(t, "to_gdal"):
        return tuple(float(v) for v in t.to_gdal())
    v = tuple(float(x) for x in t)
    if len(v) == 9 and v[6:] == (0.0, 0.0, 1.0):  # an Affine given as a 3x3 sequence
        a, b, c, d, e, f = v[:6]
        return (c, a, b, f, d, e)
    if len(v) != 6:
        raise InvalidInputError(
            "transform: give a GDAL 6-tuple (x0, dx, rx, y0, ry, dy) or an affine.Affine"
        )
    return v


def _crs_fields(crs: Any) -> Dict[str, Any]:
    """``epsg``, ``geographic`` and ``linear_unit_m`` of a CRS given as an
    EPSG code, ``"EPSG:n"``, WKT, or a pyproj / rasterio CRS object."""
    if crs is None:
        return {}
    epsg = None
    geographic = None
    unit = None
    if isinstance(crs, (int, np.integer)):
        epsg = int(crs)
    elif hasattr(crs, "to_epsg"):
        epsg = crs.to_epsg()
        geographic = getattr(crs, "is_geographic", None)
        if callable(geographic):
            geographic = geographic()
        if epsg is None and hasattr(crs, "to_wkt"):
            return _crs_fields(crs.to_wkt())
    else:
        text = str(crs).strip()
        m = re.fullmatch(r"(?i)epsg:(\d+)", text)
        if m:
            epsg = int(m.group(1))
        else:
            try:
                import pyproj  # type: ignore

                c = pyproj.CRS.from_user_input(text)
                epsg = c.to_epsg()
                geographic = c.is_geographic
                if c.axis_info:
                    unit = c.axis_info[0].unit_conversion_factor
            except ImportError:
                ids = re.findall(r'(?:AUTHORITY|ID)\[\s*"EPSG"\s*,\s*"?(\d+)"?\s*\]', text)
                if ids:
                    epsg = int(ids[-1])
                geographic = text.upper().startswith(("GEOGCS", "GEOGCRS", "GEODCRS"))
            except Exception as e:  # pyproj.exceptions.CRSError
                raise InvalidInputError(f"crs: {e}") from None
    if geographic is None:
        geographic = epsg in _GEOGRAPHIC_EPSG
    out: Dict[str, Any] = {"epsg": epsg, "geographic": bool(geographic)}
    if unit:
        out["linear_unit_m"] = float(unit)
    return out


def _xarray_georef(da: Any) -> Dict[str, Any]:
    """The georeference of a DataArray: rioxarray's when installed, else
    from regular ``x``/``y`` coordinates and ``attrs``."""
    g: Dict[str, Any] = {}
    rio = None
    try:
        import rioxarray  # type: ignore  # noqa: F401

        rio = da.rio
    except ImportError:
        pass
    if rio is not None:
        try:
            g["transform"] = _gdal_transform(rio.transform())
        except Exception:
            pass
        if rio.crs is not None:
            g.update(_crs_fields(rio.crs))
        if rio.nodata is not None:
            g["nodata"] = float(rio.nodata)
    if "transform" not in g and da.ndim == 2:
        ydim, xdim = da.dims
        if xdim in da.coords and ydim in da.coords and da.sizes[xdim] > 1 and da.sizes[ydim] > 1:
            x = np.asarray(da.coords[xdim], dtype=np.float64)
            y = np.asarray(da.coords[ydim], dtype=np.float64)
            dx, dy = x[1] - x[0], y[1] - y[0]
            if np.allclose(np.diff(x), dx) and np.allclose(np.diff(y), dy):
                g["transform"] = (x[0] - dx / 2, dx, 0.0, y[0] - dy / 2, 0.0, dy)
    if "epsg" not in g:
        for key in ("crs", "spatial_ref", "crs_wkt"):
            if key in da.attrs:
                g.update(_crs_fields(da.attrs[key]))
                break
    if "nodata" not in g:
        for key in ("nodata", "_FillValue", "missing_value"):
            if key in da.attrs:
                g["nodata"] = float(da.attrs[key])
                break
    return g


def _is_dataarray(x: Any) -> bool:
    return type(x).__name__ == "DataArray" and hasattr(x, "dims") and hasattr(x, "coords")


# Array dtypes the library reads natively; others are converted.
_NATIVE = {np.dtype(t) for t in ("float32", "float64", "uint8", "int8", "uint16", "int16", "uint32", "int32")}


def _mask_path(mask: Any) -> str:
    """The file of a ``mask=`` argument (a path or an :class:`orogen.Raster`):
    a raster on the input's grid, 0 or nodata where the input is read as
    nodata (the CLI's ``--mask``)."""
    if isinstance(mask, Raster):
        return mask.path
    if isinstance(mask, (str, os.PathLike)):
        return os.fspath(mask)
    raise InvalidInputError("mask: give the path of a raster on the input's grid (or an orogen.Raster)")


class _Input:
    """An operation's input as the extension takes it, and what is needed
    to give the result back in the input's kind."""

    def __init__(self, dem: Any, transform: Any, crs: Any, nodata: Optional[float],
                 sea_level: Optional[float] = None, mask: Any = None, allow_sparse: bool = False):
        self.template = None
        self.georef: Optional[Dict[str, Any]] = None
        if isinstance(dem, (Raster, str, os.PathLike)):
            self.value: Any = dem.path if isinstance(dem, Raster) else os.fspath(dem)
            self.kind = "path"
            # A file's reading options, as the CLI's --nodata / --sea-level.
            if nodata is not None or sea_level is not None or mask is not None or allow_sparse:
                self.georef = {"nodata": None if nodata is None else float(nodata),
                               "sea_level": None if sea_level is None else float(sea_level),
                               "mask": None if mask is None else _mask_path(mask),
                               "allow_sparse": bool(allow_sparse)}
            return
        g: Dict[str, Any] = {}
        if _is_dataarray(dem):
            if dem.ndim != 2:
                raise InvalidInputError(f"a DEM is 2-D; this DataArray has dims {dem.dims}")
            self.template = dem
            g = _xarray_georef(dem)
            arr = np.asarray(dem.values)
            self.kind = "xarray"
        else:
            arr = np.asarray(dem)
            self.kind = "numpy"
        if arr.ndim != 2:
            raise InvalidInputError(f"a DEM is a 2-D array; this one has shape {arr.shape}")
        if arr.dtype not in _NATIVE:
            if arr.dtype.kind == "f" or arr.dtype.kind in "iu":
                arr = arr.astype(np.float32 if arr.dtype.itemsize <= 2 else np.float64)
            else:
                raise InvalidInputError(f"arrays of {arr.dtype} are not elevations")
        if transform is not None:
            g["transform"] = _gdal_transform(transform)
        if crs is not None:
            g.update(_crs_fields(crs))
        if nodata is not None:
            g["nodata"] = float(nodata)
        if sea_level is not None:
            g["sea_level"] = float(sea_level)
        if mask is not None:
            g["mask"] = _mask_path(mask)
        self.value = np.ascontiguousarray(arr)
        self.georef = g

    def _has_rio(self) -> bool:
        try:
            import rioxarray  # type: ignore  # noqa: F401
        except ImportError:
            return False
        return self.template is not None

    def wrap(self, flat: np.ndarray, width: int, height: int, georef: Dict[str, Any], name: str) -> Any:
        """The result in the input's kind: float nodata becomes NaN."""
        a = _to_array(flat, width, height, georef.get("nodata"))
        if self.kind != "xarray":
            return a
        import xarray as xr  # type: ignore

        t = self.template
        out = xr.DataArray(a, dims=t.dims, coords=t.coords, attrs=dict(t.attrs), name=name)
        nd = georef.get("nodata")
        out_nd = np.nan if a.dtype.kind == "f" else nd
        for key in ("_FillValue", "missing_value"):
            out.attrs.pop(key, None)
        if self._has_rio():
            if t.rio.crs is not None:
                out = out.rio.write_crs(t.rio.crs)
            out = out.rio.write_nodata(out_nd, encoded=False)
        else:
            out.attrs["nodata"] = out_nd
        return out


def _to_array(flat: np.ndarray, width: int, height: int, nodata: Optional[float]) -> np.ndarray:
    a = flat.reshape(height, width)
    if a.dtype.kind == "f" and nodata is not None and not np.isnan(nodata):
        a[a == nodata] = np.nan
    return a


def _json(d: Dict[str, Any]) -> str:
    return json.dumps({k: v for k, v in d.items()})


def _run_settings(memory: Optional[str], tile: Optional[int], threads: int) -> str:
    r: Dict[str, Any] = {"threads": threads, "quiet": True, "tile": tile}
    if memory is not None:
        r["memory"] = str(memory)
    return _json(r)


def _raster_op(
    op: str,
    dem: Any,
    opts: Dict[str, Any],
    *,
    transform: Any,
    crs: Any,
    nodata: Optional[float],
    sea_level: Optional[float],
    mask: Any,
    output: Any,
    memory: Optional[str],
    tile: Optional[int],
    threads: int,
    format: Optional[Dict[str, Any]],
    progress: Any = None,
    allow_sparse: bool = False,
) -> Any:
    inp = _Input(dem, transform, crs, nodata, sea_level, mask, allow_sparse)
    run = _run_settings(memory, tile, threads)
    fmt = _json(format or {})
    cb = _progress(progress)
    if output is not None:
        out = os.fspath(output)
        _orogen.run_raster(op, inp.value, inp.georef, _json(opts), run, fmt, out, None, cb)
        return open(out)
    with tempfile.TemporaryDirectory(prefix="orogen-") as scratch:
        flat, w, h, g = _orogen.run_raster(op, inp.value, inp.georef, _json(opts), run, fmt, None, scratch, cb)
    return inp.wrap(flat, w, h, g, op)


class _Tqdm:
    """A ``progress`` callback drawing one tqdm bar per engine step."""

    def __init__(self) -> None:
        from tqdm.auto import tqdm  # type: ignore

        self._tqdm = tqdm
        self._bars: Dict[str, Any] = {}

    def __call__(self, step: str, done: int, total: int) -> bool:
        bar = self._bars.get(step)
        if bar is None:
            bar = self._bars[step] = self._tqdm(total=total, desc=step, unit="tile", leave=False)
        bar.update(done - bar.n)
        if done >= total:
            bar.close()
            del self._bars[step]
        return True


def _progress(progress: Any) -> Any:
    """The callback of a ``progress=`` argument: a callable
    ``(step, done, total)`` (return ``False`` to stop the run), ``True``
    for tqdm bars (tqdm must be installed), or None."""
    if progress is None or progress is False:
        return None
    if progress is True:
        try:
            return _Tqdm()
        except ImportError:
            raise InvalidInputError("progress=True draws tqdm bars: pip install tqdm, or pass a callback") from None
    if not callable(progress):
        raise InvalidInputError("progress: give a callable (step, done, total), True for tqdm, or None")
    return progress


_RUN_DOC = """
    Common parameters: ``transform``, ``crs``, ``nodata`` describe a numpy
    input; ``output`` a path to write instead of returning an array (then a
    :class:`Raster` is returned); ``memory`` the budget for tiles in flight
    (e.g. ``"512MiB"``, default ``"1GiB"``); ``tile`` the work-tile size in
    cells; ``threads`` worker threads (0: all cores); ``format`` output-file
    settings (``compress``, ``block``, ``store_tile``, ``zstd``,
    ``overwrite``, ``cog``, …, as ``orogen <cmd> --help``); ``progress`` a
    callback ``(step, done, total)`` called after every tile of every
    engine step (return ``False`` to stop the run), or ``True`` for tqdm
    bars. Ctrl-C (KeyboardInterrupt) stops a run between two tiles. The
    input array is read in place (no copy) when its dtype is native
    (float32/64, (u)int8/16/32) and it is C-contiguous."""


def _doc(f):
    f.__doc__ = (f.__doc__ or "") + _RUN_DOC
    return f


@_doc
def fill(dem, *, sinks=None, transform=None, crs=None, nodata=None, sea_level=None, mask=None, allow_sparse=False, output=None, memory=None, tile=None, threads=0, format=None, progress=None):
    """Fill the depressions of ``dem`` (``orogen fill``): Priority-Flood
    (Barnes, Lehman & Mulla 2014), exact across tiles (Barnes 2016). Nodata
    cells and the edge are outlets, and so are the declared ``sinks`` (a
    path: a raster on the DEM's grid, non-zero = sink, or a CSV/GeoJSON of
    points): an endorheic basin drains into its sink.

    >>> import numpy as np, orogen
    >>> dem = np.full((5, 5), 10.0, dtype=np.float32); dem[2, 2] = 2.0
    >>> float(orogen.fill(dem)[2, 2])
    10.0
    """
    return _raster_op("fill", dem, {"sinks": None if sinks is None else str(sinks)}, transform=transform, crs=crs, nodata=nodata, sea_level=sea_level, mask=mask, allow_sparse=allow_sparse, output=output,
                      memory=memory, tile=tile, threads=threads, format=format, progress=progress)


@_doc
def fill_epsilon(dem, *, transform=None, crs=None, nodata=None, sea_level=None, mask=None, allow_sparse=False, output=None, memory=None, tile=None, threads=0,
                 format=None, progress=None):
    """Fill to a strictly draining surface (``orogen fill-epsilon``): each
    flat cell rises k ULPs above its fill level, k its distance to the
    flat's exit (Barnes, Lehman & Mulla 2014, epsilon variant), exact
    across tiles."""
    return _raster_op("fill_epsilon", dem, {}, transform=transform, crs=crs, nodata=nodata, sea_level=sea_level, mask=mask, allow_sparse=allow_sparse, output=output,
                      memory=memory, tile=tile, threads=threads, format=format, progress=progress)


@_doc
def breach(dem, *, method="breach", max_depth=None, max_length=None, dist=50, fill_remaining=False, epsilon=False,
           transform=None, crs=None, nodata=None, sea_level=None, mask=None, allow_sparse=False, output=None, memory=None, tile=None, threads=0, format=None, progress=None):
    """Breach depressions (``orogen breach``): ``method`` ``"breach"``
    (flood-order, every depression carved), ``"hybrid"`` (Lindsay 2016
    selective breaching within ``max_depth`` / ``max_length``, else fill) or
    ``"least-cost"`` (within ``dist`` cells of each pit, across tiles;
    ``fill_remaining`` fills what no channel could drain). ``epsilon``
    carves strictly descending channels."""
    opts = {"method": method, "max_depth": max_depth, "max_length": max_length, "dist": dist,
            "fill_remaining": fill_remaining, "epsilon": epsilon}
    return _raster_op("breach", dem, opts, transform=transform, crs=crs, nodata=nodata, sea_level=sea_level, mask=mask, allow_sparse=allow_sparse, output=output,
                      memory=memory, tile=tile, threads=threads, format=format, progress=progress)


@_doc
def flow(dem, *, method="d8", seed=0, sinks=None, transform=None, crs=None, nodata=None, sea_level=None, mask=None, allow_sparse=False, output=None, memory=None, tile=None,
         threads=0, format=None, progress=None):
    """D8 flow directions of a filled DEM (``orogen flow``) as ESRI codes
    (1 E, 2 SE, 4 S, 8 SW, 16 W, 32 NW, 64 N, 128 NE; 0 no flow, 255
    nodata), uint8; flats drained per Barnes, Lehman & Mulla 2014, exact
    across tiles. ``method="rho8"``: Fairfield & Leymarie 1991, seeded by
    ``seed``. ``sinks``: the declared sinks given to :func:`fill` (D8 only):
    their cells get no flow (0) and the flats around them drain into them."""
    return _raster_op("flow", dem, {"method": method, "seed": seed, "sinks": None if sinks is None else str(sinks)}, transform=transform, crs=crs, nodata=nodata, sea_level=sea_level, mask=mask, allow_sparse=allow_sparse,
                      output=output, memory=memory, tile=tile, threads=threads, format=format, progress=progress)


@_doc
def accumulate(src, *, method="d8", exponent=4.0, weights=None, units="cells", transform=None, crs=None, nodata=None, sea_level=None, mask=None, allow_sparse=False,
               output=None, memory=None, tile=None, threads=0, format=None, progress=None):
    """Flow accumulation in cells (``orogen accumulate``), float64, nodata
    NaN. ``method="d8"`` takes D8 directions (from :func:`flow`; exact
    across tiles, Barnes 2017); ``"dinf"`` (Tarboton 1997), ``"quinn"``,
    ``"holmgren"`` (with ``exponent``) and ``"freeman"`` take a filled DEM.
    ``weights``: a path to a raster of the same size whose values are
    accumulated instead of cells. ``units``: ``"cells"``, or true cell
    areas ``"m2"`` / ``"km2"`` (per row on lat/lon grids, WGS 84; times the
    weights when given) or ``"sca"`` (specific catchment area, m² per m of
    contour width √(cell area)); these need georeferencing."""
    opts = {"method": method, "exponent": exponent,
            "weights": os.fspath(weights) if weights is not None else None, "units": units}
    return _raster_op("accumulate", src, opts, transform=transform, crs=crs, nodata=nodata, sea_level=sea_level, mask=mask, allow_sparse=allow_sparse, output=output,
                      memory=memory, tile=tile, threads=threads, format=format, progress=progress)


@_doc
def watersheds(dirs, *, transform=None, crs=None, nodata=None, sea_level=None, mask=None, allow_sparse=False, output=None, memory=None, tile=None, threads=0,
               format=None, progress=None):
    """Watershed labels of D8 directions (``orogen watersheds``): every cell
    gets the row-major index + 1 of the cell where its D8 path leaves the
    DEM (uint32, 0 nodata), exact across tiles."""
    return _raster_op("watersheds", dirs, {}, transform=transform, crs=crs, nodata=nodata, sea_level=sea_level, mask=mask, allow_sparse=allow_sparse, output=output,
                      memory=memory, tile=tile, threads=threads, format=format, progress=progress)


@_doc
def slope(dem, *, units="degrees", z_factor=1.0, compute_edges=False, transform=None, crs=None, nodata=None, sea_level=None, mask=None, allow_sparse=False,
          output=None, memory=None, tile=None, threads=0, format=None, progress=None):
    """Slope (``orogen slope``) by Horn's (1981) 3x3 gradient, as ``gdaldem
    slope``: ``units`` ``"degrees"`` or ``"percent"``; edge cells are
    nodata unless ``compute_edges``."""
    opts = {"units": units, "z_factor": z_factor, "compute_edges": compute_edges}
    return _raster_op("slope", dem, opts, transform=transform, crs=crs, nodata=nodata, sea_level=sea_level, mask=mask, allow_sparse=allow_sparse, output=output,
                      memory=memory, tile=tile, threads=threads, format=format, progress=progress)


@_doc
def aspect(dem, *, zero_for_flat=False, compute_edges=False, transform=None, crs=None, nodata=None, sea_level=None, mask=None, allow_sparse=False, output=None,
           memory=None, tile=None, threads=0, format=None, progress=None):
    """Aspect in degrees clockwise from north (``orogen aspect``), Horn
    (1981) as ``gdaldem aspect``; flat cells are nodata unless
    ``zero_for_flat``."""
    opts = {"zero_for_flat": zero_for_flat, "compute_edges": compute_edges}
    return _raster_op("aspect", dem, opts, transform=transform, crs=crs, nodata=nodata, sea_level=sea_level, mask=mask, allow_sparse=allow_sparse, output=output,
                      memory=memory, tile=tile, threads=threads, format=format, progress=progress)


@_doc
def hillshade(dem, *, azimuth=315.0, altitude=45.0, z_factor=1.0, compute_edges=False, transform=None, crs=None,
              nodata=None, sea_level=None, mask=None, allow_sparse=False, output=None, memory=None, tile=None, threads=0, format=None, progress=None):
    """Hillshade 1..255 (0 nodata), uint8 (``orogen hillshade``), Horn (1981)
    as ``gdaldem hillshade``."""
    opts = {"azimuth": azimuth, "altitude": altitude, "z_factor": z_factor, "compute_edges": compute_edges}
    return _raster_op("hillshade", dem, opts, transform=transform, crs=crs, nodata=nodata, sea_level=sea_level, mask=mask, allow_sparse=allow_sparse, output=output,
                      memory=memory, tile=tile, threads=threads, format=format, progress=progress)


def export(dem, output, *, transform=None, crs=None, nodata=None, sea_level=None, mask=None, allow_sparse=False, memory=None, tile=None, threads=0, format=None, progress=None):
    """Write ``dem`` (an array, DataArray or raster path) to ``output``
    (``orogen export`` / ``ingest``: ``.tif``, ``.tiles``, ``.png``, ``.asc``
    by extension) in its native type, tile by tile; returns a
    :class:`Raster` on it."""
    return _raster_op("export", dem, {}, transform=transform, crs=crs, nodata=nodata, sea_level=sea_level, mask=mask, allow_sparse=allow_sparse, output=output,
                      memory=memory, tile=tile, threads=threads, format=format, progress=progress)


def metrics(dem, metric: Union[str, Sequence[str]], *, transform=None, crs=None, nodata=None, sea_level=None, mask=None, allow_sparse=False, output=None,
            memory=None, tile=None, threads=0, format=None, file_format="tif", progress=None):
    """Terrain metrics (``orogen metric --metric``): ``metric`` a list of
    specs such as ``["tpi:radius=500m", "openness:radius=1km"]`` (or one
    comma-separated string; ``orogen metric --list`` names all 65 and the
    papers they follow). Returns a dict from each metric's file stem (its
    name and parameters, as the CLI names the files) to its array; with
    ``output`` a folder, the files are written there (``file_format``
    ``"tif"`` or ``"tiles"``) and the dict maps to :class:`Raster`\\ s.
    """
    spec = metric if isinstance(metric, str) else ",".join(metric)
    inp = _Input(dem, transform, crs, nodata, sea_level, mask, allow_sparse)
    run = _run_settings(memory, tile, threads)
    opts = _json({"metric": spec, "format": file_format})
    fmt = _json(format or {})
    if output is not None:
        out = os.fspath(output)
        files = _orogen.metrics(inp.value, inp.georef, opts, run, fmt, out, None, _progress(progress))
        return {os.path.splitext(os.path.basename(f))[0]: open(f) for f in files}
    with tempfile.TemporaryDirectory(prefix="orogen-") as scratch:
        res = _orogen.metrics(inp.value, inp.georef, opts, run, fmt, None, scratch, _progress(progress))
    return {name: inp.wrap(flat, w, h, g, name) for name, flat, w, h, g in res}


# Columns of peaks.csv that are whole numbers (empty cells become -1).
_INT_COLUMNS = {"col", "row", "parent", "line_parent", "dominance_group"}


def _parse_table(text: str) -> Dict[str, np.ndarray]:
    lines = text.splitlines()
    names = lines[0].split(",")
    rows = [ln.split(",") for ln in lines[1:] if ln]
    cols: Dict[str, np.ndarray] = {}
    for j, name in enumerate(names):
        cells = [r[j] for r in rows]
        if name in _INT_COLUMNS:
            cols[name] = np.array([int(c) if c else -1 for c in cells], dtype=np.int64)
        else:
            cols[name] = np.array([float(c) if c else np.nan for c in cells], dtype=np.float64)
    return cols


def peaks(dem, *, min_prominence=30.0, edge="sea-level", no_isolation=False, tiled=False, line_parents=False,
          transform=None, crs=None, nodata=None, sea_level=None, mask=None, allow_sparse=False, output=None, memory=None, tile=None, threads=0,
          as_dataframe=False, progress=None, geojson_crs="wgs84"):
    """Peaks with prominence, key saddles, parents, isolation and the divide
    tree (``orogen peaks``; Kirmse & de Ferranti 2017), in memory when the
    DEM fits ``memory``, else tile by tile with the same results.

    Returns the peaks table (the columns of ``peaks.csv``: ``y``/``x`` or
    ``lat``/``lon``, ``elevation``, ``prominence``, saddle position and
    elevation, ``isolation_km``, ``dominance``, ``col``, ``row``,
    ``parent``, …) as a dict of numpy columns (float64 with NaN for empty
    cells; the index columns int64 with -1), or a pandas DataFrame when
    ``as_dataframe`` (pandas must be installed). With ``output`` a folder,
    writes ``peaks.csv``, ``peaks.geojson``, ``saddles.geojson``,
    ``divide_tree.geojson`` and ``divide_tree.json`` there and returns
    their paths. The GeoJSON files are WGS 84 longitude/latitude (RFC 7946)
    unless ``geojson_crs="native"`` (the DEM's CRS with a ``crs`` member),
    as ``--geojson-crs`` of the CLI.
    """
    inp = _Input(dem, transform, crs, nodata, sea_level, mask, allow_sparse)
    run = _run_settings(memory, tile, threads)
    opts = _json({"min_prominence": float(min_prominence), "edge": edge, "no_isolation": no_isolation,
                  "tiled": tiled, "line_parents": line_parents, "tile": tile, "geojson_crs": geojson_crs})
    if output is not None:
        return list(_orogen.peaks(inp.value, inp.georef, opts, run, os.fspath(output), _progress(progress)))
    table = _parse_table(_orogen.peaks(inp.value, inp.georef, opts, run, None, _progress(progress)))
    if as_dataframe:
        import pandas as pd  # type: ignore

        return pd.DataFrame(table)
    return table


def erode(dem, model="hydraulic", steps=None, *, water=False, sediment=False, set=None, transform=None, crs=None,
          nodata=None, sea_level=None, mask=None, allow_sparse=False, output=None, memory=None, tile=None, threads=0, format=None, progress=None, **params):
    """Erode ``dem`` (``orogen erode``): ``model`` ``"hydraulic"`` (virtual
    pipes, Mei, Decaudin & Hu 2007), ``"thermal"`` (talus, Musgrave, Kolb &
    Mace 1989), ``"diffusion"`` (hillslope diffusion) — tiled with halo
    exchange, the same bytes for any tile size — or ``"stream-power"`` with
    uplift (Braun & Willett 2013; in memory or tiled, ``fixed_points``,
    ``levels``, ``radius`` for the constrained and coarse-to-fine runs).
    ``steps`` the number of steps; ``set`` a dict of model parameters
    (``{"rain": 0.02}``, as ``--set rain=0.02``); ``params`` the CLI's
    named options with ``_`` for ``-`` (``seed``, ``dt``, ``talus``,
    ``diffusivity``, ``exchange``, ``k``, ``m``, ``n``, ``uplift``,
    ``depressions``, ``base_level``, ``cell``, ``params`` a TOML file, …).
    Returns the eroded DEM (float32), or with ``water`` / ``sediment`` a
    dict of ``"elevation"``, ``"water"``, ``"sediment"`` arrays (hydraulic).
    With ``output`` a path the DEM is written there (``water`` /
    ``sediment`` then paths) and a :class:`Raster` returned.

    >>> import numpy as np, orogen
    >>> y, x = np.mgrid[0:32, 0:32]
    >>> cone = (300.0 - 10.0 * np.hypot(x - 16, y - 16)).astype(np.float32)
    >>> smooth = orogen.erode(cone, "diffusion", 50, diffusivity=0.5, dt=1.0)
    >>> bool(smooth[16, 16] < cone[16, 16])   # the summit is worn down
    True
    """
    inp = _Input(dem, transform, crs, nodata, sea_level, mask, allow_sparse)
    opts: Dict[str, Any] = {"model": model}
    if steps is not None:
        opts["steps"] = int(steps)
    if set:
        opts["set"] = [f"{k}={v}" for k, v in dict(set).items()]
    for k, v in params.items():
        if v is None:
            continue
        opts[k.replace("_", "-")] = os.fspath(v) if isinstance(v, os.PathLike) else v
    run = _run_settings(memory, tile, threads)
    fmt = _json(format or {})
    cb = _progress(progress)
    if output is not None:
        for name, v in (("water", water), ("sediment", sediment)):
            if v is True:
                raise InvalidInputError(f"erode: with output=, give {name}= a path")
            if v:
                opts[name] = os.fspath(v)
        _orogen.erode(inp.value, inp.georef, _json(opts), run, fmt, os.fspath(output), None, [], cb)
        return open(output)
    extras = [n for n, v in (("water", water), ("sediment", sediment)) if v]
    with tempfile.TemporaryDirectory(prefix="orogen-") as scratch:
        res = _orogen.erode(inp.value, inp.georef, _json(opts), run, fmt, None, scratch, extras, cb)
    out = {name: inp.wrap(flat, w, h, g, name) for name, flat, w, h, g in res}
    return out if extras else out["elevation"]


# --------------------------------------------------------------------------
# Files


class Raster:
    """A raster file or tile store, read lazily by window (:func:`open`)."""

    def __init__(self, path: Union[str, os.PathLike]):
        self._f = _orogen.open(os.fspath(path))
        self._georef = self._f.georef()

    @property
    def path(self) -> str:
        return os.fspath(self._f.path)

    @property
    def shape(self) -> Tuple[int, int]:
        """``(rows, columns)``."""
        w, h = self._f.size
        return (h, w)

    @property
    def dtype(self) -> np.dtype:
        """The native cell type (reads of float rasters give NaN for nodata)."""
        return np.dtype(self._f.dtype)

    @property
    def transform(self) -> Optional[Tuple[float, ...]]:
        """The GDAL geotransform, or None when not georeferenced."""
        g = self._georef
        return tuple(g["transform"]) if g["georeferenced"] else None

    @property
    def crs(self) -> Optional[int]:
        """The EPSG code of the CRS, when known."""
        return self._georef["epsg"]

    @property
    def nodata(self) -> Optional[float]:
        return self._georef["nodata"]

    def read(self, window: Optional[Tuple[int, int, int, int]] = None) -> np.ndarray:
        """Read ``window`` = ``(col, row, width, height)`` (default: all) as a
        numpy array of the native type; float nodata becomes NaN, cells
        beyond the edge are nodata."""
        if window is None:
            h, w = self.shape
            window = (0, 0, w, h)
        x, y, w, h = (int(v) for v in window)
        flat, w, h = self._f.read(x, y, w, h)
        return _to_array(flat, w, h, self.nodata)

    def to_xarray(self, window: Optional[Tuple[int, int, int, int]] = None):
        """The raster (or ``window``) as an xarray DataArray with ``y``/``x``
        cell-centre coordinates (rioxarray CRS and nodata when installed)."""
        import xarray as xr  # type: ignore

        if window is None:
            h, w = self.shape
            window = (0, 0, w, h)
        x0, y0, w, h = (int(v) for v in window)
        a = self.read(window)
        t = self._georef["transform"]
        cols = np.arange(x0, x0 + w) + 0.5
        rows = np.arange(y0, y0 + h) + 0.5
        xs = t[0] + cols * t[1]
        ys = t[3] + rows * t[5]
        nd = np.nan if a.dtype.kind == "f" else self.nodata
        attrs: Dict[str, Any] = {"transform": tuple(t)}
        if self.crs is not None:
            attrs["crs"] = f"EPSG:{self.crs}"
        da = xr.DataArray(a, dims=("y", "x"), coords={"y": ys, "x": xs}, attrs=attrs,
                          name=os.path.basename(self.path))
        try:
            import rioxarray  # type: ignore  # noqa: F401
        except ImportError:
            da.attrs["nodata"] = nd
            return da
        if self.crs is not None:
            da = da.rio.write_crs(f"EPSG:{self.crs}")
        return da.rio.write_nodata(nd, encoded=False)

    def __repr__(self) -> str:
        return f"Raster({self.path!r}, shape={self.shape}, dtype={self.dtype})"


def open(path: Union[str, os.PathLike]) -> Raster:  # noqa: A001 (the package's name for it)
    """Open a raster (GeoTIFF, tile store, .hgt, ASCII grid, PNG heightmap)
    for lazy window reads: nothing is read until :meth:`Raster.read`."""
    return Raster(path)


from . import synth  # noqa: E402  (uses the helpers above)
from ._commands import (  # noqa: E402
    basins,
    compare,
    fill_nodata,
    hydro_index,
    info,
    ingest,
    orostats,
    render,
    ridges,
    run_command,
    run_job,
    streams,
    tiles,
    viewshed,
)
