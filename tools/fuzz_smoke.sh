#!/usr/bin/env bash
# Fuzz smoke run (issue 12; run by tools/e2e.sh in CI): every cargo-fuzz
# target for a few seconds from the committed seed corpus in
# fuzz/corpus/<target>/. New inputs go to a scratch directory (the committed
# seeds are not touched). Exits non-zero on any finding (crash, panic,
# timeout, out-of-memory); the reproducer is left in fuzz/artifacts/<target>/.
#
#   tools/fuzz_smoke.sh            # all targets, SECONDS_PER_TARGET (15) each
#   SECONDS_PER_TARGET=60 tools/fuzz_smoke.sh geotiff png
#
# The toolchain is stable; cargo-fuzz passes -Z flags, hence RUSTC_BOOTSTRAP.
# cargo-fuzz is installed (pinned, --locked) when missing.
#
# Build: by default unoptimised and without a sanitizer (`--dev -s none`):
# the cheapest build that still fuzzes (coverage instrumentation, libFuzzer,
# debug assertions so integer overflows panic); measured on the shared
# 2-core machine against the optimised `-s none` build (docs/RELIABILITY.md).
# The code is safe Rust apart from memory maps, so AddressSanitizer adds
# little for a smoke run; without it `-malloc_limit_mb` does not apply and
# the RSS limit (-rss_limit_mb) catches runaway allocations.
# SANITIZER=address and FUZZ_RELEASE=1 select the other builds;
# FUZZ_TARGET_DIR another build folder than fuzz/target.
set -euo pipefail
cd "$(dirname "$0")/.."

secs="${SECONDS_PER_TARGET:-15}"
san="${SANITIZER:-none}"
prof=(--dev)
[ -n "${FUZZ_RELEASE:-}" ] && prof=(--release)
[ -n "${FUZZ_TARGET_DIR:-}" ] && prof+=(--target-dir "$FUZZ_TARGET_DIR")
cargo_fuzz_version="0.13.2"
export RUSTC_BOOTSTRAP=1

if ! cargo fuzz --version 2>/dev/null | grep -q "$cargo_fuzz_version"; then
    echo "fuzz_smoke: installing cargo-fuzz $cargo_fuzz_version" >&2
    t0=$(date +%s)
    cargo install --locked cargo-fuzz --version "$cargo_fuzz_version"
    echo "fuzz_smoke: cargo-fuzz installed in $(( $(date +%s) - t0 )) s" >&2
fi

targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
    mapfile -t targets < <(cargo fuzz list)
fi

t0=$(date +%s)
cargo fuzz build "${prof[@]}" -s "$san"
echo "fuzz_smoke: build (${prof[*]} -s $san) took $(( $(date +%s) - t0 )) s" >&2

scratch="$(mktemp -d)"
trap 'rm -rf "$scratch"' EXIT
status=0
for t in "${targets[@]}"; do
    mkdir -p "$scratch/$t"
    echo "== fuzz_smoke: $t (${secs}s)" >&2
    if ! cargo fuzz run "${prof[@]}" -s "$san" "$t" "$scratch/$t" "fuzz/corpus/$t" -- \
        -max_total_time="$secs" -rss_limit_mb=2048 -malloc_limit_mb=1024 \
        -timeout=60 -print_final_stats=1 2>"$scratch/$t.log"; then
        echo "fuzz_smoke: FINDING in target $t (see fuzz/artifacts/$t/):" >&2
        tail -n 40 "$scratch/$t.log" >&2
        status=1
        continue
    fi
    grep -E '^#[0-9]+.*DONE|stat::number_of_executed_units' "$scratch/$t.log" >&2 || true
done
exit $status
