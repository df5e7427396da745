#!/bin/bash
# MPI strong scaling 1 -> 2 ranks on the Poland mosaic (tiles of 1024, one
# thread per rank), for one or more orogen binaries built with --features mpi
# (e.g. this branch and a build of an older commit), runs interleaved so they
# share the machine's load:
#   fill -> GeoTIFF, fill -> tile store, D8 accumulation -> tile store.
# Every MPI output is compared with the in-process one of the first binary
# (GeoTIFFs with cmp, stores file by file). Prints one line per run: binary,
# step, ranks, wall seconds, load average at the start.
# Usage: tools/mpi_scaling.sh [--rounds N] BIN [BIN...]
set -euo pipefail
cd "$(dirname "$0")/.."
rounds=1
if [ "${1:-}" = --rounds ]; then rounds="$2"; shift 2; fi
[ $# -ge 1 ] || { echo "usage: $0 [--rounds N] BIN [BIN...]" >&2; exit 2; }
D=$(realpath ../shared/data/poland_N49-55_E014-025.tif)
M="mpirun --allow-run-as-root --oversubscribe"
work=$(mktemp -d -t orogen-mpi-scaling.XXXXXX)
trap 'rm -rf "$work"' EXIT
ref="$1"
fails=0
"$ref" fill "$D" -o "$work/ref.tif" --tile 1024 -q --threads 2
"$ref" fill "$D" -o "$work/ref.tiles" --store-tile 1024 -q --threads 2
"$ref" flow "$work/ref.tif" -o "$work/d8.tif" --tile 1024 -q --threads 2
"$ref" accumulate "$work/d8.tif" -o "$work/refacc.tiles" --store-tile 1024 -q --threads 2

same() {
    if [ -d "$1" ]; then diff -r -x '.*' "$1" "$2" >/dev/null; else cmp -s "$1" "$2"; fi
}

run() { # label ref out command...
    local label="$1" want="$2" out="$3"
    shift 3
    rm -rf "$out"
    local load t0 t1
    load=$(cut -d' ' -f1 /proc/loadavg)
    t0=$(date +%s.%N)
    "$@"
    t1=$(date +%s.%N)
    local ok=identical
    if ! same "$want" "$out"; then ok=DIFFERENT; fails=$((fails + 1)); fi
    printf '%-48s %6.1f s  load %s  %s\n' "$label" "$(echo "$t1 - $t0" | bc)" "$load" "$ok"
}

for round in $(seq "$rounds"); do
    for n in 1 2; do
        for b in "$@"; do
            tag=$(basename "$b")
            run "$tag fill -> GeoTIFF, $n rank(s)" "$work/ref.tif" "$work/m.tif" \
                $M -n $n "$b" fill "$D" -o "$work/m.tif" --tile 1024 -q --threads 1 --engine mpi
            run "$tag fill -> store, $n rank(s)" "$work/ref.tiles" "$work/m.tiles" \
                $M -n $n "$b" fill "$D" -o "$work/m.tiles" --store-tile 1024 -q --threads 1 --engine mpi
            run "$tag D8 accumulation -> store, $n rank(s)" "$work/refacc.tiles" "$work/a.tiles" \
                $M -n $n "$b" accumulate "$work/d8.tif" -o "$work/a.tiles" --store-tile 1024 -q --threads 1 --engine mpi
        done
    done
    echo "(round $round done)"
done
if [ "$fails" != 0 ]; then
    echo "mpi_scaling: $fails output(s) differ"
    exit 1
fi
