#!/usr/bin/env bash
# Slower end-to-end checks run by .ci/run after the test suite: the demo as a
# user runs it, GDAL cross-checks of every GeoTIFF variant, gdaldem agreement,
# crash-anywhere and I/O-error checks, the fuzz smoke, the MPI engine.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/install_gdal.sh
cargo build --release
export OROGEN="$PWD/target/release/orogen"
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT

echo "== every CLI output byte-identical to its recorded sha256 (tools/cli_golden.py)"
/usr/bin/python3 tools/cli_golden.py --bin "$OROGEN"

echo "== GeoJSON outputs placed by GDAL: lon/lat (RFC 7946) and --geojson-crs native (tools/geojson_crs_check.sh)"
OROGEN="$OROGEN" bash tools/geojson_crs_check.sh

echo "== demo"
"$OROGEN" demo -o "$tmp/demo" --quiet
for f in terrain.tif slope.tif aspect.tif hillshade.tif preview.png; do
  test -s "$tmp/demo/$f" || { echo "demo did not write $f"; exit 1; }
done
/usr/bin/python3 - "$tmp/demo" <<'PY'
import sys
from osgeo import gdal
d = sys.argv[1]
for f in ("terrain.tif", "slope.tif", "hillshade.tif"):
    ds = gdal.Open(f"{d}/{f}")
    assert ds is not None and ds.RasterXSize == 1024, f
print("demo outputs open in GDAL")
PY

echo "== GeoTIFF variants read and written, against GDAL"
bash tools/gdal_variants.sh

echo "== slope/aspect/hillshade against gdaldem"
bash tools/gdaldem_compare.sh

echo "== Cloud-Optimized GeoTIFFs against GDAL's validator"
bash tools/cog_validate.sh

echo "== web tiles in the viewer (headless Chromium) and read back by independent readers"
bash tools/viewer_e2e.sh

echo "== orometric synthesis keeps its divide tree (CLI: divide-tree, from-tree, peaks)"
/usr/bin/python3 tools/oro_roundtrip.py --bin "$OROGEN" --seeds 1 2 3 4 5 6 --max-bad 0 --work "$tmp/oro"
/usr/bin/python3 tools/oro_roundtrip.py --bin "$OROGEN" --seeds 1 2 --store --max-bad 0 --work "$tmp/oro_store"

echo "== crash anywhere: a real job killed at 60 seeded points and rerun (tools/crash_harness.py)"
/usr/bin/python3 tools/crash_harness.py --trials 60 --seed 2611 --bin "$OROGEN"

echo "== I/O errors: disk full, read-only folder, input deleted mid-run (tools/io_errors.sh)"
mkdir -p "$tmp/probe"
if [ "$(id -u)" = 0 ] && mount -t tmpfs -o size=64k tmpfs "$tmp/probe" 2>/dev/null; then
  umount "$tmp/probe"
  bash tools/io_errors.sh
else
  echo "io_errors: skipped (it mounts tmpfs: needs root and the right to mount)"
fi

echo "== fuzz smoke: every cargo-fuzz target from its committed seeds (fails on any finding)"
# Installs cargo-fuzz if missing, builds fuzz/ unoptimised without a
# sanitizer, runs each target SECONDS_PER_TARGET (15) s; times in RELIABILITY.md.
fuzz_t0=$(date +%s)
bash tools/fuzz_smoke.sh
echo "fuzz smoke: $(( $(date +%s) - fuzz_t0 )) s"

echo "== MPI engine (--features mpi): mpirun -n 1|2|4 against the in-process engine"
# Last: it rebuilds target/release/orogen with the mpi feature.
bash tools/mpi_check.sh --release --ranks "1 2 4"
