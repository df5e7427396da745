#!/usr/bin/env python3
"""Issue 10's orometry check through the CLI, as a user runs it.

For each profile and seed: `orogen synth divide-tree` (the tree, JSON),
`orogen synth from-tree` (the default TIN render; to a GeoTIFF, or to a tile
store with --store), `orogen peaks` at the tree's prominence threshold
(tiled on the store), then the peak lists are compared: a tree peak above
the threshold is recovered if a peak is found within one cell of it; a found
peak with no tree peak within one cell is spurious; a recovered peak's key
saddle is off if it is more than one cell (Chebyshev) from the tree's key
saddle or more than the noise bound (half the threshold) from its elevation.
Also prints the largest elevation, prominence and key-saddle differences.

    python3 tools/oro_roundtrip.py --bin target/release/orogen [--store] \
        [--seeds 1 2 3] [--work DIR]

Exit status 1 if more than --max-bad tree peaks are lost, peaks spurious,
key saddles off or recovered peaks off the tree's elevation or prominence
by more than --max-dz (0.01 m) in all (the figures are printed either way). Measured
(seeds 1-6, 600 x 600 at 30 m, GeoTIFF and tile store): 0; every
key saddle within one cell and 0.00 m (an earlier build: 1 lost); see
docs/design/orometric-synthesis.md#ridge-clearance-clearancers.
"""
import argparse
import csv
import json
import os
import subprocess
import sys
import tempfile

PROFILES = ["configs/profiles/alps_montblanc.json", "configs/profiles/lowrelief_dallas.json"]


def run(cmd):
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)


def tree_prominences(tree):
    """Prominence and key saddle (index, None for the highest peak) of each
    tree peak: elevation minus the highest saddle on the way to any higher
    peak (the tree is small: a search per peak)."""
    n = len(tree["peaks"])
    adj = [[] for _ in range(n)]
    for k, s in enumerate(tree["saddles"]):
        a, b = s["peaks"]
        adj[a].append((b, k))
        adj[b].append((a, k))
    z = [p["elevation"] for p in tree["peaks"]]
    zs = [s["elevation"] for s in tree["saddles"]]
    top = max(range(n), key=lambda i: z[i])
    prom, keys = [], []
    for i in range(n):
        if i == top:
            prom.append(z[i])
            keys.append(None)
            continue
        best, bk, seen, stack = float("-inf"), None, {i}, [(i, float("inf"), None)]
        while stack:
            v, low, lk = stack.pop()
            for u, k in adj[v]:
                if u in seen:
                    continue
                seen.add(u)
                m, mk = (low, lk) if low <= zs[k] else (zs[k], k)
                if z[u] > z[i] and m > best:
                    best, bk = m, mk
                stack.append((u, m, mk))
        prom.append(z[i] - best)
        keys.append(bk)
    return prom, keys


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", default="target/release/orogen")
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--store", action="store_true", help="render to a tile store, peaks --tiled")
    ap.add_argument("--work", default=None)
    ap.add_argument("--max-bad", type=int, default=0)
    ap.add_argument("--max-dz", type=float, default=0.01,
                    help="a recovered peak whose elevation or prominence differs from the tree's by more (m) is off")
    a = ap.parse_args()
    work = a.work or tempfile.mkdtemp(prefix="oro_roundtrip_")
    bad = 0
    for prof in PROFILES:
        for seed in a.seeds:
            d = os.path.join(work, f"{os.path.basename(prof)[:-5]}_{seed}")
            os.makedirs(d, exist_ok=True)
            tpath = os.path.join(d, "tree.json")
            with open(prof) as f:
                pj = json.load(f)
            # The profile's DEM size and cell (the size the tests use).
            run([a.bin, "synth", "divide-tree", "--profile", prof, "--size", "600x600",
                 "--cell", "30", "--seed", str(seed), "-o", tpath])
            out = os.path.join(d, "terrain.tiles" if a.store else "terrain.tif")
            run([a.bin, "synth", "from-tree", tpath, "-q", "-o", out])
            with open(tpath) as f:
                tree = json.load(f)
            thr = tree["min_prominence"]
            pk = os.path.join(d, "peaks")
            cmd = [a.bin, "peaks", out, "--min-prominence", str(thr), "--no-isolation", "-q", "-o", pk]
            if a.store:
                cmd.append("--tiled")
            run(cmd)
            cell, h = tree["cell"], tree["height"]
            prom, keys = tree_prominences(tree)
            tc = [(int(p["x"] // cell), int(p["y"] // cell), p["elevation"], prom[i], keys[i])
                  for i, p in enumerate(tree["peaks"]) if prom[i] >= thr]
            found = []
            with open(os.path.join(pk, "peaks.csv")) as f:
                for r in csv.DictReader(f):
                    # The key saddle's cell (georeferenced centre, y up).
                    sad = None
                    if r["saddle_x"]:
                        sad = (float(r["saddle_x"]) / cell - 0.5, h - float(r["saddle_y"]) / cell - 0.5,
                               float(r["saddle_elevation"]))
                    found.append((int(r["col"]), int(r["row"]), float(r["elevation"]),
                                  float(r["prominence"]), sad))
            near = lambda p, q: abs(p[0] - q[0]) <= 1 and abs(p[1] - q[1]) <= 1
            lost = [p for p in tc if not any(near(p, q) for q in found)]
            spur = [q for q in found if not any(near(p, q) for p in tc)]
            # Saddles: each recovered peak's key saddle within one cell of
            # the tree's and within the noise bound (half the threshold) of
            # its elevation.
            dz = dp = ds = dsz = 0.0
            far = heights_off = 0
            for p in tc:
                q = next((q for q in found if near(p, q)), None)
                if q:
                    dz = max(dz, abs(q[2] - p[2]))
                    dp = max(dp, abs(q[3] - p[3]))
                    if abs(q[2] - p[2]) > a.max_dz or abs(q[3] - p[3]) > a.max_dz:
                        heights_off += 1
                    if p[4] is not None and q[4] is not None:
                        ts = tree["saddles"][p[4]]
                        # Saddles of equal elevation on the key path tie:
                        # any tree saddle at the key saddle's elevation counts.
                        d = min(max(abs(q[4][0] - int(s["x"] // cell)), abs(q[4][1] - int(s["y"] // cell)))
                                for s in tree["saddles"] if abs(s["elevation"] - ts["elevation"]) <= 1e-3)
                        e = abs(q[4][2] - ts["elevation"])
                        ds, dsz = max(ds, d), max(dsz, e)
                        if d > 1.0 + 1e-9 or e > 0.5 * thr:
                            far += 1
                    elif (p[4] is None) != (q[4] is None):
                        far += 1
            print(f"{pj.get('label', prof)} seed {seed}: {len(tc)} tree peaks, {len(found)} found, "
                  f"{len(lost)} lost, {len(spur)} spurious, {far} key saddles off, {heights_off} peaks' heights off; "
                  f"recovered peaks within "
                  f"{dz:.2f} m elevation, {dp:.2f} m prominence, key saddles within {ds:.1f} cells "
                  f"and {dsz:.2f} m (threshold {thr} m)")
            bad += len(lost) + len(spur) + far + heights_off
    print(f"total lost + spurious + key saddles off + heights off: {bad}")
    return 1 if bad > a.max_bad else 0


if __name__ == "__main__":
    sys.exit(main())
