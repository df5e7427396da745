#!/usr/bin/env bash
# Fuzz smoke run (issue 12): every cargo-fuzz target for a few seconds from
# the committed seed corpus in fuzz/corpus/<target>/. New inputs go to a
# scratch directory (the committed seeds are not touched). Exits non-zero
# on the first finding (crash, timeout, leak, allocation over the bound);
# the reproducer is left in fuzz/artifacts/<target>/.
#
#   tools/fuzz_smoke.sh            # all targets, 20 s each
#   SECONDS_PER_TARGET=60 tools/fuzz_smoke.sh geotiff png
#
# The toolchain is stable; cargo-fuzz needs -Z flags, hence RUSTC_BOOTSTRAP.
# SANITIZER=address (default) makes -malloc_limit_mb catch single huge
# allocations; SANITIZER=none builds faster but only the RSS limit applies.
# Builds are unoptimised (--dev: a short smoke run is dominated by compile
# time); FUZZ_RELEASE=1 builds optimised targets for long runs.
set -euo pipefail
cd "$(dirname "$0")/.."

secs="${SECONDS_PER_TARGET:-20}"
san="${SANITIZER:-address}"
prof=(--dev)
[ -n "${FUZZ_RELEASE:-}" ] && prof=()
export RUSTC_BOOTSTRAP=1

if ! cargo fuzz --version >/dev/null 2>&1; then
    echo "fuzz_smoke: installing cargo-fuzz" >&2
    cargo install --locked cargo-fuzz
fi

targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
    mapfile -t targets < <(cargo fuzz list)
fi

cargo fuzz build "${prof[@]}" -s "$san"

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
