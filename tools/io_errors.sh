#!/usr/bin/env bash
# I/O-error checks (issue 12) that need root: disk full (a small tmpfs), a
# read-only output folder (a tmpfs mounted read-only: permissions do not stop
# root), plus an input deleted while a command runs. Each case must give one
# clear error naming the file, a non-zero exit, no partial output presented
# as complete, and a rerun after the condition is fixed must complete with
# the same bytes as a run that never failed.
#
#   sudo tools/io_errors.sh        # OROGEN=path/to/orogen to pick the binary
set -euo pipefail
cd "$(dirname "$0")/.."
. tools/lib.sh
OROGEN="${OROGEN:-$PWD/target/debug/orogen}"
DEM="$PWD/tests/data/whitebox_DEM.tif" # 237 x 188 f32: 178 KB of cells
[ "$(id -u)" = 0 ] || { echo "io_errors: needs root (mounts tmpfs)"; exit 2; }

work=$(mktemp -d)
mnt="$work/mnt"
mkdir -p "$mnt"
cleanup() { umount "$mnt" 2>/dev/null || true; rm -rf "$work"; }
trap cleanup EXIT
fails=0
pass() { echo "PASS: $*"; }
fail() { echo "FAIL: $*"; fails=$((fails + 1)); }

# expect_error LOG NEEDLE...: the command failed and its stderr names each needle.
expect_error() {
  local log=$1; shift
  for n in "$@"; do
    grep -qF -- "$n" "$log" || { fail "error does not mention '$n': $(cat "$log")"; return 1; }
  done
  if grep -q panicked "$log"; then fail "panic: $(cat "$log")"; return 1; fi
  return 0
}

# References, written where there is room.
"$OROGEN" slope "$DEM" -o "$work/ref.tif" --compress none -q
"$OROGEN" slope "$DEM" -o "$work/ref.tiles" --store-tile 32 -q

echo "== disk full: GeoTIFF output"
mount -t tmpfs -o size=96k tmpfs "$mnt"
if "$OROGEN" slope "$DEM" -o "$mnt/s.tif" --compress none -q 2>"$work/err"; then
  fail "slope into a full disk succeeded"
else
  expect_error "$work/err" "No space left" "s.tif" "free disk space" && pass "disk full: one error naming the file: $(head -c 300 "$work/err")"
fi
left=$(ls -A "$mnt")
[ -z "$left" ] && pass "disk full: nothing left behind" || fail "disk full left: $left"
mount -o remount,size=4m "$mnt"
"$OROGEN" slope "$DEM" -o "$mnt/s.tif" --compress none -q
cmp -s "$mnt/s.tif" "$work/ref.tif" && pass "disk full: rerun after freeing space gives the reference bytes" || fail "rerun differs"
umount "$mnt"

echo "== disk full: tile store output"
mount -t tmpfs -o size=96k tmpfs "$mnt"
if "$OROGEN" slope "$DEM" -o "$mnt/s.tiles" --store-tile 32 -q 2>"$work/err"; then
  fail "store into a full disk succeeded"
else
  expect_error "$work/err" "No space left" "s.tiles" "free disk space" && pass "disk full (store): $(head -c 300 "$work/err")"
fi
if "$OROGEN" info "$mnt/s.tiles" >/dev/null 2>"$work/err2"; then
  fail "a store cut short by a full disk opens as finished"
else
  expect_error "$work/err2" "unfinished tile store" && pass "disk full (store): the partial store is refused by readers"
fi
done_before=$(ls "$mnt/s.tiles" | grep -c '^t_.*\.bin$' || true)
mount -o remount,size=4m "$mnt"
"$OROGEN" slope "$DEM" -o "$mnt/s.tiles" --store-tile 32 -q
if diff -r "$mnt/s.tiles" "$work/ref.tiles" >/dev/null; then
  pass "disk full (store): rerun resumed ($done_before tiles were kept) and matches the reference"
else
  fail "store rerun differs: $(diff -rq "$mnt/s.tiles" "$work/ref.tiles" | head -5)"
fi
umount "$mnt"

echo "== disk full: a job"
mount -t tmpfs -o size=160k tmpfs "$mnt"
job_fixture ingest_slope.toml OUT="$mnt/out" DEM="$DEM" >"$work/job.toml"
if "$OROGEN" run "$work/job.toml" -q 2>"$work/err"; then
  fail "job into a full disk succeeded"
else
  expect_error "$work/err" "No space left" "rerun the job" && pass "disk full (job): $(tail -c 400 "$work/err" | tr '\n' ' ')"
fi
[ ! -e "$mnt/out/s.tif" ] && pass "disk full (job): no s.tif" || fail "disk full (job): s.tif present"
mount -o remount,size=4m "$mnt"
"$OROGEN" run "$work/job.toml" -q
cmp -s "$mnt/out/s.tif" "$work/ref.tif" && pass "disk full (job): rerun completes, reference bytes" || fail "job rerun differs"
umount "$mnt"

echo "== read-only output folder"
mount -t tmpfs -o size=4m,ro tmpfs "$mnt"
for out in s.tif s.tiles; do
  if "$OROGEN" slope "$DEM" -o "$mnt/$out" -q 2>"$work/err"; then
    fail "slope into a read-only folder succeeded ($out)"
  else
    expect_error "$work/err" "Read-only file system" "$out" "choose a writable output folder" && pass "read-only ($out): $(head -c 300 "$work/err")"
  fi
done
mount -o remount,rw "$mnt"
"$OROGEN" slope "$DEM" -o "$mnt/s.tif" --compress none -q
cmp -s "$mnt/s.tif" "$work/ref.tif" && pass "read-only: rerun after remounting read-write completes" || fail "read-only rerun differs"
umount "$mnt"

echo "== input deleted while a command runs"
mkdir -p "$work/del"
"$OROGEN" ingest "$DEM" -o "$work/del/in.tiles" --store-tile 32 -q
# Reference from the same input path (a store's provenance names its input).
"$OROGEN" slope "$work/del/in.tiles" -o "$work/del/ref.tiles" --store-tile 32 -q
OROGEN_CRASH_AT=store.tile.renamed:2 OROGEN_CRASH_ACTION=pause OROGEN_CRASH_SIGNAL="$work/sig" \
  "$OROGEN" slope "$work/del/in.tiles" -o "$work/del/s.tiles" --store-tile 32 --threads 1 -q 2>"$work/err" &
pid=$!
for _ in $(seq 1 600); do [ -e "$work/sig.paused" ] && break; sleep 0.1; done
rm "$work/del/in.tiles/t_4_5.bin"
touch "$work/sig.resume"
if wait $pid; then
  fail "slope went on with a deleted input tile"
else
  expect_error "$work/err" "t_4_5.bin" && pass "deleted input tile: $(head -c 300 "$work/err")"
fi
"$OROGEN" info "$work/del/s.tiles" >/dev/null 2>&1 && fail "partial output opens as finished" || pass "deleted input: the partial output is refused by readers"
"$OROGEN" ingest "$DEM" -o "$work/del/in.tiles" --store-tile 32 -q
"$OROGEN" slope "$work/del/in.tiles" -o "$work/del/s.tiles" --store-tile 32 -q
diff -r "$work/del/s.tiles" "$work/del/ref.tiles" >/dev/null && pass "deleted input: rerun after restoring the input matches the reference" || fail "deleted-input rerun differs"

echo "== io_errors: $fails failure(s)"
exit $((fails > 0))
