#!/usr/bin/env python3
"""Check `orogen demo`'s outputs by their values, with GDAL and numpy only.

Usage:  python3 tools/demo_check.py DEMO_DIR   (the folder `orogen demo -o` wrote)

Oracles that share no code with orogen:
  - slope, aspect and hillshade against `gdaldem` (Horn's kernel, light
    from 315 deg at 45 deg) on terrain.tif, interior cells;
  - filled.tif: >= terrain.tif everywhere and no pit (every interior cell
    has a neighbour at or below it, so every cell drains to the border);
  - flow_d8.tif: every code one of the 8 ESRI codes, pointing to a
    neighbour no higher in filled.tif, and off the grid only at the border;
  - accumulation.tif: each cell = 1 + the sum over the cells whose code
    points at it, accumulated here in topological (Kahn) order;
  - preview.png: RGBA of the terrain's width, opaque over the terrain, and
    its luminance follows hillshade.tif (correlation > 0.5).
Prints one line per check and exits 1 if any fails.
"""
import os
import subprocess
import sys
import tempfile

import numpy as np
from osgeo import gdal

CODES = [1, 2, 4, 8, 16, 32, 64, 128]
OFFS = [(0, 1), (1, 1), (1, 0), (1, -1), (0, -1), (-1, -1), (-1, 0), (-1, 1)]  # (dy, dx)
fails = []


def read(path, band=1):
    ds = gdal.Open(path)
    b = ds.GetRasterBand(band)
    a = b.ReadAsArray().astype(np.float64)
    nd = b.GetNoDataValue()
    if nd is not None:
        a[a == nd] = np.nan
    return a


def check(name, ok, detail):
    print(f"{'PASS' if ok else 'FAIL'}: {name}: {detail}")
    if not ok:
        fails.append(name)


def main(d):
    z = read(f"{d}/terrain.tif")
    h, w = z.shape
    inner = np.zeros((h, w), bool)
    inner[1:-1, 1:-1] = True
    with tempfile.TemporaryDirectory() as tmp:
        for what, args in [
            ("slope", ["slope", "-alg", "Horn"]),
            ("aspect", ["aspect", "-alg", "Horn"]),
            ("hillshade", ["hillshade", "-alg", "Horn", "-az", "315", "-alt", "45"]),
        ]:
            out = os.path.join(tmp, f"{what}.tif")
            subprocess.run(["gdaldem", *args[:1], f"{d}/terrain.tif", out, *args[1:], "-q"], check=True)
            g, o = read(out), read(f"{d}/{what}.tif")
            m = inner & np.isfinite(g) & np.isfinite(o)
            if what == "aspect":
                # gdaldem writes -9999 on flat cells, and works in float32: its
                # aspect wanders by ~0.01 deg / slope (deg) on gentle ground, so
                # compare where the slope is at least 1 deg
                m &= (g >= 0) & (o >= 0) & (read(f"{d}/slope.tif") >= 1.0)
                diff = np.abs((o - g + 180.0) % 360.0 - 180.0)
                tol = 0.02
            elif what == "hillshade":
                diff = np.abs(o - g)
                tol = 1.0  # both bytes: rounding may differ by one
            else:
                diff = np.abs(o - g)
                tol = 1e-3
            mx = float(diff[m].max()) if m.any() else float("nan")
            check(f"{what} vs gdaldem", m.sum() > 0.5 * inner.sum() and mx <= tol,
                  f"max |d| {mx:.3g} on {int(m.sum())} interior cells (tolerance {tol})")

    f = read(f"{d}/filled.tif")
    check("filled >= terrain", bool(np.all(f >= z - 1e-6)), f"min(filled - terrain) = {np.nanmin(f - z):.3g}")
    pad = np.full((h + 2, w + 2), np.inf)
    pad[1:-1, 1:-1] = f
    lowest = np.min([pad[1 + dy:1 + dy + h, 1 + dx:1 + dx + w] for dy, dx in OFFS], axis=0)
    pits = int((inner & (lowest > f)).sum())
    check("filled has no pit", pits == 0, f"{pits} interior cells above all their neighbours' lowest")

    c = read(f"{d}/flow_d8.tif")
    ok_code = np.isin(np.nan_to_num(c, nan=-1), CODES)
    recv = np.full(h * w, -1, dtype=np.int64)
    bad_dir = 0
    ys, xs = np.divmod(np.arange(h * w), w)
    flat_c = c.ravel()
    for k, code in enumerate(CODES):
        sel = flat_c == code
        dy, dx = OFFS[k]
        ny, nx = ys[sel] + dy, xs[sel] + dx
        on = (ny >= 0) & (ny < h) & (nx >= 0) & (nx < w)
        idx = np.nonzero(sel)[0]
        recv[idx[on]] = ny[on] * w + nx[on]
        inside = idx[on]
        bad_dir += int((f.ravel()[recv[inside]] > f.ravel()[inside] + 1e-6).sum())
        # leaving the grid only from a border cell
        bad_dir += int((~on & inner.ravel()[idx]).sum())
    check("flow_d8 codes", bool(ok_code.all()) and bad_dir == 0,
          f"{int((~ok_code).sum())} cells without an ESRI code, {bad_dir} pointing uphill or off the grid from inside")

    acc = read(f"{d}/accumulation.tif").ravel()
    want = np.ones(h * w)
    # Kahn's order: a cell is passed on once all its donors have been
    indeg = np.bincount(recv[recv >= 0], minlength=h * w)
    stack = list(np.nonzero(indeg == 0)[0])
    while stack:
        i = stack.pop()
        r = recv[i]
        if r >= 0:
            want[r] += want[i]
            indeg[r] -= 1
            if indeg[r] == 0:
                stack.append(r)
    diff = int((acc != want).sum())
    check("accumulation = 1 + upstream", diff == 0, f"{diff} cells differ from the sum over their D8 donors")

    p = gdal.Open(f"{d}/preview.png")
    bands = [p.GetRasterBand(k + 1).ReadAsArray().astype(np.float64) for k in range(p.RasterCount)]
    size_ok = p.RasterCount == 4 and p.RasterXSize == w and p.RasterYSize >= h
    check("preview size", size_ok, f"{p.RasterXSize}x{p.RasterYSize}, {p.RasterCount} bands (terrain {w}x{h})")
    if size_ok:
        alpha = bands[3][:h]
        check("preview opaque over the terrain", bool((alpha == 255).all()),
              f"{int((alpha != 255).sum())} transparent pixels")
        lum = 0.299 * bands[0][:h] + 0.587 * bands[1][:h] + 0.114 * bands[2][:h]
        hs = read(f"{d}/hillshade.tif")
        m = inner & np.isfinite(hs)
        r = float(np.corrcoef(lum[m], hs[m])[0, 1])
        check("preview shaded by the hillshade", r > 0.5, f"corr(luminance, hillshade) {r:.3f}")
    return 1 if fails else 0


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    sys.exit(main(sys.argv[1]))
