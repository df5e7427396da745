"""Shared fixtures: small DEMs, an ESRI ASCII writer (written here, sharing
no code with orogen's readers) and the built ``orogen`` binary."""

import os
import shutil
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]


def write_asc(path, z, cell=1.0, x0=0.0, y0=0.0, nodata=-9999.0):
    """An ESRI ASCII grid of ``z`` (rows north first); NaN cells are written
    as ``nodata``; ``(x0, y0)`` is the lower-left corner."""
    h, w = z.shape
    lines = [
        f"ncols {w}",
        f"nrows {h}",
        f"xllcorner {x0!r}",
        f"yllcorner {y0!r}",
        f"cellsize {cell!r}",
        f"NODATA_value {nodata!r}",
    ]
    for row in z:
        lines.append(" ".join(repr(float(nodata if np.isnan(v) else v)) for v in row))
    Path(path).write_text("\n".join(lines) + "\n")
    return str(path)


def orogen_bin():
    """The CLI binary: $OROGEN_BIN, else the worktree's release build, else
    its debug build; None when none is built."""
    env = os.environ.get("OROGEN_BIN")
    if env:
        return env
    for p in (ROOT / "target" / "release" / "orogen", ROOT / "target" / "debug" / "orogen"):
        if p.is_file():
            return str(p)
    return shutil.which("orogen")


@pytest.fixture
def cli():
    b = orogen_bin()
    if b is None:
        msg = "no orogen binary (cargo build --release, or set OROGEN_BIN): CLI comparison skipped"
        if os.environ.get("CI"):
            pytest.fail(msg)
        pytest.skip(msg)
    return b


@pytest.fixture
def rough_dem():
    """A 40 x 50 DEM: smooth hills plus noise, pits included (seeded)."""
    rng = np.random.default_rng(7)
    y, x = np.mgrid[0:40, 0:50].astype(np.float64)
    z = 100 + 20 * np.sin(x / 7.0) * np.cos(y / 5.0) + 3 * rng.standard_normal((40, 50))
    return z.astype(np.float32)
