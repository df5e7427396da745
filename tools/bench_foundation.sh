#!/usr/bin/env bash
# Whole-command timings and peak memory on the Poland mosaic (13201x7201),
# orogen against GDAL in the same run. Prints a table with ratios; paste it
# into docs/PERFORMANCE.md with the date and machine.
#   bash tools/bench_foundation.sh [THREADS]
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/install_gdal.sh
cargo build --release -q
OROGEN="$PWD/target/release/orogen"
DEM=../shared/data/poland_N49-55_E014-025.tif
THREADS=${1:-0}
tmp=${TMPDIR:-/tmp}/orogen-bench; rm -rf "$tmp"; mkdir -p "$tmp"; trap 'rm -rf "$tmp"' EXIT

# run LABEL CMD...: wall seconds and peak RSS (MiB) via GNU time
run() {
  local label=$1; shift
  sync; echo 3 > /proc/sys/vm/drop_caches 2>/dev/null || true
  cat "$DEM" > /dev/null   # same warm input cache for every command
  /usr/bin/time -f "%e %M" -o "$tmp/time" "$@" > /dev/null 2> "$tmp/err" || { cat "$tmp/err"; exit 1; }
  read -r secs kib < "$tmp/time"
  printf "%-44s %8.2f s %8.0f MiB\n" "$label" "$secs" "$((kib / 1024))"
  echo "$secs" > "$tmp/last"
}
echo "threads=$THREADS  $(nproc) cores  $(date -u +%F)"
run "orogen ingest --memory 256MiB" "$OROGEN" ingest "$DEM" -o "$tmp/p.tiles" --memory 256MiB --threads "$THREADS" -q
t_ingest=$(cat "$tmp/last")
run "gdal_translate -> tiled uncompressed tif" gdal_translate -q -co TILED=YES "$DEM" "$tmp/g.tif"
t_gt=$(cat "$tmp/last")
run "orogen export store -> tif (deflate)" "$OROGEN" export "$tmp/p.tiles" -o "$tmp/e.tif" --threads "$THREADS" -q
run "orogen slope tif -> tif (uncompressed)" "$OROGEN" slope "$DEM" -o "$tmp/s.tif" --compress none --threads "$THREADS" -q
t_slope=$(cat "$tmp/last")
run "orogen slope store -> tif (uncompressed)" "$OROGEN" slope "$tmp/p.tiles" -o "$tmp/s2.tif" --compress none --threads "$THREADS" -q
run "gdaldem slope -s 111120" gdaldem slope -q -s 111120 "$DEM" "$tmp/gs.tif"
t_gslope=$(cat "$tmp/last")
run "orogen aspect tif -> tif (uncompressed)" "$OROGEN" aspect "$DEM" -o "$tmp/a.tif" --compress none --threads "$THREADS" -q
t_aspect=$(cat "$tmp/last")
run "gdaldem aspect -s 111120" gdaldem aspect -q -s 111120 "$DEM" "$tmp/ga.tif"
t_gaspect=$(cat "$tmp/last")
run "orogen hillshade tif -> tif" "$OROGEN" hillshade "$DEM" -o "$tmp/h.tif" --compress none --threads "$THREADS" -q
run "gdaldem hillshade -s 111120" gdaldem hillshade -q -s 111120 "$DEM" "$tmp/gh.tif"
awk -v a="$t_gt" -v b="$t_ingest" -v c="$t_gslope" -v d="$t_slope" -v e="$t_gaspect" -v f="$t_aspect" 'BEGIN {
  printf "ingest: gdal_translate/orogen = %.2fx ; slope: gdaldem/orogen = %.2fx ; aspect: gdaldem/orogen = %.2fx\n", a/b, c/d, e/f }'
