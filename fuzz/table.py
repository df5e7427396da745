#!/usr/bin/env python3
"""Print the fuzz campaign table of docs/RELIABILITY.md (issue 12).

Reads the per-slice JSON lines fuzz/plateau.py appends (default:
fuzz/campaign/runs.jsonl) and prints one Markdown row per target of the
given build (default: the build of the newest line): slices, fuzzing time,
executions, exec/s, the last slice's cov/ft, the best cov, when (in
cumulative fuzzing time) the last new edge came, how long the target had
then fuzzed without one, the edges the last half of its executions added
(the plateau rule's second clause), the corpus at the end, peak RSS, whether the plateau
rule held, and findings. Builds fuzzed under the current rule
(fuzz/plateau.py) show that rule's verdict as recorded by the run; older
builds, the earlier "--quiet seconds without a new edge" rule.

  python3 fuzz/table.py [RUNS.jsonl] [--build ID] [--quiet 300]
"""
import argparse
import json
import os


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    ap = argparse.ArgumentParser()
    ap.add_argument("runs", nargs="?", default=os.path.join(here, "campaign", "runs.jsonl"))
    ap.add_argument("--build")
    ap.add_argument("--quiet", type=float, default=300)
    a = ap.parse_args()
    rows = [json.loads(l) for l in open(a.runs) if l.strip()]
    if not rows:
        raise SystemExit(f"{a.runs}: no runs recorded")
    build = a.build if a.build is not None else rows[-1].get("build", "")
    rows = [r for r in rows if r.get("build", "") == build]
    by = {}
    for r in rows:
        by.setdefault(r["target"], []).append(r)
    total_s = sum(r["seconds"] for r in rows)
    total_x = sum(r["executions"] for r in rows)
    print(f"build {build or '(none)'}: {len(rows)} slices, {total_s / 60:.0f} min, "
          f"{total_x / 1e6:.1f} M executions\n")
    print("| target | slices | time | executions | exec/s | last cov / ft | best cov "
          "| last new cov at | quiet at end | gain, last half | corpus at end | peak RSS "
          f"| plateau ({rows[-1].get('rule') or f'{a.quiet:.0f} s rule'}) | findings |")
    print("|---|---:|---:|---:|---:|---|---:|---:|---:|---:|---|---:|---|---|")
    for t, rs in by.items():
        last = rs[-1]
        secs = sum(r["seconds"] for r in rs)
        execs = sum(r["executions"] for r in rs)
        quiet = last.get("quiet_cum_s", 0)
        cum = last.get("cum_seconds", secs)
        rss = max((r.get("peak_rss_mb") or 0) for r in rs)
        finds = sum(1 for r in rs if r.get("finding"))
        gain = last.get("half_gain_pct")
        held = last["plateau"] if "rule" in last else quiet >= a.quiet
        print(
            f"| {t} | {len(rs)} | {secs} s | {execs:,} | {round(execs / max(secs, 1))} "
            f"| {last['cov']} / {last['ft']} | {last.get('best_cov', last['cov'])} "
            f"| {cum - quiet} s | {quiet} s | {'' if gain is None else f'{gain:.2f} %'} "
            f"| {last.get('corpus', '')} | {rss} MB "
            f"| {'yes' if held else 'no'} | {finds or 'none'} |".replace(",", " ")
        )


if __name__ == "__main__":
    main()
