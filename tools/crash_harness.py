#!/usr/bin/env python3
"""Crash-anywhere harness (issue 12).

Runs a real job (tests/data/jobs/all_output_kinds.toml: ingest -> fill -> flow -> accumulation -> peaks ->
orostats CSV -> descriptors -> slope GeoTIFF -> COG export; tile stores, GeoTIFFs, COGs) on a small real DEM, kills
it at seeded random moments, checks what the kill left on disk, reruns the
job to completion and checks that the final outputs are byte-identical to an
uninterrupted reference run.

Kinds of trial (chosen by the seeded generator):
  time   SIGKILL after a random delay spread over the whole run.
  point  the library aborts itself at the N-th named crash point
         (OROGEN_CRASH_AT, see src/store/crash.rs): tile temporary written,
         tile renamed, journal appended, manifest written/renamed, GeoTIFF/COG
         complete under its temporary name, job state saved.
Either kind may then "tear" a tile (truncate it, or flip a byte in it) of
one of the stores on disk, as a power loss or a bad disk could, finished
store or not; the rerun must detect it by its checksum and recompute it.

After every kill (before the rerun) no output may look complete and be
wrong: a .tif is absent or byte-identical to the reference; a tile store
whose manifest says complete holds exactly the reference's bytes; a store
not marked complete is refused by `orogen info`; the peaks/ files and the
top-level CSV/JSON outputs are absent or identical to the reference. After the rerun: exit 0, the same set of files
as the reference (no leftover temporaries, journals or locks) and the same
bytes.

    tools/crash_harness.py [--trials 60] [--seed 12] [--bin target/debug/orogen]

Exits non-zero on the first violation, printing the trial's seed and kind.
"""

import argparse
import hashlib
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time

import fixtures

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DEM = os.path.join(ROOT, "tests", "data", "whitebox_DEM.tif")


# Files of the job runner itself (timings inside; not outputs).
IGNORED = {".orogen-job.json"}


def snapshot(out):
    """Relative path -> sha256 of every file under `out`."""
    res = {}
    for d, _, files in os.walk(out):
        for f in files:
            p = os.path.join(d, f)
            rel = os.path.relpath(p, out)
            if rel in IGNORED:
                continue
            with open(p, "rb") as fh:
                res[rel] = hashlib.sha256(fh.read()).hexdigest()
    return res


def run_job(work, binary, env_extra=None, timeout=600):
    env = dict(os.environ)
    env.pop("OROGEN_CRASH_AT", None)
    env.pop("OROGEN_CRASH_LOG", None)
    if env_extra:
        env.update(env_extra)
    return subprocess.run(
        [binary, "run", "job.toml", "-q"],
        cwd=work,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        timeout=timeout,
    )


def stores(out):
    """Tile-store directories under `out` (relative paths)."""
    res = []
    for d, _, files in os.walk(out):
        if "manifest.json" in files or d.endswith(".tiles"):
            res.append(os.path.relpath(d, out))
    return sorted(res)


def manifest_complete(path):
    """True/False from manifest.json, None if missing or unreadable."""
    import json

    try:
        with open(os.path.join(path, "manifest.json"), "rb") as fh:
            return bool(json.load(fh).get("complete"))
    except (OSError, ValueError):
        return None


def check_after_kill(out, ref, binary):
    """Violations: outputs that look complete but are not the reference."""
    bad = []
    if not os.path.isdir(out):
        return bad
    cur = snapshot(out)
    for rel, h in cur.items():
        base = os.path.basename(rel)
        top = rel.split(os.sep)[0]
        if base.startswith(".") or base.endswith(".tmp") or base in ("journal", ".lock"):
            continue  # temporaries and bookkeeping: hidden or obviously partial
        if rel.endswith(".tif") and os.sep not in rel:
            if ref.get(rel) != h:
                bad.append(f"{rel}: present but differs from the reference")
        elif os.sep not in rel and rel.endswith((".csv", ".json", ".geojson")):
            if ref.get(rel) != h:
                bad.append(f"{rel}: present but differs from the reference (torn write?)")
        elif top == "peaks":
            if ref.get(rel) != h:
                bad.append(f"{rel}: present but differs from the reference (torn write?)")
    for s in stores(out):
        p = os.path.join(out, s)
        c = manifest_complete(p)
        if c:
            for rel, h in cur.items():
                if rel.startswith(s + os.sep) and not os.path.basename(rel).startswith("."):
                    if os.path.basename(rel) == "journal":
                        # Killed between the final manifest's rename and the
                        # journal's removal: harmless (readers ignore it; the
                        # next writer truncates it), not an output.
                        continue
                    if rel.endswith(".tmp"):
                        bad.append(f"{rel}: left in a store marked complete")
                    elif ref.get(rel) != h:
                        bad.append(f"{rel}: differs from the reference in a store marked complete")
            for rel in ref:
                if rel.startswith(s + os.sep) and rel not in cur:
                    bad.append(f"{rel}: missing from a store marked complete")
        else:
            r = subprocess.run([binary, "info", p], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
            if r.returncode == 0:
                bad.append(f"{s}: store not marked complete, but `orogen info` opened it")
            # Tiles already renamed into place are atomic: reference bytes.
            for rel, h in cur.items():
                b = os.path.basename(rel)
                if rel.startswith(s + os.sep) and b.startswith("t_") and b.endswith(".bin"):
                    if ref.get(rel) != h:
                        bad.append(f"{rel}: a renamed tile with wrong bytes")
    return bad


def tear(out, rng):
    """Damage one tile file of one store; returns a description or None."""
    tiles = []
    for s in stores(out):
        p = os.path.join(out, s)
        for f in sorted(os.listdir(p)):
            if f.startswith("t_") and f.endswith(".bin"):
                tiles.append(os.path.join(p, f))
    if not tiles:
        return None
    t = rng.choice(tiles)
    data = bytearray(open(t, "rb").read())
    if not data:
        return None
    if rng.random() < 0.5:
        n = rng.randrange(len(data))
        with open(t, "wb") as fh:
            fh.write(data[:n])
        return f"truncated {os.path.relpath(t, out)} to {n} of {len(data)} bytes"
    i = rng.randrange(len(data))
    data[i] ^= 1 << rng.randrange(8)
    with open(t, "wb") as fh:
        fh.write(data)
    return f"flipped a bit of byte {i} in {os.path.relpath(t, out)}"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--trials", type=int, default=60)
    ap.add_argument("--seed", type=int, default=12)
    ap.add_argument("--bin", default=os.path.join(ROOT, "target", "debug", "orogen"))
    ap.add_argument("--tear", type=float, default=0.3, help="probability of tearing a tile after a kill")
    ap.add_argument("--keep", action="store_true", help="keep the scratch folder")
    a = ap.parse_args()
    binary = os.path.abspath(a.bin)
    base = tempfile.mkdtemp(prefix="orogen-crash-")
    job = fixtures.job("all_output_kinds.toml", DEM=DEM)

    def fresh(name):
        w = os.path.join(base, name)
        shutil.rmtree(w, ignore_errors=True)
        os.makedirs(w)
        with open(os.path.join(w, "job.toml"), "w") as fh:
            fh.write(job)
        return w

    # Reference: uninterrupted, counting the crash points it passes.
    w = fresh("ref")
    log = os.path.join(base, "points.log")
    t0 = time.monotonic()
    r = run_job(w, binary, {"OROGEN_CRASH_LOG": log})
    t_ref = time.monotonic() - t0
    if r.returncode != 0:
        sys.exit(f"reference run failed:\n{r.stderr.decode()}")
    ref = snapshot(os.path.join(w, "out"))
    leftovers = [p for p in ref if os.path.basename(p).startswith(".") or p.endswith(".tmp") or os.path.basename(p) == "journal"]
    if leftovers:
        sys.exit(f"reference run left temporaries: {leftovers}")
    points = [l.strip() for l in open(log) if l.strip()]
    kinds = sorted(set(points))
    print(f"reference: {t_ref:.2f} s, {len(ref)} files, {len(points)} crash points ({', '.join(kinds)})")
    # A second uninterrupted run in a fresh folder must give the same bytes.
    w2 = fresh("ref2")
    if run_job(w2, binary).returncode != 0 or snapshot(os.path.join(w2, "out")) != ref:
        sys.exit("two uninterrupted runs differ: outputs are not deterministic")

    stats = {"time": 0, "point": 0, "killed": 0, "finished-before-kill": 0, "torn": 0, "reruns-with-resume": 0}
    failures = 0
    for i in range(a.trials):
        # One generator per trial: a trial's kind, point and tear depend on
        # the seed and its number only, not on how many tiles an earlier
        # trial's kill left on disk (which varies with timing).
        rng = random.Random(f"{a.seed}/{i}")
        w = fresh(f"trial{i}")
        out = os.path.join(w, "out")
        kind = "time" if rng.random() < 0.5 else "point"
        stats[kind] += 1
        desc = ""
        if kind == "time":
            delay = rng.uniform(0.0, t_ref * 1.05)
            p = subprocess.Popen([binary, "run", "job.toml", "-q"], cwd=w, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            time.sleep(delay)
            if p.poll() is None:
                p.send_signal(signal.SIGKILL)
                stats["killed"] += 1
            else:
                stats["finished-before-kill"] += 1
            p.wait()
            desc = f"SIGKILL after {delay:.3f} s"
        else:
            # Half the point trials aim at one kind of point, half at any.
            if rng.random() < 0.5:
                pat = rng.choice(kinds)
                n = rng.randint(1, points.count(pat))
            else:
                pat = "*"
                n = rng.randint(1, len(points))
            r = run_job(w, binary, {"OROGEN_CRASH_AT": f"{pat}:{n}"})
            if r.returncode == 0:
                stats["finished-before-kill"] += 1
            else:
                stats["killed"] += 1
            desc = f"abort at crash point {pat}:{n} (rc {r.returncode})"
        bad = check_after_kill(out, ref, binary)
        torn = None
        if rng.random() < a.tear:
            torn = tear(out, rng)
            if torn:
                stats["torn"] += 1
                desc += f"; {torn}"
        r = run_job(w, binary)
        if r.returncode != 0:
            bad.append(f"rerun failed (rc {r.returncode}): {r.stderr.decode()[-800:]}")
        else:
            if b"resum" in r.stderr or b"skipped" in r.stderr:
                stats["reruns-with-resume"] += 1
            fin = snapshot(out)
            for rel in sorted(set(fin) | set(ref)):
                if fin.get(rel) != ref.get(rel):
                    what = "missing" if rel not in fin else ("extra" if rel not in ref else "differs")
                    bad.append(f"after rerun: {rel} {what}")
        status = "ok" if not bad else "FAIL"
        print(f"trial {i:3d} [{kind:5s}] {desc}: {status}")
        for b in bad:
            print(f"    {b}")
        if bad:
            failures += 1
        else:
            shutil.rmtree(w, ignore_errors=True)
    print(f"trials {a.trials}, seed {a.seed}: {stats}; failures {failures}")
    if not a.keep and failures == 0:
        shutil.rmtree(base, ignore_errors=True)
    else:
        print(f"scratch kept in {base}")
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
