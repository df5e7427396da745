#!/bin/bash
# Kill an MPI rank mid-job, then resume (issue 11, "kill one rank").
#
#   mpirun -n 2 orogen fill DEM -o out.tiles --store-tile 128 --engine mpi
# with rank 1 paused (crash point `store.delegated-tile.renamed`, which only
# ranks other than 0 reach: they write their own tiles into rank 0's store)
# after its N-th tile file, then `kill -9` of rank 1 (its pid from the pause
# file). Checks:
#   - mpirun exits non-zero, names rank 1, and rank 0's message names the
#     tiles it still waited for from rank 1 (including the paused one);
#   - the store does not look complete (manifest "complete": false);
#   - the rerun (no crash point) reports how many tiles it skipped and
#     gives a store byte-identical to the in-process run's.
# Usage: tools/mpi_kill.sh [--release] [--dem PATH] [--after N]
# (assumes `cargo build --features mpi` was run; tools/mpi_check.sh does it)
set -euo pipefail
cd "$(dirname "$0")/.."
profile=debug
dem=../shared/data/srtm3_N46E008.tif
after=10
while [ $# -gt 0 ]; do
    case "$1" in
    --release) profile=release ;;
    --dem) dem="$2"; shift ;;
    --after) after="$2"; shift ;;
    *) echo "usage: $0 [--release] [--dem PATH] [--after N]" >&2; exit 2 ;;
    esac
    shift
done
bin="$PWD/target/$profile/orogen"
dem=$(realpath "$dem")
mpirun_="mpirun --allow-run-as-root --oversubscribe"
work=$(mktemp -d -t orogen-mpi-kill.XXXXXX)
pid=""
cleanup() {
    if [ -n "$pid" ] && kill -0 "$pid" 2>/dev/null; then kill "$pid" 2>/dev/null || true; fi
    rm -rf "$work"
}
trap cleanup EXIT
fails=0
bad() { echo "FAIL: $*"; fails=$((fails + 1)); }

"$bin" fill "$dem" -o "$work/local.tiles" --store-tile 128 -q

# The killed run (in the background; rank 1 pauses at its N-th tile file).
set +e
OROGEN_CRASH_AT="store.delegated-tile.renamed:$after" OROGEN_CRASH_ACTION=pause \
    OROGEN_CRASH_SIGNAL="$work/rank" \
    $mpirun_ -x OROGEN_CRASH_AT -x OROGEN_CRASH_ACTION -x OROGEN_CRASH_SIGNAL -n 2 \
    "$bin" fill "$dem" -o "$work/mpi.tiles" --store-tile 128 -q --engine mpi \
    >"$work/killed.out" 2>"$work/killed.err" &
pid=$!
set -e
for _ in $(seq 600); do
    [ -s "$work/rank.paused" ] && break
    sleep 0.1
done
if [ ! -s "$work/rank.paused" ]; then
    bad "rank 1 never reached its crash point"
    cat "$work/killed.err"
    exit 1
fi
victim=$(cat "$work/rank.paused")
if ! grep -qz '^OMPI_COMM_WORLD_RANK=1$' "/proc/$victim/environ" 2>/dev/null; then
    bad "pid $victim is not rank 1"
fi
sleep 0.5 # let rank 0 reach the paused tile
kill -9 "$victim"
set +e
wait "$pid"
status=$?
set -e
pid=""
echo "killed run: exit status $status"
sed 's/^/  | /' "$work/killed.err"
[ "$status" != 0 ] || bad "the killed run exited 0"
grep -q "rank 1" "$work/killed.err" || bad "no message names rank 1"
grep -q "rank 1: [0-9]* tile(s) granted and not received: " "$work/killed.err" ||
    bad "rank 0 did not name the tiles it waited for from rank 1"
if grep -q '"complete": *true' "$work/mpi.tiles/manifest.json" 2>/dev/null; then
    bad "the store of the killed run looks complete"
fi

# mpirun may return while rank 0 (ended by its SIGTERM) is not yet reaped;
# its store lock is taken over only once that pid is gone.
owner=$(head -c 32 "$work/mpi.tiles/.lock" 2>/dev/null | tr -dc 0-9 || true)
for _ in $(seq 200); do
    if [ -z "$owner" ] || [ ! -e "/proc/$owner" ]; then break; fi
    sleep 0.1
done

# The rerun resumes and finishes with the in-process bytes.
$mpirun_ -n 2 "$bin" fill "$dem" -o "$work/mpi.tiles" --store-tile 128 --engine mpi \
    >"$work/rerun.out" 2>"$work/rerun.err" || bad "the rerun failed: $(cat "$work/rerun.err")"
grep "resuming" "$work/rerun.err" | sed 's/^/  | /' || true
grep -q "resuming: [1-9][0-9]* of [0-9]* tiles already finished (skipped)" "$work/rerun.err" ||
    bad "the rerun did not report the tiles it skipped"
if diff -r -x '.*' "$work/local.tiles" "$work/mpi.tiles" >/dev/null; then
    echo "rerun: store identical to the in-process run ($(ls "$work/local.tiles" | wc -l) files)"
else
    bad "the resumed store differs from the in-process one"
fi
if [ "$fails" != 0 ]; then
    echo "mpi_kill: $fails failure(s)"
    exit 1
fi
echo "mpi_kill: a killed rank ends the job naming rank and tiles; the rerun resumes to identical bytes"
