#!/usr/bin/env bash
# Save a fuzz campaign into the repository, so the
# next session, on another machine, resumes it instead of starting over
# from the seeds (a campaign once lost 388 min of working corpora with the
# machine). For each target: libFuzzer's `-merge=1` minimises WORK's
# working corpus together with the saved one into a fresh folder, and the
# inputs of at most MAX_LEN bytes (default 65536) replace the archive
# fuzz/campaign/corpus/TARGET.tar.gz (one per target, names sorted, no
# owners or times, `gzip -n`: the same inputs give the same bytes, and
# thousands of small files stay out of the tree; 7.7 MB for all targets
# after a long campaign, where uncompressed tars would be about 30 MB). Larger inputs, mostly
# grown GeoTIFF and ASCII files, would make it tens of MB; the seeds they
# grew from stay in fuzz/corpus/. The target's counts (WORK/state/TARGET.json) are
# copied to fuzz/campaign/state/, and WORK/runs.jsonl's lines are added to
# fuzz/campaign/runs.jsonl (the record fuzz/table.py prints).
#
# A target whose counts are unchanged since the last save (WORK/state/TARGET.json
# equal to fuzz/campaign/state/TARGET.json) was not fuzzed since, and is
# skipped: `-merge=1` over an unchanged corpus picks another, equally minimal
# set, so re-saving it would only churn its archive (6 MB for geotiff).
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
    if cmp -s "$work/state/$t.json" "fuzz/campaign/state/$t.json"; then
        echo "fuzz_save: $t: not fuzzed since the last save, kept" >&2
        continue
    fi
    tmp="$(mktemp -d)"
    mkdir -p "$tmp/saved" "$tmp/$t"
    archive="fuzz/campaign/corpus/$t.tar.gz"
    [ -f "$archive" ] && tar -xzf "$archive" -C "$tmp/saved"
    nice -n 19 "$bin_dir/$t" -merge=1 -timeout=10 -rss_limit_mb=2048 \
        -malloc_limit_mb=1024 "$tmp/$t" "$tmp/saved" "$work/corpus/$t" 2>"$tmp/merge.log" || {
        echo "fuzz_save: merge of $t failed; log: $tmp/merge.log" >&2
        exit 1
    }
    find "$tmp/$t" -type f -size +"${max_len}"c -delete
    (cd "$tmp/$t" && find . -type f -printf '%P\n' | LC_ALL=C sort |
        tar -cf - --no-recursion --owner=0 --group=0 --numeric-owner --mtime=@0 \
            --mode=644 -T - | gzip -n -9) >"$archive.tmp"
    mv "$archive.tmp" "$archive"
    [ -f "$work/state/$t.json" ] && cp "$work/state/$t.json" "fuzz/campaign/state/$t.json"
    echo "fuzz_save: $t: $(ls "$tmp/$t" | wc -l) inputs, $(du -k "$archive" | cut -f1) KB" >&2
    rm -rf "$tmp"
done
if [ -f "$work/runs.jsonl" ]; then
    touch fuzz/campaign/runs.jsonl
    # Add the lines not yet recorded, in their order.
    grep -vxF -f fuzz/campaign/runs.jsonl "$work/runs.jsonl" >>fuzz/campaign/runs.jsonl || true
fi
