#!/usr/bin/env bash
# Peaks tiled == in memory on the real DEMs of ../shared/data, and the
# figures for docs/PERFORMANCE.md (wall time, peak RSS via GNU time).
#   bash tools/peaks_tiled_check.sh [DEM...]
# Default DEMs: Aconcagua (srtm3_S33W071.tif) and the Poland mosaic.
# For each DEM: `orogen peaks` in memory (--memory 8GiB) and tile by tile
# (--memory 512MiB --tiled), both at --min-prominence 30 with isolation;
# every output file must be identical byte for byte.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -q
OROGEN="$PWD/target/release/orogen"
if [ $# -eq 0 ]; then
  set -- ../shared/data/srtm3_S33W071.tif ../shared/data/poland_N49-55_E014-025.tif
fi
tmp=${TMPDIR:-/tmp}/orogen-peaks; rm -rf "$tmp"; mkdir -p "$tmp"; trap 'rm -rf "$tmp"' EXIT
run() {
  local label=$1; shift
  /usr/bin/time -f "%e %M" -o "$tmp/time" "$@" > /dev/null 2> "$tmp/err" || { cat "$tmp/err"; exit 1; }
  read -r secs kib < "$tmp/time"
  printf "  %-28s %8.2f s %8.0f MiB\n" "$label" "$secs" "$((kib / 1024))"
}
for dem in "$@"; do
  [ -f "$dem" ] || { echo "skip $dem (absent)"; continue; }
  echo "$(basename "$dem")  ($(nproc) cores, $(date -u +%F))"
  run "in memory (--memory 8GiB)" "$OROGEN" peaks "$dem" --min-prominence 30 --memory 8GiB -q -o "$tmp/mem"
  run "tiled (--memory 512MiB)" "$OROGEN" peaks "$dem" --min-prominence 30 --memory 512MiB --tiled -q -o "$tmp/tiled"
  for f in peaks.csv peaks.geojson saddles.geojson divide_tree.geojson divide_tree.json; do
    cmp -s "$tmp/mem/$f" "$tmp/tiled/$f" || { echo "  DIFFER: $f"; exit 1; }
  done
  echo "  identical: $(($(wc -l < "$tmp/mem/peaks.csv") - 1)) peaks >= 30 m, all 5 files"
done
