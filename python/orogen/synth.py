"""Terrain synthesis (``orogen synth ...``), as arrays or files.

``noise`` runs tile by tile into an array or a file; the other methods
(rivers, tectonic, orometric, from a divide tree, the region profile and
divide tree of an exemplar, example-based optimisation) run as the CLI
does, their options the CLI's long options with ``_`` for ``-``
(``orogen synth <method> --help``), raster options given as arrays or
paths.
"""

from __future__ import annotations

import os
import tempfile
from typing import Any, Dict, Optional, Tuple, Union

from . import _orogen


def noise(
    size: Union[int, Tuple[int, int], str] = 1024,
    *,
    cell: float = 30.0,
    output: Any = None,
    memory: Optional[str] = None,
    tile: Optional[int] = None,
    threads: int = 0,
    format: Optional[Dict[str, Any]] = None,
    progress: Any = None,
    **params: Any,
) -> Any:
    """Procedural terrain (``orogen synth noise``): fBm, ridged multifractal
    (Musgrave 1989), domain-warped blends, diamond-square (Fournier, Fussell
    & Carpenter 1982) or spectral synthesis, generated tile by tile, the same
    bytes as the CLI for the same parameters. ``size`` is cells (``n``,
    ``(width, height)`` or ``"WxH"``); ``cell`` the cell size in metres;
    ``params`` the CLI's noise options with ``_`` for ``-`` (``kind``,
    ``seed``, ``octaves``, ``lacunarity``, ``gain``, ``wavelength``,
    ``base``, ``amplitude``, ``ridge_offset``, ``ridge_gain``, ``warp``,
    ``blend``, ``beta``), each defaulting as ``orogen synth noise --help``
    says. Returns a float32 array (rows north first), or with ``output`` a
    :class:`orogen.Raster` of the written file.

    >>> import orogen
    >>> z = orogen.synth.noise(64, seed=7, amplitude=500.0)
    >>> z.shape, str(z.dtype)
    ((64, 64), 'float32')
    >>> bool((orogen.synth.noise(64, seed=7, amplitude=500.0) == z).all())
    True
    """
    from . import _json, _progress, _run_settings, _to_array, open as _open

    if isinstance(size, tuple):
        size = f"{size[0]}x{size[1]}"
    opts: Dict[str, Any] = {"size": str(size), "cell": float(cell)}
    for k, v in params.items():
        opts[k.replace("_", "-")] = v
    run = _run_settings(memory, tile, threads)
    fmt = _json(format or {})
    if output is not None:
        out = os.fspath(output)
        _orogen.synth_noise(_json(opts), run, fmt, out, None, _progress(progress))
        return _open(out)
    with tempfile.TemporaryDirectory(prefix="orogen-") as scratch:
        flat, w, h, g = _orogen.synth_noise(_json(opts), run, fmt, None, scratch, _progress(progress))
    return _to_array(flat, w, h, g.get("nodata"))


def _raster(method: str, inputs, output, progress, options):
    from ._commands import _raster_command

    return _raster_command(f"synth {method}", inputs, output, progress, None, None, None, options)


def _files(method: str, inputs, output, progress, options):
    from ._commands import _files_command

    return _files_command(f"synth {method}", inputs, output, progress, None, None, None, options)


def tectonic(map, *, output=None, progress=None, **options):  # noqa: A002 (the CLI's name)
    """Tectonic terrain (``orogen synth tectonic``; Cortial et al. 2019):
    ``map`` a GeoJSON path of coastline polygons, river lines and peak
    points (``configs/tectonic-map.geojson`` is an example); plates,
    velocities and folds from it, rivers cut in, optional hydraulic erosion
    (``erode_steps``). Returns a float32 array, or with ``output`` an
    :class:`orogen.Raster`."""
    options["map"] = os.fspath(map)
    return _raster("tectonic", [], output, progress, options)


def rivers(*, output=None, progress=None, **options):
    """Terrain from a river network (``orogen synth rivers``; Génevaux et
    al. 2013): the network grown from the outlets, the terrain raised from
    it. Returns a float32 array, or with ``output`` an :class:`orogen.Raster`."""
    return _raster("rivers", [], output, progress, options)


def orometric(profile, *, output=None, progress=None, **options):
    """Terrain from a region profile (``orogen synth orometric``; Argudo et
    al. 2019 §6): a divide tree synthesised to the profile's statistics,
    then terrain from it. ``profile`` a JSON path (from :func:`profile`)."""
    options["profile"] = profile
    return _raster("orometric", [], output, progress, options)


def from_tree(tree, *, output=None, progress=None, **options):
    """Terrain from a divide tree (``orogen synth from-tree``; Argudo et al.
    2019 §6): ``tree`` a JSON path from :func:`divide_tree` (edited or
    not)."""
    return _raster("from-tree", [tree], output, progress, options)


def profile(dem, *, output, progress=None, **options):
    """The region profile of an exemplar DEM (``orogen synth profile``): the
    orometric statistics :func:`orometric` and :func:`divide_tree` follow,
    written to the JSON ``output``. Returns the paths written."""
    return _files("profile", [dem], output, progress, options)


def divide_tree(profile, *, output, progress=None, **options):  # noqa: A002
    """A synthetic divide tree following a region profile (``orogen synth
    divide-tree``), written to the JSON ``output``."""
    options["profile"] = profile
    return _files("divide-tree", [], output, progress, options)


def optimise(source, guide, *, output=None, progress=None, **options):
    """Example-based synthesis (``orogen synth optimise``): the ``guide``
    terrain re-synthesised from patches of the exemplar ``source``, pits
    removed (Gain-pit). Returns a float32 array, or with ``output`` an
    :class:`orogen.Raster`."""
    options["source"] = source
    options["guide"] = guide
    return _raster("optimise", [], output, progress, options)
