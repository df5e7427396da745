#!/usr/bin/env python3
"""Run one cargo-fuzz target until its coverage plateaus (issue 12).

Starts the (already built) target binary on a working corpus seeded from
fuzz/corpus/<target>/, timestamps every libFuzzer status line, and stops the
run when coverage stopped growing: no new `cov` in the last third of the run
(after at least --min seconds), or --quiet seconds without new `cov`, or at
--max seconds. Writes the timestamped log and prints one summary line (JSON):
executions, time, final cov/ft, time of the last new cov, exec/s, corpus
size, and whether it ended on a plateau. A crash/timeout/OOM ends the run
with the reproducer in fuzz/artifacts/<target>/ and a non-zero exit.

  fuzz/plateau.py geotiff --min 180 --max 1200 [--bin PATH] [--work DIR]
                 [--seeds DIR ...] [--state FILE] [--build-id ID]

Resumed runs: with --state FILE the run continues the counts
of earlier runs of the target on the same working corpus: cumulative
executions and seconds, the highest `cov` ever seen, and the cumulative
time of the last new `cov` (a resumed run first replays its corpus, which
only reaches the old coverage; an edge counts as new when `cov` exceeds
every earlier run's). --quiet then means "seconds of fuzzing, over all
runs, without a new cov edge". The state is updated at the end of the
run and one JSON line per run is appended to WORK/runs.jsonl.

The plateau rule (stated before the runs it judges). Coverage
grows roughly with the logarithm of the fuzzing effort (Böhme and Falk,
"Fuzzing: on the exponential cost of vulnerability discovery", ESEC/FSE
2020), so "N seconds without a new edge" is met by every target sooner or
later and says little: in one campaign hgt gained 13 % after meeting it. A
resumed target is at its plateau when all three hold, on the counts of
the current build:
  1. it has fuzzed at least --min-total seconds (default 1200);
  2. the last half of its executions (the last doubling of the effort)
     added at most --max-gain percent of its edges (default 1.0): the
     state keeps every new best `cov` with the cumulative executions it
     came at, and the gain is the best cov minus the best cov reached by
     half the executions;
  3. --quiet seconds of fuzzing without a new edge.

The binary defaults to the optimised uninstrumented-by-ASan build
(`cargo fuzz build -s none`): fuzz/target/x86_64-unknown-linux-gnu/release/.
"""
import argparse
import json
import os
import queue
import re
import signal
import subprocess
import sys
import threading
import time

STATUS = re.compile(
    r"^#(\d+)\s+(\w+)\s+cov: (\d+) ft: (\d+)(?: corp: (\d+)/(\S+))?.*?(?:exec/s: (\d+))?(?: rss: (\d+)Mb)?"
)


def half_gain(st, executions):
    """Edges gained over the last half of `executions`, in percent of the
    best `cov`: the best cov minus the best cov reached within the first
    half (0 before any was seen). Rule 2 of the plateau."""
    before = [c for x, c in st["curve"] if x <= executions / 2]
    ref = before[-1] if before else 0
    return 100.0 * (st["best_cov"] - ref) / max(st["best_cov"], 1)


def at_plateau(st, a, seconds, executions):
    """The plateau rule of the header (rules 1-3) on cumulative counts."""
    return (
        seconds - st["last_new_cov_cum"] >= a.quiet
        and seconds >= a.min_total
        and half_gain(st, executions) <= a.max_gain
    )


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("target")
    ap.add_argument("--min", type=float, default=180)
    ap.add_argument("--max", type=float, default=1200)
    ap.add_argument("--quiet", type=float, default=600)
    ap.add_argument("--bin")
    ap.add_argument("--work", default="/tmp/orogen-fuzz-plateau")
    ap.add_argument("--timeout", type=int, default=10)
    ap.add_argument(
        "--seeds", action="append", help="read-only seed folder (repeatable)"
    )
    ap.add_argument("--state", help="JSON file carrying counts across resumed runs")
    ap.add_argument("--build-id", default="", help="identity of the build the counts are for")
    ap.add_argument("--min-total", type=float, default=1200,
                    help="plateau rule: least cumulative fuzzing seconds")
    ap.add_argument("--max-gain", type=float, default=1.0,
                    help="plateau rule: most edges gained over the last half of the "
                    "executions, in percent of all")
    ap.add_argument("extra", nargs="*", help="extra libFuzzer flags")
    a = ap.parse_args()
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    binary = a.bin or os.path.join(
        root, "fuzz/target/x86_64-unknown-linux-gnu/release", a.target
    )
    corpus = os.path.join(a.work, "corpus", a.target)
    os.makedirs(corpus, exist_ok=True)
    seeds = [d for d in (a.seeds or [os.path.join(root, "fuzz/corpus", a.target)]) if os.path.isdir(d)]
    st = {
        "seconds": 0.0,
        "executions": 0,
        "best_cov": -1,
        "last_new_cov_cum": 0.0,
        "runs": 0,
        "build": a.build_id,
        "curve": [],
    }
    if a.state and os.path.exists(a.state):
        old = json.load(open(a.state))
        if old.get("build", "") == a.build_id:
            st.update(old)
        else:
            keep = f"{a.state}.{old.get('build', '') or 'unknown'}"
            os.replace(a.state, keep)
            print(
                f"plateau.py: {a.state} counts another build ({old.get('build')!r}, "
                f"now {a.build_id!r}): fresh counts, old state kept as {keep}",
                file=sys.stderr,
            )
    base_t, base_x = st["seconds"], st["executions"]
    art = os.path.join(root, "fuzz/artifacts", a.target) + "/"
    os.makedirs(art, exist_ok=True)
    log_path = os.path.join(a.work, f"{a.target}.log")
    cmd = [
        binary,
        corpus,
    ] + seeds + [
        f"-artifact_prefix={art}",
        f"-timeout={a.timeout}",
        "-rss_limit_mb=2048",
        "-malloc_limit_mb=1024",
        "-print_final_stats=1",
        f"-max_total_time={int(a.max)}",
    ] + a.extra
    t0 = time.time()
    p = subprocess.Popen(
        cmd, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True, errors="replace"
    )
    lines = queue.Queue()

    def reader():
        for line in p.stderr:
            lines.put((time.time() - t0, line))
        lines.put(None)

    threading.Thread(target=reader, daemon=True).start()
    last_cov, t_last_cov, cov, ft, execs, eps, corp = -1, 0.0, 0, 0, 0, 0, ""
    plateau, stopped, done = False, False, False
    with open(log_path, "w") as log:
        log.write(" ".join(cmd) + "\n")
        while not done:
            try:
                item = lines.get(timeout=1.0)
            except queue.Empty:
                item = ()
            if item is None:
                done = True
            elif item:
                t, line = item
                log.write(f"[{t:8.1f}] {line}")
                m = STATUS.match(line)
                if m:
                    execs, cov, ft = int(m.group(1)), int(m.group(3)), int(m.group(4))
                    if m.group(5):
                        corp = f"{m.group(5)}/{m.group(6)}"
                    if m.group(7):
                        eps = int(m.group(7))
                    if cov > last_cov:
                        last_cov, t_last_cov = cov, t
                    if cov > st["best_cov"]:
                        st["best_cov"], st["last_new_cov_cum"] = cov, base_t + t
                        st["curve"].append([base_x + execs, cov])
            t = time.time() - t0
            rule = (
                at_plateau(st, a, base_t + t, base_x + execs)
                if a.state
                else (t_last_cov <= t * 2 / 3 or t - t_last_cov >= a.quiet)
            )
            if not stopped and t >= a.min and rule:
                plateau, stopped = True, True
                log.write(f"[{t:8.1f}] plateau: no new cov since {t_last_cov:.1f} s; stopping\n")
                p.send_signal(signal.SIGINT)  # libFuzzer prints final stats
        rc = p.wait()
    t_end = time.time() - t0
    stats = {}
    for line in open(log_path):
        m = re.search(r"stat::(\w+):\s+(\d+)", line)
        if m:
            stats[m.group(1)] = int(m.group(2))
    finding = any(
        s in open(log_path).read()
        for s in ("ERROR: libFuzzer", "panicked", "==ERROR", "SUMMARY: libFuzzer")
    )
    out = {
        "target": a.target,
        "build": a.build_id,
        "ended": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        "seconds": round(t_end),
        "executions": stats.get("number_of_executed_units", execs),
        "exec_per_s": round(stats.get("number_of_executed_units", execs) / max(t_end, 1e-9)),
        "cov": cov,
        "ft": ft,
        "last_new_cov_s": round(t_last_cov),
        "corpus": corp,
        "peak_rss_mb": stats.get("peak_rss_mb"),
        "plateau": plateau or (t_last_cov <= t_end * 2 / 3),
        "finding": finding,
        "rc": rc,
    }
    if a.state:
        st["seconds"] = base_t + t_end
        st["executions"] += out["executions"]
        st["runs"] += 1
        json.dump(st, open(a.state, "w"))
        out.update(
            cum_seconds=round(st["seconds"]),
            cum_executions=st["executions"],
            best_cov=st["best_cov"],
            quiet_cum_s=round(st["seconds"] - st["last_new_cov_cum"]),
            half_gain_pct=round(half_gain(st, st["executions"]), 2),
            rule=f"{a.min_total:.0f} s, {a.max_gain:g} % per doubling, {a.quiet:.0f} s quiet",
            plateau=at_plateau(st, a, st["seconds"], st["executions"]),
        )
        with open(os.path.join(a.work, "runs.jsonl"), "a") as f:
            f.write(json.dumps(out) + "\n")
    print(json.dumps(out), flush=True)
    sys.exit(1 if finding else 0)


if __name__ == "__main__":
    main()
