#!/usr/bin/env python3
"""Where a fuzz target's coverage grew, by origin.

Replays two corpora of one target (BEFORE and AFTER, each one or more
folders or `.tar.gz` archives of fuzz/campaign/corpus/) with libFuzzer's
`-runs=0 -print_coverage=1`, which lists every instrumented function with
its covered and total edges, and prints, per origin, the edges covered
before and after and the edges gained (the sum over functions of the
growth). Origins: orogen's files under `src/` and `fuzz/`, each crate of
the registry, and `std(mono)` (generic std code instantiated in
instrumented crates; std itself is not instrumented).

Why: the plateau rule (300 s of fuzzing without a new `cov` edge) counts
edges in every instrumented crate; this tells whether a target that keeps
finding edges is exploring orogen's readers or a dependency's parser.
Inlined code counts in the function it was inlined into, so per-file
figures are approximate; per-crate sums are what to read.

  python3 fuzz/cov_origin.py --bin BIN --before PATH [--before PATH...] \
      --after PATH [--after PATH...] [--top 20] [--by-file]
"""
import argparse
import collections
import os
import re
import subprocess
import tarfile
import tempfile

LINE = re.compile(r"(?:UN)?COVERED_FUNC: hits: \d+ edges: (\d+)/(\d+) (.*) (\S+):\d+$")
DONE = re.compile(r"DONE\s+cov: (\d+) ft: (\d+)")


def origin(path):
    if path.startswith("/rustc/"):
        return "std(mono)"
    m = re.search(r"registry/src/[^/]+/([^/]+)/", path)
    if m:
        return re.sub(r"-\d+\.\d+\.\d+.*$", "", m.group(1))
    m = re.search(r".*/((?:src|fuzz)/.*)", path)
    return "orogen " + m.group(1) if m else path


def replay(binary, corpora, tmp):
    """Per-function (covered, total) edges and libFuzzer's (cov, ft)."""
    dirs = []
    for c in corpora:
        if c.endswith(".tar.gz"):
            d = tempfile.mkdtemp(dir=tmp)
            with tarfile.open(c) as t:
                t.extractall(d, filter="data")
            c = d
        dirs.append(c)
    env = dict(os.environ)
    env.setdefault("ASAN_OPTIONS", "detect_odr_violation=0")
    out = subprocess.run([binary, "-runs=0", "-print_coverage=1", *dirs],
                         stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                         env=env, check=False).stdout.decode(errors="replace")
    funcs, done = {}, None
    for line in out.splitlines():
        m = LINE.match(line.strip())
        if m:
            funcs[(m.group(3), m.group(4))] = (int(m.group(1)), int(m.group(2)))
        m = DONE.search(line)
        if m:
            done = (int(m.group(1)), int(m.group(2)))
    if done is None or not funcs:
        raise SystemExit(f"{binary} on {' '.join(corpora)}: no coverage report; output ends:\n"
                         + "\n".join(out.splitlines()[-20:]))
    return funcs, done


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", required=True)
    ap.add_argument("--before", action="append", required=True)
    ap.add_argument("--after", action="append", required=True)
    ap.add_argument("--top", type=int, default=20)
    ap.add_argument("--by-file", action="store_true",
                    help="split orogen's origin by file (default: one row)")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        fa, da = replay(a.bin, a.before, tmp)
        fb, db = replay(a.bin, a.after, tmp)
    before, after, gain, total = (collections.Counter() for _ in range(4))
    for key in set(fa) | set(fb):
        o = origin(key[1])
        if not a.by_file and o.startswith("orogen "):
            o = "orogen"
        ea = fa.get(key, (0, 0))[0]
        eb, n = fb.get(key, fa.get(key, (0, 0)))
        total[o] += n
        before[o] += ea
        after[o] += eb
        gain[o] += max(0, eb - ea)
    print(f"libFuzzer cov: {da[0]} -> {db[0]} (ft {da[1]} -> {db[1]}); "
          f"edges gained over functions: {sum(gain.values())}")
    print("| origin | edges before | edges after | gained | edges in the binary |")
    print("|---|---:|---:|---:|---:|")
    rows = sorted(after, key=lambda o: (-gain[o], -after[o], o))
    for o in rows[: a.top]:
        print(f"| {o} | {before[o]} | {after[o]} | {gain[o]} | {total[o]} |")
    rest = rows[a.top:]
    if rest:
        print(f"| ({len(rest)} more) | {sum(before[o] for o in rest)} | "
              f"{sum(after[o] for o in rest)} | {sum(gain[o] for o in rest)} | "
              f"{sum(total[o] for o in rest)} |")


if __name__ == "__main__":
    main()
