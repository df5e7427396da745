#!/usr/bin/env python3
"""Issue 10's orometry check through the CLI, as a user runs it.

For each profile and seed: `orogen synth divide-tree` (the tree, JSON),
`orogen synth from-tree` (the default TIN render; to a GeoTIFF, or to a tile
store with --store), `orogen peaks` at the tree's prominence threshold
(tiled on the store), then the peak lists are compared: a tree peak above
the threshold is recovered if a peak is found within one cell of it; a found
peak with no tree peak within one cell is spurious. Also prints the largest
elevation and prominence differences of the recovered peaks.

    python3 tools/oro_roundtrip.py --bin target/release/orogen [--store] \
        [--seeds 1 2 3] [--work DIR]

Exit status 1 if more than --max-bad tree peaks are lost or peaks spurious
in all (the figures are printed either way). Measured (session 7, seeds
1-6, 600 x 600 at 30 m): 1 (Dallas seed 2 loses one peak); see
docs/notes/oro7.md.
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
    """Prominence of each tree peak: elevation minus the highest saddle on
    the way to any higher peak (the tree is small: a search per peak)."""
    n = len(tree["peaks"])
    adj = [[] for _ in range(n)]
    for s in tree["saddles"]:
        a, b = s["peaks"]
        adj[a].append((b, s["elevation"]))
        adj[b].append((a, s["elevation"]))
    z = [p["elevation"] for p in tree["peaks"]]
    top = max(range(n), key=lambda i: z[i])
    prom = []
    for i in range(n):
        if i == top:
            prom.append(z[i])
            continue
        best, seen, stack = float("-inf"), {i}, [(i, float("inf"))]
        while stack:
            v, low = stack.pop()
            for u, se in adj[v]:
                if u in seen:
                    continue
                seen.add(u)
                m = min(low, se)
                if z[u] > z[i]:
                    best = max(best, m)
                stack.append((u, m))
        prom.append(z[i] - best)
    return prom


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", default="target/release/orogen")
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--store", action="store_true", help="render to a tile store, peaks --tiled")
    ap.add_argument("--work", default=None)
    ap.add_argument("--max-bad", type=int, default=0)
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
            prom = tree_prominences(tree)
            tc = [(int(p["x"] // cell), int(p["y"] // cell), p["elevation"], prom[i])
                  for i, p in enumerate(tree["peaks"]) if prom[i] >= thr]
            found = []
            with open(os.path.join(pk, "peaks.csv")) as f:
                for r in csv.DictReader(f):
                    found.append((int(r["col"]), int(r["row"]), float(r["elevation"]), float(r["prominence"])))
            near = lambda p, q: abs(p[0] - q[0]) <= 1 and abs(p[1] - q[1]) <= 1
            lost = [p for p in tc if not any(near(p, q) for q in found)]
            spur = [q for q in found if not any(near(p, q) for p in tc)]
            dz = dp = 0.0
            for p in tc:
                q = next((q for q in found if near(p, q)), None)
                if q:
                    dz = max(dz, abs(q[2] - p[2]))
                    dp = max(dp, abs(q[3] - p[3]))
            print(f"{pj.get('label', prof)} seed {seed}: {len(tc)} tree peaks, {len(found)} found, "
                  f"{len(lost)} lost, {len(spur)} spurious; recovered peaks within "
                  f"{dz:.2f} m elevation, {dp:.2f} m prominence (threshold {thr} m)")
            bad += len(lost) + len(spur)
    print(f"total lost + spurious: {bad}")
    return 1 if bad > a.max_bad else 0


if __name__ == "__main__":
    sys.exit(main())
