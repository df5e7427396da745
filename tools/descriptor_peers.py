"""Compare orogen outputs with GRASS/SAGA ones written by descriptor_peers.sh.

For each pair: cells valid in both (a border of R+2 cells left out, where
edge rules differ), Pearson r, max and mean |difference| after the unit or
sign conversion noted, or the agreement rate for classes. Then the wall
times from times.txt as ratios to orogen's.

Each pair has a gate (minimum r, maximum p99 |d|, scale within a band, or a
minimum class agreement), set from the definitions where they are the same
(r.param.scale: equal to 1e-12) and a margin around the figures of
docs/PERFORMANCE.md where the peers define the quantity differently. A pair
past its gate, or a missing output, prints FAIL and the exit status is 1.
"""
import os
import sys

import numpy as np
from osgeo import gdal

from gates import Gates

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


gate = Gates()


def cmp(name, ours, theirs, conv=lambda x: x, note="", min_r=None, max_p99=None, max_abs=None, scale=None):
    """Prints the agreement of orogen's `ours` with the peer's `theirs` and
    gates it: r >= min_r, p99 |d| <= max_p99, max |d| <= max_abs, scale in
    the band (lo, hi)."""
    a, b = rd(f"{d}/o/{ours}"), rd(f"{d}/{theirs}")
    if a is None or b is None:
        print(f"{name:<44} missing output ({ours} / {theirs})" + gate(name, False, "missing output"))
        return
    b = conv(b)
    ok = np.isfinite(a) & np.isfinite(b)
    x, y = a[ok], b[ok]
    r = np.corrcoef(x, y)[0, 1] if x.size > 2 else float("nan")
    diff = np.abs(x - y)
    # Least-squares scale of the peer against orogen (1 = same units).
    k = float((x * y).sum() / (x * x).sum()) if (x * x).sum() > 0 else float("nan")
    p99 = float(np.percentile(diff, 99)) if x.size else float("nan")
    mx = float(diff.max()) if x.size else float("nan")
    verdict = gate(name, x.size > 1000, f"only {x.size} cells valid in both")
    if min_r is not None:
        verdict += gate(name, r >= min_r, f"r {r:.4f} < {min_r}")
    if max_p99 is not None:
        verdict += gate(name, p99 <= max_p99, f"p99|d| {p99:.4g} > {max_p99}")
    if max_abs is not None:
        verdict += gate(name, mx <= max_abs, f"max|d| {mx:.4g} > {max_abs}")
    if scale is not None:
        verdict += gate(name, scale[0] <= k <= scale[1], f"scale {k:.4g} outside {scale}")
    print(
        f"{name:<44} n={x.size:>7} r={r:+.4f} scale={k:.4g} max|d|={mx:.4g} "
        f"mean|d|={diff.mean():.4g} p99|d|={p99:.4g} {note}{verdict}"
    )


def agree(name, ours, theirs, note="", min_agreement=None):
    """Prints the share of cells in the same class and gates it (>= min_agreement)."""
    a, b = rd(f"{d}/o/{ours}"), rd(f"{d}/{theirs}")
    if a is None or b is None:
        print(f"{name:<44} missing output" + gate(name, False, "missing output"))
        return
    ok = np.isfinite(a) & np.isfinite(b)
    same = (a[ok] == b[ok]).mean() if ok.any() else float("nan")
    verdict = gate(name, ok.sum() > 1000, f"only {ok.sum()} cells valid in both")
    if min_agreement is not None:
        verdict += gate(name, same >= min_agreement, f"agreement {100 * same:.2f}% < {100 * min_agreement}%")
    print(f"{name:<44} n={ok.sum():>7} agreement={100 * same:.2f}% {note}{verdict}")


def closest(stem, ours, conv=lambda x: x, runs=9):
    """Of the peer's runs TMP/STEM{1..runs}.tif, the one closest to orogen's
    o/OURS (largest |difference|), written as TMP/STEM.tif; prints how many
    runs equal orogen's to 1e-12. The gate stays sound: a wrong orogen field
    equals none of GRASS's runs, right or wrong."""
    a = rd(f"{d}/o/{ours}")
    best, best_d, exact = None, float("inf"), 0
    for k in range(1, runs + 1):
        b = rd(f"{d}/{stem}{k}.tif")
        if a is None or b is None:
            continue
        ok = np.isfinite(a) & np.isfinite(b)
        dmax = float(np.abs(a[ok] - conv(b)[ok]).max()) if ok.any() else float("inf")
        exact += dmax <= 1e-12
        if dmax < best_d:
            best, best_d = k, dmax
    if best is None:
        return
    if exact < runs:
        print(f"  note: {exact} of {runs} GRASS runs of {stem} equal orogen's (GRASS's r.param.scale "
              f"is not deterministic here); taken: run {best}")
    os.replace(f"{d}/{stem}{best}.tif", f"{d}/{stem}.tif")


closest("g_profc", "profile_curvature.tif")
closest("g_planc", "plan_curvature.tif", lambda v: -v)
print("== agreement (orogen vs peer)")
# Central differences (GRASS) vs Evans's quadric (orogen): r 0.984/0.987, p99 0.0019/0.0023.
cmp("profile_curvature vs r.slope.aspect pcurv", "profile_curvature.tif", "g_pc.tif",
    note="(GRASS: 3x3 finite differences, convex positive)", min_r=0.975, max_p99=0.003, scale=(0.97, 1.10))
cmp("tangential_curvature vs r.slope.aspect tcurv", "tangential_curvature.tif", "g_tc.tif",
    min_r=0.975, max_p99=0.003, scale=(0.97, 1.10))
# Wood's quadric on 3x3 is Evans's: the same numbers.
cmp("profile_curvature vs r.param.scale profc", "profile_curvature.tif", "g_profc.tif",
    note="(Wood quadric on 3x3)", max_abs=1e-12)
cmp("plan_curvature vs r.param.scale planc", "plan_curvature.tif", "g_planc.tif",
    lambda v: -v, "(r.param.scale planc is concave-positive: sign flipped)", max_abs=1e-12)
# rule=grass: r.geomorphon 8's line rule, cut-off and edge ring (100.00 % of
# the cells compared on bigtujunga_srtm30m_utm11); the paper's rule (the
# default) differs near the flatness threshold (92.6 %).
agree("geomorphon rule=grass vs r.geomorphon", f"geomorphon_r{R}c_grass.tif", "g_gm.tif", min_agreement=0.99)
agree("geomorphon (paper's rule) vs r.geomorphon", f"geomorphon_r{R}c.tif", "g_gm.tif", min_agreement=0.91)
# SAGA interpolates along its rays, orogen samples whole cells: r 0.992, p99 3.3 deg.
cmp("openness vs SAGA positive openness (deg)", f"openness_r{R}c.tif", "s_pos.sdat",
    min_r=0.985, max_p99=4.5, scale=(0.96, 1.02))
cmp("openness_neg vs SAGA negative openness (deg)", f"openness_neg_r{R}c.tif", "s_neg.sdat",
    min_r=0.985, max_p99=4.5, scale=(0.96, 1.02))
# SAGA's sky-view factor adds the cell's own slope and aspect (Häntzschel et
# al. 2005); its visible sky (percent) is Zakšek et al.'s 1 − mean sin(horizon), as orogen's.
cmp("sky_view vs SAGA sky view factor", f"sky_view_r{R}c.tif", "s_svf.sdat", min_r=0.87)
cmp("sky_view vs SAGA visible sky (/100)", f"sky_view_r{R}c.tif", "s_vis.sdat", lambda v: v / 100.0,
    min_r=0.99, max_p99=0.12, scale=(1.0, 1.08))
# Weiss's TPI leaves the centre out (orogen), SAGA includes it: r 1.000, p99 0.2 m.
cmp("tpi:shape=disk vs SAGA TPI (circle)", f"tpi_r{R}c_disk.tif", "s_tpi.sdat",
    note="(orogen leaves the centre out of the mean)", min_r=0.9995, max_p99=0.3, scale=(0.99, 1.01))

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

sys.exit(gate.report("descriptor peers"))
