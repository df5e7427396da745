#!/usr/bin/env bash
# Fuzz every target to a coverage plateau, one fuzzer at a time.
# Round-robin over the targets in slices of SLICE seconds, each
# slice resuming the target's working corpus (WORK/corpus/TARGET) and its
# counts (WORK/state/TARGET.json) through fuzz/plateau.py --state; a target
# leaves the rotation once it meets the plateau rule, or on a finding
# (reproducer in fuzz/artifacts/TARGET/). The rule (see
# fuzz/plateau.py): at least MIN_TOTAL seconds of fuzzing on the build, the
# last half of its executions added at most MAX_GAIN percent of its edges,
# and QUIET seconds without a new edge. Stops at the epoch second DEADLINE.
#
#   BIN_DIR=/work/fuzzwork/target/x86_64-unknown-linux-gnu/release \
#   WORK=/work/fuzzwork SEEDS=/work/fuzzwork/seeds SLICE=600 QUIET=300 \
#   MIN_TOTAL=1200 MAX_GAIN=1.0 \
#   DEADLINE=$(date -d 17:45 +%s) tools/fuzz_plateau.sh [TARGET...]
#
# Runs under `nice -n 19`, one process (libFuzzer's default: one job, one
# worker): never more than one core. Every slice appends one JSON line to
# WORK/runs.jsonl.
#
# Campaigns carry over between machines: the minimised working
# corpus of each target and its counts are committed in fuzz/campaign/
# (tools/fuzz_save.sh writes them). A slice also replays the saved corpus
# (fuzz/campaign/corpus/TARGET.tar.gz, unpacked once into WORK/saved/TARGET),
# and a target without a state in WORK/state
# starts from fuzz/campaign/state/TARGET.json. Counts are per build:
# BUILD_ID (default: the commit that last changed the fuzzed code, src/,
# fuzz/ and the lock files, in this checkout) must name the tree BIN_DIR was
# built from; a state of another build starts fresh counts (fuzz/plateau.py).
set -uo pipefail
cd "$(dirname "$0")/.."

bin_dir="${BIN_DIR:-fuzz/target/x86_64-unknown-linux-gnu/release}"
work="${WORK:-/tmp/orogen-fuzz-plateau}"
seeds="${SEEDS:-fuzz/corpus}"
slice="${SLICE:-240}"
quiet="${QUIET:-300}"
min_total="${MIN_TOTAL:-1200}"
max_gain="${MAX_GAIN:-1.0}"
deadline="${DEADLINE:-$(( $(date +%s) + 3600 ))}"
mkdir -p "$work/state"
build_id="${BUILD_ID:-$(git log -1 --format=%h -- src fuzz/common.rs fuzz/fuzz_targets \
    fuzz/Cargo.toml fuzz/Cargo.lock Cargo.toml Cargo.lock)}"
# The bundled SQLite has same-named function-local statics that ASan's ODR
# check reports at start-up (see docs/RELIABILITY.md).
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_odr_violation=0}"

targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
    mapfile -t targets < <(ls fuzz/fuzz_targets | sed 's/\.rs$//')
fi

declare -A done_
while :; do
    left=0
    for t in "${targets[@]}"; do
        [ -n "${done_[$t]:-}" ] && continue
        now=$(date +%s)
        remaining=$(( deadline - now ))
        if [ "$remaining" -lt 60 ]; then
            echo "fuzz_plateau: deadline reached" >&2
            exit 0
        fi
        left=1
        max=$(( slice < remaining ? slice : remaining ))
        if [ ! -f "$work/state/$t.json" ] && [ -f "fuzz/campaign/state/$t.json" ]; then
            cp "fuzz/campaign/state/$t.json" "$work/state/$t.json"
        fi
        if [ ! -d "$work/saved/$t" ]; then
            mkdir -p "$work/saved/$t"
            [ -f "fuzz/campaign/corpus/$t.tar.gz" ] && tar -xzf "fuzz/campaign/corpus/$t.tar.gz" -C "$work/saved/$t"
        fi
        line=$(nice -n 19 python3 fuzz/plateau.py "$t" --bin "$bin_dir/$t" \
            --work "$work" --seeds "$seeds/$t" --seeds "$work/saved/$t" \
            --state "$work/state/$t.json" --build-id "$build_id" \
            --min 30 --max "$max" --quiet "$quiet" \
            --min-total "$min_total" --max-gain "$max_gain")
        rc=$?
        echo "$line"
        if [ $rc -ne 0 ]; then
            echo "fuzz_plateau: FINDING in $t (fuzz/artifacts/$t/)" >&2
            done_[$t]=finding
        elif echo "$line" | grep -q '"plateau": true'; then
            done_[$t]=plateau
        fi
    done
    [ $left -eq 0 ] && break
done
echo "fuzz_plateau: every target reached a plateau or a finding" >&2
