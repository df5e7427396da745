"""Terrain synthesis (``orogen synth ...``), as arrays or files.

``noise`` is here; the other methods (rivers, tectonic, orometric, from a
divide tree) are reached through the CLI or a job for now.
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
    from . import _json, _run_settings, _to_array, open as _open

    if isinstance(size, tuple):
        size = f"{size[0]}x{size[1]}"
    opts: Dict[str, Any] = {"size": str(size), "cell": float(cell)}
    for k, v in params.items():
        opts[k.replace("_", "-")] = v
    run = _run_settings(memory, tile, threads)
    fmt = _json(format or {})
    if output is not None:
        out = os.fspath(output)
        _orogen.synth_noise(_json(opts), run, fmt, out, None)
        return _open(out)
    with tempfile.TemporaryDirectory(prefix="orogen-") as scratch:
        flat, w, h, g = _orogen.synth_noise(_json(opts), run, fmt, None, scratch)
    return _to_array(flat, w, h, g.get("nodata"))
