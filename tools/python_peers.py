#!/usr/bin/env python3
"""orogen's Python package against the Python peers on the same numpy array.

Run it through the wrapper, which makes the venv and installs everything
from the registry (pysheds, xarray-spatial, py-richdem when it builds, and
the orogen wheel):

    bash tools/python_peers.sh --wheel python/target/wheels/orogen-*.whl

or, in a venv that already has them: ``python tools/python_peers.py``.

Input (default): a 2000 x 2000 crop (4 Mcells) of the real SRTM3 mosaic
``../shared/data/poland_N49-55_E014-025.tif`` (int16, 3", EPSG:4326) at
``--window 6200,5200,2000,2000`` -- the High Tatras (2 600 m) down to the
flats of the Nowy Targ and Orava basins, 42 SRTM void cells inside -- read
with ``orogen.open(...).read(window)`` as float32 with NaN for nodata. The
hydrology runs on the bare array (unit square cells, no transform) for every
tool; for slope both tools get the same nominal square cell of ``--cell``
metres (default 90; orogen ``transform=(0, c, 0, 0, 0, -c)`` with a
projected CRS, xarray-spatial ``attrs["res"] = (c, c)``), since
xarray-spatial's planar Horn slope takes one cell size.

Checks (each exits non-zero past its threshold):

* fill vs RichDEM ``FillDepressions(epsilon=False)``: RichDEM 0.3.4 treats
  NoData cells as ordinary low cells and fills them, orogen treats them as
  outlets. Threshold: 0 differing cells over the whole array between RichDEM
  and ``orogen.fill`` given the voids as the same low cells (-9999), and 0
  differing cells between RichDEM and the plain ``orogen.fill(dem)`` outside
  the cells that the nodata rule changes (those where orogen's fill with
  voids-as-low-cells differs from its fill with voids-as-nodata; counted).
* fill vs pysheds ``fill_depressions(fill_pits(dem))``: pysheds treats
  interior nodata as walls (never outlets). Threshold: 0 differing valid
  cells against ``orogen.fill`` given the voids as walls (+1e4), and the
  plain fill differing only on cells that rule changes.
* D8 accumulation: ``orogen.accumulate(orogen.flow(F))`` vs pysheds
  ``accumulation(flowdir(resolve_flats(F)))`` (ESRI dirmap) on the same
  filled DEM F = ``orogen.fill(dem)``. Directions on tie-free cells (one
  steepest lower neighbour; flats and ties are where each tool has its own
  rule): threshold >= 99.9 % equal. Accumulation on cells whose whole
  upstream area has the same direction in both tools (in either tool's
  graph): threshold 100 % equal (the same graph must give the same counts).
  Also printed: equality over all valid cells (no threshold; flats routed
  differently change whole subtrees).
* slope vs xarray-spatial ``slope`` (planar Horn, float32): threshold max
  |difference| <= 1e-4 degrees on interior cells (not on the edge, no
  nodata in the 3x3 window).

Timings: median of ``--repeat`` (3) calls of each function on the same
array in this run, after a warm-up on a small crop (numba's JIT for pysheds
and xarray-spatial is not timed), orogen with 1 thread and with all cores,
printed as a table with the ratios peer / orogen.
"""
import argparse
import os
import platform
import statistics
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DEFAULT_DEM = os.path.normpath(os.path.join(ROOT, "..", "shared", "data", "poland_N49-55_E014-025.tif"))
ND = -9999.0
ESRI = (64, 128, 1, 2, 4, 8, 16, 32)  # pysheds' dirmap order N, NE, E, SE, S, SW, W, NW
# ESRI codes and their (dy, dx)
OFFS = {1: (0, 1), 2: (1, 1), 4: (1, 0), 8: (1, -1), 16: (0, -1), 32: (-1, -1), 64: (-1, 0), 128: (-1, 1)}

failures = []


def check(name, ok, detail):
    print(f"  [{'ok' if ok else 'FAIL'}] {name}: {detail}")
    if not ok:
        failures.append(name)


class Quiet:
    """Silences file descriptor 2 (RichDEM's C++ progress lines)."""

    def __enter__(self):
        sys.stderr.flush()
        self.saved = os.dup(2)
        self.null = os.open(os.devnull, os.O_WRONLY)
        os.dup2(self.null, 2)

    def __exit__(self, *exc):
        os.dup2(self.saved, 2)
        os.close(self.saved)
        os.close(self.null)


def timed(fn, repeat):
    """Median wall time of `repeat` calls of `fn`, and the last result."""
    ts = []
    out = None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        ts.append(time.perf_counter() - t)
    return statistics.median(ts), out


def load(path, window):
    import orogen

    r = orogen.open(path)
    a = r.read(window)
    nd = r.nodata
    a = a.astype(np.float32)
    if nd is not None:
        a[a == np.float32(nd)] = np.nan
    return a


# ------------------------------------------------------------------ peers --

def richdem_fill(a):
    import richdem as rd

    r = rd.rdarray(np.where(np.isnan(a), ND, a).astype(np.float32), no_data=ND)
    r.geotransform = [0, 1, 0, 0, 0, -1]
    with Quiet():
        f = rd.FillDepressions(r, epsilon=False, in_place=False)
    return np.array(f, dtype=np.float32)


def pysheds_grid(a):
    from affine import Affine
    from pysheds.grid import Grid
    from pysheds.sview import Raster, ViewFinder

    vf = ViewFinder(affine=Affine(1.0, 0.0, 0.0, 0.0, -1.0, 0.0), shape=a.shape, nodata=ND)
    r = Raster(np.where(np.isnan(a), ND, a).astype(np.float64), viewfinder=vf)
    return Grid.from_raster(r), r


def pysheds_fill(a):
    g, r = pysheds_grid(a)
    f = np.array(g.fill_depressions(g.fill_pits(r)), dtype=np.float64)
    f[f == ND] = np.nan
    return f


def pysheds_flowdir(F):
    g, r = pysheds_grid(F)
    fd = g.flowdir(g.resolve_flats(r), dirmap=ESRI)
    return g, fd


def pysheds_accumulation(g, fd):
    return np.array(g.accumulation(fd, dirmap=ESRI), dtype=np.float64)


def xrspatial_slope(a, cell):
    import xarray as xr
    from xrspatial import slope

    h, w = a.shape
    da = xr.DataArray(a, dims=("y", "x"),
                      coords={"y": -(np.arange(h) + 0.5) * cell, "x": (np.arange(w) + 0.5) * cell},
                      attrs={"res": (float(cell), float(cell))})
    return np.asarray(slope(da).values)


# ----------------------------------------------------------------- checks --

def d8_tie_free(z):
    """Per cell: the ESRI code of the unique steepest lower neighbour on unit
    square cells (0 where there is none or several share the steepest drop),
    and the tie-free mask."""
    h, w = z.shape
    pad = np.full((h + 2, w + 2), np.nan)
    pad[1:-1, 1:-1] = z
    codes = list(OFFS)
    drops = np.full((8, h, w), -np.inf)
    for k, c in enumerate(codes):
        dy, dx = OFFS[c]
        nb = pad[1 + dy:1 + dy + h, 1 + dx:1 + dx + w]
        d = (z - nb) / (np.sqrt(2.0) if dx and dy else 1.0)
        drops[k] = np.where(np.isnan(nb), -np.inf, d)
    best = drops.max(axis=0)
    n_best = (drops == best[None]).sum(axis=0)
    free = (best > 0) & (n_best == 1) & ~np.isnan(z)
    code = np.where(free, np.array(codes)[drops.argmax(axis=0)], 0)
    return code, free


def receivers(codes):
    """Flat index of each cell's D8 receiver (-1: none, off the grid or not a
    direction code)."""
    h, w = codes.shape
    n = h * w
    recv = np.full(n, -1, dtype=np.int64)
    flat = codes.ravel()
    ys, xs = np.divmod(np.arange(n), w)
    for c, (dy, dx) in OFFS.items():
        m = flat == c
        ny, nx = ys[m] + dy, xs[m] + dx
        ok = (ny >= 0) & (ny < h) & (nx >= 0) & (nx < w)
        idx = np.nonzero(m)[0][ok]
        recv[idx] = ny[ok] * w + nx[ok]
    return recv


def downstream_closure(bad, recvs):
    """`bad` spread down every graph in `recvs` (cells with a bad cell
    anywhere upstream in any of them)."""
    b = bad.ravel().copy()
    front = np.nonzero(b)[0]
    while front.size:
        nxt = np.concatenate([r[front] for r in recvs])
        nxt = nxt[nxt >= 0]
        nxt = np.unique(nxt[~b[nxt]])
        b[nxt] = True
        front = nxt
    return b.reshape(bad.shape)


def interior_mask(a):
    """Cells off the edge whose whole 3x3 window is valid."""
    v = ~np.isnan(a)
    m = np.zeros_like(v)
    m[1:-1, 1:-1] = True
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            m[1:-1, 1:-1] &= v[1 + dy:v.shape[0] - 1 + dy, 1 + dx:v.shape[1] - 1 + dx]
    return m


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--dem", default=DEFAULT_DEM, help="a real DEM file (default: the Poland SRTM3 mosaic)")
    ap.add_argument("--window", default="6200,5200,2000,2000", help="col,row,width,height of the crop")
    ap.add_argument("--cell", type=float, default=90.0, help="square cell size in metres given to both slopes")
    ap.add_argument("--repeat", type=int, default=3, help="timed calls per function (median)")
    ap.add_argument("--require-richdem", action="store_true", help="fail when richdem is not importable")
    args = ap.parse_args()

    import orogen

    try:
        import richdem  # noqa: F401

        have_rd = True
    except ImportError as e:
        have_rd = False
        status = os.environ.get("PYTHON_PEERS_RICHDEM_STATUS")
        why = open(status).read().strip() if status and os.path.exists(status) else str(e)
        print(f"richdem NOT available, its checks and timings are skipped: {why}")
        if args.require_richdem:
            print("--require-richdem given: failing")
            return 2
    import pysheds
    import xrspatial

    window = tuple(int(v) for v in args.window.split(","))
    a = load(args.dem, window)
    valid = ~np.isnan(a)
    h, w = a.shape
    ncpu = os.cpu_count()
    vers = {"orogen": orogen.__version__, "numpy": np.__version__,
            "pysheds": getattr(pysheds, "__version__", "?"), "xarray-spatial": xrspatial.__version__}
    if have_rd:
        import importlib.metadata as md

        vers["richdem"] = md.version("richdem")
    print(f"DEM: {os.path.basename(args.dem)} window {window}: {w}x{h} = {w*h/1e6:.2f} Mcells, "
          f"{int((~valid).sum())} nodata, {np.nanmin(a):.0f}..{np.nanmax(a):.0f} m")
    print("versions: " + ", ".join(f"{k} {v}" for k, v in vers.items())
          + f"; Python {platform.python_version()}, {ncpu} cores, load average "
          + " ".join(f"{v:.2f}" for v in os.getloadavg()))

    # warm-up: numba JIT of pysheds and xarray-spatial, orogen's first call
    s = a[:64, :64].copy()
    orogen.accumulate(orogen.flow(orogen.fill(s)))
    orogen.slope(s, transform=(0, args.cell, 0, 0, 0, -args.cell), crs=32634)
    pf_s = pysheds_fill(s)
    g_s, fd_s = pysheds_flowdir(pf_s)
    pysheds_accumulation(g_s, fd_s)
    xrspatial_slope(s, args.cell)
    if have_rd:
        richdem_fill(s)

    rows = []  # (operation, t_orogen_1, t_orogen_all, peer, t_peer)
    R = args.repeat

    # ------------------------------------------------------------- fill --
    print("fill")
    t1, F = timed(lambda: orogen.fill(a, threads=1), R)
    tn, F2 = timed(lambda: orogen.fill(a), R)
    check("orogen fill: 1 thread == all threads", np.array_equal(F, F2, equal_nan=True), "bit for bit")
    low = orogen.fill(np.where(valid, a, ND).astype(np.float32))
    wall = orogen.fill(np.where(valid, a, 1e4).astype(np.float32))
    if have_rd:
        tp, rf = timed(lambda: richdem_fill(a), R)
        rows.append(("fill", t1, tn, "richdem FillDepressions(epsilon=False)", tp))
        d_all = int((rf != low).sum())
        check("fill == richdem, voids as the same low cells", d_all == 0,
              f"{d_all} of {w*h} cells differ (threshold 0; RichDEM fills its NoData cells as low cells)")
        changed = valid & (low != F)
        d_away = int((valid & ~changed & (rf != F)).sum())
        d_near = int((valid & changed & (rf != F)).sum())
        check("orogen.fill(dem) == richdem away from nodata", d_away == 0,
              f"{d_away} differ on the {int((valid & ~changed).sum())} valid cells the nodata rule does not "
              f"change (threshold 0); {d_near} differ on the {int(changed.sum())} it does "
              f"(orogen: nodata drains, RichDEM: nodata filled)")
    tp, pf = timed(lambda: pysheds_fill(a), R)
    rows.append(("fill", t1, tn, "pysheds fill_pits + fill_depressions", tp))
    d_wall = int((valid & (pf.astype(np.float32) != wall)).sum())
    check("fill == pysheds, voids as walls", d_wall == 0,
          f"{d_wall} of {int(valid.sum())} valid cells differ (threshold 0; pysheds never drains into interior nodata)")
    changed_w = valid & (wall != F)
    d_away = int((valid & ~changed_w & (pf.astype(np.float32) != F)).sum())
    check("orogen.fill(dem) == pysheds away from nodata", d_away == 0,
          f"{d_away} differ on the {int((valid & ~changed_w).sum())} valid cells the nodata rule does not change "
          f"(threshold 0); the rule changes {int(changed_w.sum())} cells")

    # ------------------------------------------------------------- D8 --
    print("D8 flow directions and accumulation on F = orogen.fill(dem)")
    tf1, dirs = timed(lambda: orogen.flow(F, threads=1), R)
    tfn, _ = timed(lambda: orogen.flow(F), R)
    ta1, acc = timed(lambda: orogen.accumulate(dirs, threads=1), R)
    tan, _ = timed(lambda: orogen.accumulate(dirs), R)
    tpf, (g, fd) = timed(lambda: pysheds_flowdir(F), R)
    tpa, pacc = timed(lambda: pysheds_accumulation(g, fd), R)
    rows.append(("flow (D8)", tf1, tfn, "pysheds resolve_flats + flowdir", tpf))
    rows.append(("accumulate (D8)", ta1, tan, "pysheds accumulation", tpa))
    rows.append(("flow + accumulate", tf1 + ta1, tfn + tan, "pysheds resolve_flats + flowdir + accumulation",
                 tpf + tpa))
    oc = np.asarray(dirs).astype(np.int64)
    pc = np.asarray(fd).astype(np.int64)
    code, free = d8_tie_free(F.astype(np.float64))
    if not free.any():
        check("the DEM has tie-free cells", False, "none (all flat?): choose another --window")
        free[:] = False
    own = float((oc[free] == code[free]).mean()) if free.any() else float("nan")
    check("orogen D8 == unique steepest descent on tie-free cells", own >= 0.999,
          f"{own*100:.3f} % of {int(free.sum())} tie-free cells (threshold >= 99.9 %)")
    rate = float((oc[free] == pc[free]).mean()) if free.any() else float("nan")
    off = free & (oc != pc)
    near_nd = off & ~interior_mask(np.where(valid, 0.0, np.nan))  # on the edge or next to nodata
    check("D8 directions == pysheds on tie-free cells", rate >= 0.999,
          f"{rate*100:.3f} % of {int(free.sum())} tie-free cells (threshold >= 99.9 %); of the "
          f"{int(off.sum())} that differ, {int(near_nd.sum())} touch nodata or the edge "
          f"(pysheds' flowdir drains into nodata, orogen's tie-free steepest descent ignores it)")
    same_all = valid & (oc == pc)
    print(f"  directions equal on {same_all[valid].mean()*100:.2f} % of all {int(valid.sum())} valid cells "
          f"(no threshold: flats and edges have each tool's own rule)")
    oacc = np.asarray(acc, dtype=np.float64)
    pacc = np.where(valid, pacc, np.nan)
    differ_dir = valid & (oc != pc)
    clean = ~downstream_closure(differ_dir | ~valid, [receivers(oc), receivers(pc)]) & valid
    eq_clean = float((oacc[clean] == pacc[clean]).mean()) if clean.any() else float("nan")
    check("D8 accumulation == pysheds where the whole upstream area has the same directions", eq_clean == 1.0,
          f"{eq_clean*100:.4f} % of {int(clean.sum())} cells ({clean[valid].mean()*100:.2f} % of the valid cells; "
          f"threshold 100 %)")
    eq_all = float((oacc[valid] == pacc[valid]).mean())
    print(f"  accumulation equal on {eq_all*100:.2f} % of all valid cells (no threshold); "
          f"max {np.nanmax(oacc):.0f} (orogen) vs {np.nanmax(pacc):.0f} (pysheds)")

    # ----------------------------------------------------------- slope --
    print(f"slope (Horn, degrees, square {args.cell:g} m cells)")
    tr = (0.0, args.cell, 0.0, 0.0, 0.0, -args.cell)
    ts1, so = timed(lambda: orogen.slope(a, transform=tr, crs=32634, threads=1), R)
    tsn, _ = timed(lambda: orogen.slope(a, transform=tr, crs=32634), R)
    tpx, sx = timed(lambda: xrspatial_slope(a, args.cell), R)
    rows.append(("slope", ts1, tsn, "xarray-spatial slope (planar)", tpx))
    inner = interior_mask(a)
    both = inner & np.isfinite(so) & np.isfinite(sx)
    dmax = float(np.abs(so[both].astype(np.float64) - sx[both]).max())
    check("slope == xarray-spatial on interior cells", dmax <= 1e-4 and both.sum() == inner.sum(),
          f"max |diff| {dmax:.2e} deg over {int(both.sum())} of {int(inner.sum())} interior cells "
          f"(threshold 1e-4 deg); slopes up to {np.nanmax(so):.1f} deg")

    # ---------------------------------------------------------- table --
    print()
    print(f"Python: orogen vs pysheds / xarray-spatial / richdem on the same numpy array "
          f"({w}x{h} = {w*h/1e6:.2f} Mcells, median of {R}, seconds)")
    print()
    print(f"| operation | orogen 1 thread | orogen {ncpu} threads | peer | peer | peer / orogen 1 thr | "
          f"peer / orogen {ncpu} thr |")
    print("|---|---|---|---|---|---|---|")
    for op, o1, on, peer, tp in rows:
        print(f"| {op} | {o1:.3f} | {on:.3f} | {peer} | {tp:.3f} | {tp / o1:.2f}x | {tp / on:.2f}x |")
    print()
    if failures:
        print(f"FAILED: {len(failures)} check(s): " + "; ".join(failures))
        return 1
    print("load average at the end: " + " ".join(f"{v:.2f}" for v in os.getloadavg()))
    print("all checks passed" + ("" if have_rd else " (richdem skipped)"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
