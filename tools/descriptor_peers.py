"""Compare orogen outputs with GRASS/SAGA ones written by descriptor_peers.sh.

For each pair: cells valid in both (a border of R+2 cells left out, where
edge rules differ), Pearson r, max and mean |difference| after the unit or
sign conversion noted, or the agreement rate for classes. Then the wall
times from times.txt as ratios to orogen's.
"""
import os
import sys

import numpy as np
from osgeo import gdal

d, R = sys.argv[1], int(sys.argv[2])


def rd(p):
    if not os.path.exists(p):
        return None
    ds = gdal.Open(p)
    b = ds.GetRasterBand(1)
    a = b.ReadAsArray().astype(np.float64)
    nd = b.GetNoDataValue()
    if nd is not None:
        a[a == nd] = np.nan
    a[~np.isfinite(a)] = np.nan
    m = R + 2
    a[:m, :] = np.nan
    a[-m:, :] = np.nan
    a[:, :m] = np.nan
    a[:, -m:] = np.nan
    return a


def cmp(name, ours, theirs, conv=lambda x: x, note=""):
    a, b = rd(f"{d}/o/{ours}"), rd(f"{d}/{theirs}")
    if a is None or b is None:
        print(f"{name:<44} missing output ({ours} / {theirs})")
        return
    b = conv(b)
    ok = np.isfinite(a) & np.isfinite(b)
    x, y = a[ok], b[ok]
    r = np.corrcoef(x, y)[0, 1] if x.size > 2 else float("nan")
    diff = np.abs(x - y)
    # Least-squares scale of the peer against orogen (1 = same units).
    k = float((x * y).sum() / (x * x).sum()) if (x * x).sum() > 0 else float("nan")
    print(
        f"{name:<44} n={x.size:>7} r={r:+.4f} scale={k:.4g} max|d|={diff.max():.4g} "
        f"mean|d|={diff.mean():.4g} p99|d|={np.percentile(diff, 99):.4g} {note}"
    )


def agree(name, ours, theirs, note=""):
    a, b = rd(f"{d}/o/{ours}"), rd(f"{d}/{theirs}")
    if a is None or b is None:
        print(f"{name:<44} missing output")
        return
    ok = np.isfinite(a) & np.isfinite(b)
    same = (a[ok] == b[ok]).mean()
    print(f"{name:<44} n={ok.sum():>7} agreement={100 * same:.2f}% {note}")


print("== agreement (orogen vs peer)")
cmp("profile_curvature vs r.slope.aspect pcurv", "profile_curvature.tif", "g_pc.tif",
    note="(GRASS: 3x3 finite differences, convex positive)")
cmp("tangential_curvature vs r.slope.aspect tcurv", "tangential_curvature.tif", "g_tc.tif")
cmp("profile_curvature vs r.param.scale profc", "profile_curvature.tif", "g_profc.tif",
    note="(Wood quadric on 3x3)")
cmp("plan_curvature vs r.param.scale planc", "plan_curvature.tif", "g_planc.tif",
    lambda v: -v, "(r.param.scale planc is concave-positive: sign flipped)")
agree("geomorphon vs r.geomorphon", f"geomorphon_r{R}c.tif", "g_gm.tif")
cmp("openness vs SAGA positive openness (deg)", f"openness_r{R}c.tif", "s_pos.sdat")
cmp("openness_neg vs SAGA negative openness (deg)", f"openness_neg_r{R}c.tif", "s_neg.sdat")
cmp("sky_view vs SAGA sky view factor", f"sky_view_r{R}c.tif", "s_svf.sdat")
cmp("tpi:shape=disk vs SAGA TPI (circle)", f"tpi_r{R}c_disk.tif", "s_tpi.sdat",
    note="(orogen leaves the centre out of the mean)")

print("== wall times (s) and ratio peer / orogen")
t = {}
for line in open(f"{d}/times.txt"):
    k, v = line.split()
    t[k] = float(v)
pairs = [("grass:curvatures", "curvatures"), ("grass:param_scale", "curvatures"),
         ("grass:geomorphon", "geomorphon"), ("saga:openness", "openness"),
         ("saga:sky_view", "sky_view"), ("saga:tpi", "tpi")]
for peer, ours in pairs:
    o1, o0 = t.get(f"orogen_t1:{ours}"), t.get(f"orogen_t0:{ours}")
    p = t.get(peer)
    if None in (o1, o0, p):
        continue
    print(f"{peer:<20} {p:8.3f} s   orogen 1 thread {o1:7.3f} s (x{p / o1:6.2f})   all cores {o0:7.3f} s (x{p / o0:6.2f})")
