#!/usr/bin/env bash
# Out-of-core hydrology at scale: generate a seeded SIZE x SIZE DEM straight
# into a tile store (examples/gen_big_dem.rs: fBm + sea at 0 + pits, 1 m
# steps), then time fill, flow (D8), accumulate and slope on it with GNU
# time (wall, peak RSS). Outputs are deleted at the end (KEEP=1 keeps them).
#   bash tools/hydro_scale.sh [SIZE=50000] [MEMORY=1GiB] [WORKDIR=/tmp/orogen-scale]
# Disk: at most SIZE^2 x 13 bytes at once (DEM f32 + D8 u8 + accumulation
# f64; the filled DEM is deleted after flow, the accumulation before slope),
# e.g. 32.5 GB at 50000, 5.2 GB at 20000; the script refuses if df says less.
set -euo pipefail
cd "$(dirname "$0")/.."
SIZE=${1:-50000}
MEM=${2:-1GiB}
WORK=${3:-${TMPDIR:-/tmp}/orogen-scale}
need=$((SIZE * SIZE * 13 / 1024 / 1024))
mkdir -p "$WORK"
avail=$(df -Pm "$WORK" | awk 'NR==2 {print $4}')
if [ "$avail" -lt "$need" ]; then
  echo "need ~${need} MiB free in $WORK, have ${avail} MiB; try a smaller SIZE" >&2
  exit 1
fi
cargo build --release -q --bin orogen --example gen_big_dem
B="$PWD/target/release/orogen"
G="$PWD/target/release/examples/gen_big_dem"
[ "${KEEP:-0}" = 1 ] || trap 'rm -rf "$WORK"/*.tiles' EXIT

run() {
  local label=$1; shift
  /usr/bin/time -f "%e %M %U %S" -o "$WORK/time" "$@" > /dev/null 2> "$WORK/err" || { cat "$WORK/err"; exit 1; }
  read -r secs kib usr sys < "$WORK/time"
  printf "| %-58s | %8.1f s | %8.1f s | %6d MiB |\n" "$label" "$secs" "$(echo "$usr + $sys" | bc)" "$((kib / 1024))"
}
echo "SIZE=$SIZE ($((SIZE * SIZE / 1000000)) Mcells), memory $MEM, $(nproc) cores, $(date -u '+%F %H:%M') UTC"
echo "| command | wall | CPU | peak RSS |"
echo "|---|---|---|---|"
run "gen_big_dem $SIZE $SIZE 42 dem.tiles" "$G" "$SIZE" "$SIZE" 42 "$WORK/dem.tiles" 1 512
run "orogen fill dem.tiles -o filled.tiles --memory $MEM" "$B" fill "$WORK/dem.tiles" -o "$WORK/filled.tiles" --memory "$MEM" -q
run "orogen flow filled.tiles -o d8.tiles --memory $MEM" "$B" flow "$WORK/filled.tiles" -o "$WORK/d8.tiles" --memory "$MEM" -q
rm -rf "$WORK/filled.tiles"
run "orogen accumulate d8.tiles -o acc.tiles --memory $MEM" "$B" accumulate "$WORK/d8.tiles" -o "$WORK/acc.tiles" --memory "$MEM" -q
rm -rf "$WORK/acc.tiles"
run "orogen slope dem.tiles -o slope.tiles --memory $MEM" "$B" slope "$WORK/dem.tiles" -o "$WORK/slope.tiles" --memory "$MEM" -q
