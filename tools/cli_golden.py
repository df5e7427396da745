#!/usr/bin/env python3
"""The bytes of every CLI output, recorded once and compared after each change.

A fixed list of commands covers every subcommand of `orogen` on the small real
DEMs in tests/data (tiled runs with odd work-tile sizes where the command tiles).
`--record` writes the sha256 of each output file to tests/golden/cli_outputs.sha256;
the default (`--check`) reruns the list and fails naming every output whose bytes
changed, vanished or appeared. A change that is meant is recorded again, and its
reason stated in the commit that records it.

Outputs that are not a function of the input (timings, wall-clock dates in job
logs and reports) are listed in SKIP and not hashed; the command still has to
succeed.

    python3 tools/cli_golden.py --bin target/release/orogen            # check
    python3 tools/cli_golden.py --bin target/release/orogen --record   # record
"""
import argparse
import hashlib
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import fixtures

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "tests" / "data"
GOLDEN = ROOT / "tests" / "golden" / "cli_outputs.sha256"

# Inputs are named relative to the work folder (links `data` -> tests/data and
# `configs` -> configs), so outputs that record their inputs' paths (store
# manifests, profiles) do not depend on where the repository sits.
WB = "data/whitebox_DEM.tif"  # 237 x 188 float32, local CRS, nodata
BT = "data/bigtujunga_crop.tif"  # 301 x 203 int16, UTM 11N
ASC = "data/landlab_SRTMGL3_frontrange.asc"  # 240 x 144, geographic
VOIDS = "data/hydro/srtm3_N46E008_voids_crop.tif"  # 300 x 300 int16, geographic, SRTM voids
ALPS = "data/oro/terraindescriptors_alps_montblanc.tif"
SRTM46 = "data/oro/srtm3_N46E008_crop.tif"  # 300 x 300 int16, EPSG:4326, voids
TREE = "data/oro/crossing_ridges_tree.json"
TECTONIC_MAP = "configs/tectonic-map.geojson"

# Files whose bytes carry time or machine state, not results (name patterns).
SKIP = (
    "report.html",  # step timings and peak memory
    ".orogen-state.json",  # fingerprints with input modification times
    "job.jsonl",  # the job log: timestamps and durations
    "cost.csv",  # metric table: timings relative to slope
    "cost.md",
    ".orogen-job.json",  # job state: step durations and peak memory
)

# (name, argv after the binary, outputs relative to the work folder).
# Names are stable keys in the golden file; commands run in order, and later
# ones may read earlier outputs.
Q = ["-q"]
COMMANDS = [
    ("info", ["info", BT, "--json", "--stats"], ["@stdout"]),
    ("info_asc", ["info", ASC], ["@stdout"]),
    ("ingest", ["ingest", WB, "-o", "wb.tiles", "--store-tile", "50"] + Q, ["wb.tiles"]),
    ("export", ["export", "wb.tiles", "-o", "wb.tif"] + Q, ["wb.tif"]),
    ("export_cog", ["export", BT, "-o", "bt_cog.tif", "--cog", "--block", "64"] + Q, ["bt_cog.tif"]),
    ("export_asc", ["export", BT, "-o", "bt.asc"] + Q, ["bt.asc"]),
    ("export_png", ["export", BT, "-o", "bt.png"] + Q, ["bt.png"]),
    ("slope", ["slope", BT, "-o", "slope.tif", "--tile", "77"] + Q, ["slope.tif"]),
    ("slope_geo", ["slope", ASC, "-o", "slope_geo.tif", "--units", "percent"] + Q, ["slope_geo.tif"]),
    ("aspect", ["aspect", BT, "-o", "aspect.tif", "--tile", "77"] + Q, ["aspect.tif"]),
    ("hillshade", ["hillshade", BT, "-o", "hs.tif", "--compute-edges"] + Q, ["hs.tif"]),
    ("metric_list", ["metric", "list"], ["@stdout"]),
    (
        "metric",
        ["metric", BT, "--tile", "61", "-o", "metrics", "-m",
         "slope,mean_curvature,tpi:radius=5c,tri,openness:radius=10c,geomorphon:radius=8c,"
         "sky_view:radius=8c,fractional_laplacian:s=0.5,roughness,weiss_landform"] + Q,
        ["metrics"],
    ),
    ("metric_table", ["metric", "table", WB, "-o", "mtable", "--no-cost"] + Q, ["mtable"]),
    ("fill_nodata", ["fill-nodata", VOIDS, "-o", "voids_filled.tif", "--tile", "53", "--max-distance", "40"] + Q, ["voids_filled.tif"]),
    ("fill", ["fill", WB, "-o", "filled.tif", "--tile", "53"] + Q, ["filled.tif"]),
    ("fill_store", ["fill", "wb.tiles", "-o", "filled.tiles"] + Q, ["filled.tiles"]),
    ("fill_epsilon", ["fill-epsilon", WB, "-o", "eps.tif", "--tile", "53"] + Q, ["eps.tif"]),
    ("breach", ["breach", WB, "-o", "breach.tif", "--tile", "53"] + Q, ["breach.tif"]),
    ("breach_hybrid", ["breach", WB, "-o", "hybrid.tif", "--method", "hybrid", "--max-depth", "2", "--max-length", "50"] + Q, ["hybrid.tif"]),
    ("breach_lc", ["breach", WB, "-o", "lc.tif", "--method", "least-cost", "--tile", "53"] + Q, ["lc.tif"]),
    ("flow", ["flow", "filled.tif", "-o", "d8.tif", "--tile", "53"] + Q, ["d8.tif"]),
    ("flow_rho8", ["flow", "filled.tif", "-o", "rho8.tif", "--method", "rho8", "--seed", "3"] + Q, ["rho8.tif"]),
    ("accumulate", ["accumulate", "d8.tif", "-o", "acc.tif", "--tile", "53"] + Q, ["acc.tif"]),
    ("accumulate_dinf", ["accumulate", "filled.tif", "-o", "dinf.tif", "--method", "dinf"] + Q, ["dinf.tif"]),
    ("fill_latlon", ["fill", SRTM46, "-o", "ll_filled.tif", "--tile", "71"] + Q, ["ll_filled.tif"]),
    ("flow_latlon", ["flow", "ll_filled.tif", "-o", "ll_d8.tif", "--tile", "71"] + Q, ["ll_d8.tif"]),
    ("accumulate_latlon_km2", ["accumulate", "ll_d8.tif", "-o", "ll_km2.tif", "--units", "km2", "--tile", "71"] + Q, ["ll_km2.tif"]),
    ("accumulate_latlon_sca", ["accumulate", "ll_filled.tif", "-o", "ll_sca.tif", "--method", "dinf", "--units", "sca"] + Q, ["ll_sca.tif"]),
    ("noise_big", ["synth", "noise", "--size", "500x400", "--seed", "9", "-o", "big.tif"] + Q, ["big.tif"]),
    ("fill_big", ["fill", "big.tif", "-o", "big_filled.tif", "--tile", "97"] + Q, ["big_filled.tif"]),
    (
        "accumulate_mfd_tiled",
        ["accumulate", "big_filled.tif", "-o", "quinn.tif", "--method", "quinn", "--tile", "97", "--memory", "16MiB"] + Q,
        ["quinn.tif"],
    ),
    ("accumulate_freeman", ["accumulate", "filled.tif", "-o", "freeman.tif", "--method", "freeman"] + Q, ["freeman.tif"]),
    ("watersheds", ["watersheds", "d8.tif", "-o", "ws.tif", "--tile", "53"] + Q, ["ws.tif"]),
    ("basins", ["basins", "d8.tif", "-o", "basins.tif", "--metrics", "bm.csv", "--dem", WB] + Q, ["basins.tif", "bm.csv"]),
    ("streams", ["streams", "d8.tif", "-o", "streams.geojson", "--threshold", "50"] + Q, ["streams.geojson"]),
    ("hydro_twi", ["hydro-index", "--index", "twi", "--dem", "filled.tif", "--acc", "acc.tif", "-o", "twi.tif"] + Q, ["twi.tif"]),
    ("hydro_hand", ["hydro-index", "--index", "hand", "--dem", "filled.tif", "--dirs", "d8.tif", "--acc", "acc.tif", "--threshold", "50", "-o", "hand.tif", "--tile", "53"] + Q, ["hand.tif"]),
    ("peaks", ["peaks", BT, "--min-prominence", "20", "-o", "peaks"] + Q, ["peaks"]),
    ("peaks_tiled", ["peaks", BT, "--min-prominence", "20", "-o", "peaks_tiled", "--tile", "67", "--tiled"] + Q, ["peaks_tiled"]),
    ("orostats", ["orostats", BT, "-R", "1km", "--label", "tujunga", "--seed", "3", "-o", "os.csv"] + Q, ["os.csv"]),
    ("orostats_b", ["orostats", WB, "-R", "3km", "--label", "whitebox", "--seed", "3", "-o", "os_b.csv"] + Q, ["os_b.csv"]),
    ("classify_train", ["classify", "train", "--trees", "15", "-o", "model.json", "os.csv", "os_b.csv"], ["model.json"]),
    ("classify_predict", ["classify", "predict", "model.json", "os.csv", "-o", "pred.csv"], ["pred.csv"]),
    ("ridges", ["ridges", BT, "--min-prominence", "20", "-o", "ridges"] + Q, ["ridges"]),
    ("render", ["render", BT, "-o", "render.png"] + Q, ["render.png"]),
    ("tiles", ["tiles", BT, "-o", "tiles.pmtiles", "-o", "tiles.mbtiles", "--threads", "1"] + Q, ["tiles.pmtiles"]),
    ("viewshed", ["viewshed", BT, "--pixel", "--at", "150,100", "-o", "vs.tif"] + Q, ["vs.tif"]),
    ("erode_hydraulic", ["erode", WB, "--model", "hydraulic", "--steps", "20", "--tile", "53", "-o", "er_h.tif"] + Q, ["er_h.tif"]),
    ("erode_thermal", ["erode", WB, "--model", "thermal", "--steps", "20", "-o", "er_t.tif"] + Q, ["er_t.tif"]),
    ("erode_diffusion", ["erode", WB, "--model", "diffusion", "--steps", "5", "-o", "er_d.tif"] + Q, ["er_d.tif"]),
    ("erode_sp", ["erode", BT, "--model", "stream-power", "--steps", "5", "-o", "er_sp.tif"] + Q, ["er_sp.tif"]),
    ("erode_sp_tiled", ["erode", BT, "--model", "stream-power", "--steps", "5", "--tiled", "--tile", "67", "-o", "er_sp_t.tif"] + Q, ["er_sp_t.tif"]),
    ("synth_noise", ["synth", "noise", "--kind", "warped", "--size", "300x200", "--seed", "5", "--tile", "77", "-o", "noise.tif"] + Q, ["noise.tif"]),
    ("synth_noise_ds", ["synth", "noise", "--kind", "diamond-square", "--size", "200x150", "-o", "ds.tif"] + Q, ["ds.tif"]),
    ("synth_noise_spectral", ["synth", "noise", "--kind", "spectral", "--size", "200x150", "-o", "spec.tif"] + Q, ["spec.tif"]),
    ("synth_rivers", ["synth", "rivers", "--size", "300x200", "--radius", "6", "--seed", "7", "-o", "rivers.tif"] + Q, ["rivers.tif"]),
    ("synth_tectonic", ["synth", "tectonic", "--map", TECTONIC_MAP, "--cell", "300", "-o", "tect.tif"] + Q, ["tect.tif"]),
    ("synth_optimise", ["synth", "optimise", "--source", BT, "--guide", "noise.tif", "--size", "300x200", "--pit", "fill", "--threads", "2", "-o", "opt.tif"] + Q, ["opt.tif"]),
    ("synth_profile", ["synth", "profile", ALPS, "--min-prominence", "100", "-o", "alps.json"], ["alps.json"]),
    ("synth_divide_tree", ["synth", "divide-tree", "--profile", "alps.json", "--size", "300x300", "--seed", "2", "-o", "tree.json"], ["tree.json"]),
    ("synth_from_tree", ["synth", "from-tree", TREE, "-o", "from_tree.tif"] + Q, ["from_tree.tif"]),
    ("synth_orometric", ["synth", "orometric", "--profile", "alps.json", "--size", "300x300", "--seed", "2", "-o", "oro.tif"] + Q, ["oro.tif"]),
    ("compare", ["compare", "rivers.tif", BT, "-o", "compare"] + Q, ["compare"]),
    ("demo", ["demo", "-o", "demo"] + Q, ["demo"]),
    ("run_job", ["run", "@job", "-q"], ["job_out"]),
]


def sha(p: Path) -> str:
    h = hashlib.sha256()
    with open(p, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def files_of(work: Path, rel: str):
    p = work / rel
    if p.is_dir():
        for q in sorted(p.rglob("*")):
            if q.is_file():
                yield q
    elif p.is_file():
        yield p


def run_all(binary: str, work: Path, only=None):
    for name, target in (("data", DATA), ("configs", ROOT / "configs")):
        if not (work / name).exists():
            os.symlink(target, work / name)
    (work / "job.toml").write_text(fixtures.job("fill_flow_slope_noise.toml", DEM=WB))
    out = {}
    failures = []
    for name, argv, outputs in COMMANDS:
        if only and name not in only:
            continue
        argv = [str(work / "job.toml") if a == "@job" else a for a in argv]
        r = subprocess.run([binary] + argv, cwd=work, capture_output=True)
        if r.returncode != 0:
            failures.append(f"{name}: exit {r.returncode}: {r.stderr.decode(errors='replace').strip()[-600:]}")
            continue
        for rel in outputs:
            if rel == "@stdout":
                text = r.stdout
                out[f"{name}/stdout"] = hashlib.sha256(text).hexdigest()
                continue
            found = list(files_of(work, rel))
            if not found:
                failures.append(f"{name}: wrote no {rel}")
            for f in found:
                if any(f.name.endswith(s) for s in SKIP):
                    continue
                out[f"{name}/{f.relative_to(work)}"] = sha(f)
    return out, failures


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", default=str(ROOT / "target" / "release" / "orogen"))
    ap.add_argument("--record", action="store_true", help="write tests/golden/cli_outputs.sha256")
    ap.add_argument("--only", nargs="*", help="run only these command names")
    ap.add_argument("--keep", help="work folder to keep (default: a temporary one)")
    a = ap.parse_args()
    os.environ.setdefault("RAYON_NUM_THREADS", "2")
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(a.keep or tmp)
        work.mkdir(parents=True, exist_ok=True)
        got, failures = run_all(os.path.abspath(a.bin), work, a.only)
    for f in failures:
        print("FAILED", f)
    if a.record:
        if failures:
            sys.exit("not recorded: some commands failed")
        GOLDEN.parent.mkdir(parents=True, exist_ok=True)
        if a.only and GOLDEN.exists():  # re-record these commands, keep the rest
            for line in GOLDEN.read_text().splitlines():
                h, k = line.split("  ", 1)
                if k.split("/", 1)[0] not in a.only:
                    got.setdefault(k, h)
        GOLDEN.write_text("".join(f"{v}  {k}\n" for k, v in sorted(got.items())))
        print(f"recorded {len(got)} outputs of {len(COMMANDS)} commands in {GOLDEN.relative_to(ROOT)}")
        return
    want = {}
    for line in GOLDEN.read_text().splitlines():
        h, k = line.split("  ", 1)
        want[k] = h
    if a.only:
        want = {k: v for k, v in want.items() if k.split("/", 1)[0] in a.only}
    changed = sorted(k for k in want if k in got and got[k] != want[k])
    missing = sorted(k for k in want if k not in got)
    extra = sorted(k for k in got if k not in want)
    for k in changed:
        print("CHANGED", k)
    for k in missing:
        print("MISSING", k)
    for k in extra:
        print("NEW    ", k)
    same = len(want) - len(changed) - len(missing)
    print(f"cli golden: {same} passed, {len(changed) + len(missing) + len(extra) + len(failures)} failed")
    if changed or missing or extra or failures:
        sys.exit(1)


if __name__ == "__main__":
    main()
