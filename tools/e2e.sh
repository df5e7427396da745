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
/usr/bin/python3 tools/demo_check.py "$tmp/demo"

echo "== GeoTIFF variants read and written, against GDAL"
bash tools/gdal_variants.sh

echo "== slope/aspect/hillshade against gdaldem"
bash tools/gdaldem_compare.sh

echo "== Cloud-Optimized GeoTIFFs against GDAL's validator"
bash tools/cog_validate.sh

echo "== web tiles in the viewer (headless Chromium) and read back by independent readers"
bash tools/viewer_e2e.sh

# The peers from the package registries, each with its gates (exit 1 past
# one); a peer that cannot be installed is an error here, not a skip.
export OROGEN_REQUIRE_PEERS=1
echo "== hydrology against RichDEM, pysheds, SAGA and GRASS (tools/hydro_peers.sh)"
OROGEN_BIN="$OROGEN" bash tools/hydro_peers.sh

echo "== descriptors against GRASS and SAGA (tools/descriptor_peers.sh)"
OROGEN="$OROGEN" bash tools/descriptor_peers.sh

echo "== stream power against fastscapelib (tools/fastscape_compare.sh)"
bash tools/fastscape_compare.sh
bash tools/fastscape_compare.sh --start noise --size 256 --steps 50
bash tools/fastscape_compare.sh --tiled --tile 200 --steps 40 --threads 2

echo "== orometric synthesis keeps its divide tree (CLI: divide-tree, from-tree, peaks)"
/usr/bin/python3 tools/oro_roundtrip.py --bin "$OROGEN" --seeds 1 2 3 4 5 6 --max-bad 0 --work "$tmp/oro"
/usr/bin/python3 tools/oro_roundtrip.py --bin "$OROGEN" --seeds 1 2 --store --max-bad 0 --work "$tmp/oro_store"

echo "== crash anywhere: a real job killed at 60 seeded points and rerun (tools/crash_harness.py)"
/usr/bin/python3 tools/crash_harness.py --trials 60 --seed 2611 --bin "$OROGEN"

echo "== I/O errors: disk full, read-only folder, input deleted mid-run (tools/io_errors.sh)"
# It mounts small tmpfs folders: as root directly, else in a user and mount
# namespace (unshare -rm) where the kernel allows one. Neither: an error
# (OROGEN_CI_NO_MOUNT=1 states that this machine cannot run it).
mkdir -p "$tmp/probe"
if [ "$(id -u)" = 0 ] && mount -t tmpfs -o size=64k tmpfs "$tmp/probe" 2>/dev/null; then
  umount "$tmp/probe"
  OROGEN="$OROGEN" bash tools/io_errors.sh
elif unshare -rm true 2>/dev/null; then
  OROGEN="$OROGEN" unshare -rm bash tools/io_errors.sh
elif [ "${OROGEN_CI_NO_MOUNT:-0}" = 1 ]; then
  echo "io_errors: not run: this machine cannot mount tmpfs (OROGEN_CI_NO_MOUNT=1)"
else
  echo "error: tools/io_errors.sh cannot run: it mounts tmpfs, which needs root or unprivileged user namespaces (unshare -rm); set OROGEN_CI_NO_MOUNT=1 to run the rest without it" >&2
  exit 1
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
