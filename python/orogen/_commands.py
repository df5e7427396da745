"""The operations reached by name through the library's command registry
(``orogen::ops::job::run_command``, the same typed options a job step
takes): the inputs and any array-valued option are written to temporary
GeoTIFFs, the command runs on the files, and a raster result is read back
into the input's kind unless ``output=`` names where to keep it.

Options are the CLI's long options with ``_`` for ``-`` (``orogen <cmd>
--help`` lists them); ``True`` is a flag, a list is the CLI's
comma-separated list, an array / DataArray / :class:`orogen.Raster` /
path is a raster. Unknown names are refused with the accepted ones and the
nearest.
"""

from __future__ import annotations

import json
import os
import tempfile
import warnings
from typing import Any, Dict, List, Optional, Sequence

import numpy as np

from . import _orogen


def _is_raster_value(v: Any) -> bool:
    from . import Raster, _is_dataarray

    return isinstance(v, (np.ndarray, Raster)) or _is_dataarray(v)


def _spill(v: Any, tmp: str, name: str, georef: Dict[str, Any]) -> str:
    """A raster value as a path: arrays and DataArrays are written (native
    type, uncompressed) into ``tmp``; a Raster gives its path."""
    from . import Raster, _raster_op

    if isinstance(v, Raster):
        return v.path
    if isinstance(v, (str, os.PathLike)):
        return os.fspath(v)
    out = os.path.join(tmp, f"{name}.tif")
    _raster_op("export", v, {}, transform=georef.get("transform"), crs=georef.get("crs"),
               nodata=georef.get("nodata"), sea_level=None, mask=None, output=out, memory=None, tile=None, threads=0,
               format={"compress": "none"}, progress=None)
    return out


def _notes(pairs: Sequence[Any], spilled: Dict[str, str]) -> List[Any]:
    """Warnings become Python warnings; the rest is returned as text. The
    temporary files an array was written to are named as the array."""
    kept = []
    for kind, text in pairs:
        for path, name in spilled.items():
            text = text.replace(path, name)
        if kind == "warning":
            warnings.warn(text, stacklevel=3)
        else:
            kept.append((kind, text))
    return kept


def run_command(command: str, inputs: Sequence[Any] = (), output: Any = None, *, progress: Any = None,
                transform: Any = None, crs: Any = None, nodata: Optional[float] = None,
                **options: Any) -> List[Any]:
    """Run any orogen command by name on files (``"basins"``, ``"synth
    tectonic"``, …) as a job step runs it: ``inputs`` its positional
    inputs, ``output`` its ``-o``, ``options`` its long options. Arrays
    are written to temporary files first (``transform``/``crs``/``nodata``
    describe numpy arrays). Returns the command's notes as ``(kind,
    text)`` pairs (``wrote``, ``info``, ``message``, ``print``); warnings
    are issued as Python warnings.

    >>> import orogen, tempfile, os
    >>> d = tempfile.mkdtemp()
    >>> notes = orogen.run_command("synth noise", output=os.path.join(d, "n.tif"), size="32", seed=3)
    >>> orogen.open(os.path.join(d, "n.tif")).shape
    (32, 32)
    """
    from . import _progress

    georef = {"transform": transform, "crs": crs, "nodata": nodata}
    spilled: Dict[str, str] = {}

    def spill(v: Any, name: str, what: str) -> str:
        p = _spill(v, tmp, name, georef)
        if _is_raster_value(v) and p.startswith(tmp):
            spilled[p] = what
        return p

    with tempfile.TemporaryDirectory(prefix="orogen-") as tmp:
        paths = [spill(x, f"input{i}", "<array>" if len(inputs) == 1 else f"<array {i}>")
                 for i, x in enumerate(inputs)]
        args: Dict[str, Any] = {}
        for k, v in options.items():
            if v is None or v is False:
                continue
            if _is_raster_value(v) or isinstance(v, os.PathLike):
                v = spill(v, k, f"<array {k}>")
            elif isinstance(v, tuple):
                v = list(v)
            args[k] = v
        out = os.fspath(output) if output is not None else None
        pairs = _orogen.command(command, paths, out, json.dumps(args), _progress(progress))
    return _notes(pairs, spilled)


def _raster_command(command: str, inputs: Sequence[Any], output: Any, progress: Any, transform: Any,
                    crs: Any, nodata: Optional[float], options: Dict[str, Any]) -> Any:
    """A command whose output is one raster: written to ``output`` (a
    :class:`orogen.Raster` on it is returned), or read back into the kind of
    the first input (numpy, or xarray with its coordinates)."""
    from . import Raster, _Input

    if output is not None:
        run_command(command, inputs, output, progress=progress, transform=transform, crs=crs, nodata=nodata,
                    **options)
        return Raster(output)
    first = inputs[0] if inputs else None
    inp = _Input(first, transform, crs, nodata) if first is not None else None
    with tempfile.TemporaryDirectory(prefix="orogen-") as tmp:
        out = os.path.join(tmp, "result.tif")
        run_command(command, inputs, out, progress=progress, transform=transform, crs=crs, nodata=nodata,
                    **options)
        r = Raster(out)
        a = r.read()
        g = dict(r._georef)
    if inp is None or inp.kind != "xarray":
        return a
    return inp.wrap(a.ravel(), a.shape[1], a.shape[0], g, command.replace(" ", "_"))


def _files_command(command: str, inputs: Sequence[Any], output: Any, progress: Any, transform: Any, crs: Any,
                   nodata: Optional[float], options: Dict[str, Any]) -> List[str]:
    """A command writing files or folders: ``output`` is required; returns
    the paths it wrote."""
    if output is None:
        raise _orogen.InvalidInputError(f"{command}: give output= (the command writes files)")
    notes = run_command(command, inputs, output, progress=progress, transform=transform, crs=crs, nodata=nodata,
                        **options)
    wrote = [t for k, t in notes if k == "wrote"]
    return wrote or [os.fspath(output)]


_COMMON = """

    ``output``: where to write (else the result comes back in memory);
    ``progress``: a callback ``(step, done, total)`` or ``True`` for a tqdm
    bar; ``transform``/``crs``/``nodata`` describe numpy inputs; every
    other keyword is an option of ``orogen {cmd} --help`` (``_`` for
    ``-``), with its defaults, including ``memory``, ``threads`` and
    ``tile``."""


def _doc(cmd: str):
    def deco(f):
        f.__doc__ = (f.__doc__ or "") + _COMMON.format(cmd=cmd)
        return f

    return deco


@_doc("fill-nodata")
def fill_nodata(dem, *, output=None, progress=None, transform=None, crs=None, nodata=None, **options):
    """Fill voids (``orogen fill-nodata``) before hydrology: each nodata cell
    gets the inverse-distance-weighted mean (Shepard 1968, power 2) of the
    first valid cells on 16 rays within ``max_distance`` (cells, or
    ``"3km"``), exact across tiles; farther voids stay nodata, valid cells
    are copied unchanged. The input's cell type and nodata.

    >>> import numpy as np, orogen
    >>> z = np.full((1, 5), 10.0, dtype=np.float32); z[0, 2] = np.nan
    >>> orogen.fill_nodata(z, transform=(0, 1, 0, 0, 0, -1)).tolist()   # both sides 1 cell away
    [[10.0, 10.0, 10.0, 10.0, 10.0]]
    """
    return _raster_command("fill-nodata", [dem], output, progress, transform, crs, nodata, options)


@_doc("basins")
def basins(dirs, *, output=None, progress=None, transform=None, crs=None, nodata=None, **options):
    """Basin labels of every outlet of D8 directions (``orogen basins``,
    exact across tiles): a basin's label is its outlet's row-major index + 1;
    or the watersheds of ``points`` (a CSV or GeoJSON path; label = the
    point's number); ``metrics="basins.csv"`` with ``dem=`` also writes
    per-basin area, perimeter, circularity and hypsometry. 0 is nodata.

    >>> import numpy as np, orogen
    >>> d8 = np.full((3, 4), 1, dtype=np.uint8); d8[:, 3] = 0   # all flow east
    >>> orogen.basins(d8).tolist()   # outlets at cells 3, 7 and 11
    [[4, 4, 4, 4], [8, 8, 8, 8], [12, 12, 12, 12]]
    """
    return _raster_command("basins", [dirs], output, progress, transform, crs, nodata, options)


@_doc("streams")
def streams(dirs, *, output, progress=None, transform=None, crs=None, nodata=None, **options):
    """Stream network of D8 directions (``orogen streams``): ``output`` a
    GeoJSON of links with Strahler order, Shreve magnitude, length and
    drainage area; ``threshold`` (cells) or ``area`` (m²) sets where
    channels begin; ``raster=`` / ``stats=`` paths add the stream raster and
    Horton/Tokunaga statistics. Returns the paths written."""
    return _files_command("streams", [dirs], output, progress, transform, crs, nodata, options)


@_doc("hydro-index")
def hydro_index(index, *, output=None, progress=None, transform=None, crs=None, nodata=None, **options):
    """A hydrological index (``orogen hydro-index``): ``index`` one of
    ``twi``, ``spi``, ``sti``, ``ls`` (Moore, Grayson & Ladson 1991),
    ``hand`` (Rennó et al. 2008), ``dtw`` (Murphy et al. 2009),
    ``branch-length``; its rasters as ``dem=``, ``acc=``, ``dirs=``,
    ``streams=`` (arrays or paths), ``threshold``, ``min_slope``."""
    options["index"] = index
    first = next((options[k] for k in ("dem", "acc", "dirs") if options.get(k) is not None), None)
    if output is not None:
        from . import Raster

        run_command("hydro-index", [], output, progress=progress, transform=transform, crs=crs,
                    nodata=nodata, **options)
        return Raster(output)
    from . import Raster, _Input

    inp = _Input(first, transform, crs, nodata) if first is not None else None
    with tempfile.TemporaryDirectory(prefix="orogen-") as tmp:
        out = os.path.join(tmp, "index.tif")
        run_command("hydro-index", [], out, progress=progress, transform=transform, crs=crs, nodata=nodata,
                    **options)
        r = Raster(out)
        a, g = r.read(), dict(r._georef)
    if inp is None or inp.kind != "xarray":
        return a
    return inp.wrap(a.ravel(), a.shape[1], a.shape[0], g, index)


@_doc("viewshed")
def viewshed(dem, *, output=None, progress=None, transform=None, crs=None, nodata=None, **options):
    """Viewshed (``orogen viewshed``; R3 line of sight, Franklin & Ray 1994)
    of the observer ``at="X,Y"`` (map units; column,row with
    ``pixel=True``) ``observer_height`` m above the ground, within
    ``radius``; a cumulative viewshed of ``points=`` (a CSV or GeoJSON
    path), or Fisher's fuzzy viewshed (``fuzzy="B1,B2"``). uint8: 1
    visible, 0 not (a count for a cumulative one).

    >>> import numpy as np, orogen
    >>> bowl = np.fromfunction(lambda r, c: np.hypot(r - 10, c - 10), (21, 21)).astype(np.float32)
    >>> v = orogen.viewshed(bowl, at="10,10", pixel=True)
    >>> int(v[10, 10]), int(v.min())   # from the bottom of a bowl, every cell is seen
    (1, 1)
    """
    return _raster_command("viewshed", [dem], output, progress, transform, crs, nodata, options)


@_doc("render")
def render(dem, *, output, progress=None, transform=None, crs=None, nodata=None, **options):
    """A preview PNG (``orogen render``): hillshade blended with a
    hypsometric colour ramp. Returns the paths written."""
    return _files_command("render", [dem], output, progress, transform, crs, nodata, options)


@_doc("tiles")
def tiles(dem, *, output, progress=None, transform=None, crs=None, nodata=None, **options):
    """A Web-Mercator tile pyramid (``orogen tiles``): Terrain-RGB,
    Terrarium or colour PNG tiles into a z/x/y folder, ``.mbtiles`` or
    ``.pmtiles`` (by the extension of ``output``). Returns the paths
    written."""
    return _files_command("tiles", [dem], output, progress, transform, crs, nodata, options)


@_doc("ridges")
def ridges(dem, *, output, progress=None, transform=None, crs=None, nodata=None, **options):
    """Ridge networks (``orogen ridges``): divide-tree ridges with hierarchy
    levels and orders, and PPA ridges, into the folder ``output``."""
    return _files_command("ridges", [dem], output, progress, transform, crs, nodata, options)


@_doc("orostats")
def orostats(dem, *, output, progress=None, transform=None, crs=None, nodata=None, **options):
    """Orometric feature vectors over blue-noise disks (``orogen
    orostats``; Argudo et al. 2019, Table 1) and a region profile, into
    ``output``."""
    return _files_command("orostats", [dem], output, progress, transform, crs, nodata, options)


@_doc("compare")
def compare(a, b, *, output, progress=None, transform=None, crs=None, nodata=None, **options):
    """Realism report of two terrains (``orogen compare``): orometric
    histogram distances, pits, hypsometry, slope/curvature/geomorphon
    distributions, drainage density, Horton ratios, into the folder
    ``output`` (``compare.json``, ``compare.html``, charts). Returns the
    report as a dict (``compare.json``)."""
    _files_command("compare", [a, b], output, progress, transform, crs, nodata, options)
    with open(os.path.join(os.fspath(output), "compare.json")) as f:
        return json.load(f)


@_doc("ingest")
def ingest(inputs, *, output, progress=None, **options):
    """Ingest rasters (several: one mosaic) into a tile store or GeoTIFF
    (``orogen ingest``); returns a :class:`orogen.Raster` on it."""
    from . import Raster

    if isinstance(inputs, (str, os.PathLike)):
        inputs = [inputs]
    run_command("ingest", list(inputs), output, progress=progress, **options)
    return Raster(output)


def info(src, *, stats=False, transform=None, crs=None, nodata=None) -> Dict[str, Any]:
    """Describe a raster (``orogen info --json``): size, type,
    georeference, nodata and, with ``stats``, min/max/mean, as a dict.

    >>> import numpy as np, orogen
    >>> orogen.info(np.arange(12, dtype=np.int16).reshape(3, 4), stats=True)["width"]
    4
    """
    notes = run_command("info", [src], None, transform=transform, crs=crs, nodata=nodata, json=True,
                        stats=stats)
    text = "".join(t for k, t in notes if k == "print")
    return json.loads(text)


def run_job(path, *, memory: Optional[str] = None, threads: Optional[int] = None,
            dry_run: bool = False) -> List[str]:
    """Run the batch job ``path`` (``orogen run``: a TOML file of steps),
    resumable; returns its step lines (``dry_run``: the plan only)."""
    return list(_orogen.run_job(os.fspath(path), memory, threads, dry_run))
