#!/usr/bin/env bash
# Save a fuzz campaign into the repository (issue 12; session 9), so the
# next session, on another machine, resumes it instead of starting over
# from the seeds (session 9 lost 388 min of working corpora with the
# machine). For each target: libFuzzer's `-merge=1` minimises WORK's
# working corpus together with the saved one into a fresh folder, and the
# inputs of at most MAX_LEN bytes (default 65536) replace
# fuzz/campaign/corpus/TARGET/ (larger inputs, mostly grown GeoTIFF and
# ASCII files, would make the folder tens of MB; the seeds they grew from
# stay in fuzz/corpus/). The target's counts (WORK/state/TARGET.json) are
# copied to fuzz/campaign/state/, and WORK/runs.jsonl's lines are added to
# fuzz/campaign/runs.jsonl (the record fuzz/table.py prints).
#
#   BIN_DIR=/work/fuzzwork/target/x86_64-unknown-linux-gnu/release \
#   WORK=/work/fuzzwork tools/fuzz_save.sh [TARGET...]
set -euo pipefail
cd "$(dirname "$0")/.."

bin_dir="${BIN_DIR:-fuzz/target/x86_64-unknown-linux-gnu/release}"
work="${WORK:-/tmp/orogen-fuzz-plateau}"
max_len="${MAX_LEN:-65536}"
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_odr_violation=0}"

targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
    mapfile -t targets < <(ls fuzz/fuzz_targets | sed 's/\.rs$//')
fi

mkdir -p fuzz/campaign/corpus fuzz/campaign/state
for t in "${targets[@]}"; do
    [ -d "$work/corpus/$t" ] || { echo "fuzz_save: no working corpus for $t" >&2; continue; }
    out="$(mktemp -d)"
    saved="fuzz/campaign/corpus/$t"
    mkdir -p "$saved"
    nice -n 19 "$bin_dir/$t" -merge=1 -timeout=10 -rss_limit_mb=2048 \
        -malloc_limit_mb=1024 "$out" "$saved" "$work/corpus/$t" 2>"$out.log" || {
        echo "fuzz_save: merge of $t failed; log: $out.log" >&2
        exit 1
    }
    find "$out" -type f -size +"${max_len}"c -delete
    rm -rf "$saved"
    mv "$out" "$saved"
    chmod 755 "$saved"
    [ -f "$work/state/$t.json" ] && cp "$work/state/$t.json" "fuzz/campaign/state/$t.json"
    echo "fuzz_save: $t: $(ls "$saved" | wc -l) inputs, $(du -sk "$saved" | cut -f1) KB" >&2
done
if [ -f "$work/runs.jsonl" ]; then
    touch fuzz/campaign/runs.jsonl
    # Add the lines not yet recorded, in their order.
    grep -vxF -f fuzz/campaign/runs.jsonl "$work/runs.jsonl" >>fuzz/campaign/runs.jsonl || true
fi
