#!/usr/bin/env bash
# Cross-check orogen's GeoTIFF reader and writer against GDAL.
#
#   tools/gdal_variants.sh              compare on full-size DEMs from ../shared/data
#   tools/gdal_variants.sh --fixtures   (re)write the small fixtures in tests/data/gdal/
#   tools/gdal_variants.sh --band-fixtures   (re)write the multi-band / photometric ones in tests/data/gdal/bands/
#   tools/gdal_variants.sh --cases           compare only the mask/alpha/sparse/float16/LERC/georef cases
#   tools/gdal_variants.sh --case-fixtures   (re)write masks, alpha, sparse, float16, georeferencing in tests/data/gdal/cases/
#   tools/gdal_variants.sh --scaled-fixtures (re)write bands with scale/offset and GDAL's unscaled values in tests/data/gdal/scaled/
#
# orogen is driven through its CLI (`orogen info FILE --json`, `orogen export IN -o OUT
# [--compress ..] [--predictor ..] [--block ..] [--bigtiff ..]`): set $OROGEN to a built
# binary, otherwise `cargo run --release --bin orogen --` is used.
# Prints "N passed, M failed" and exits non-zero on any failure.
set -euo pipefail
cd "$(dirname "$0")/.."

# GDAL with its Python bindings (idempotent).
py=""
for c in /usr/bin/python3 python3; do
    if command -v "$c" >/dev/null 2>&1 && "$c" -c 'from osgeo import gdal; import numpy' 2>/dev/null; then
        py="$c"; break
    fi
done
if [ -z "$py" ] || ! command -v gdal_translate >/dev/null 2>&1; then
    echo "installing gdal-bin python3-gdal ..." >&2
    SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
    $SUDO apt-get install -y gdal-bin python3-gdal >/dev/null 2>&1 \
        || { $SUDO apt-get update >/dev/null && $SUDO apt-get install -y gdal-bin python3-gdal >/dev/null; }
    py=/usr/bin/python3
fi

if [ -z "${OROGEN:-}" ]; then
    cargo build --release --bin orogen >&2
    OROGEN="$(pwd)/target/release/orogen"
fi
export OROGEN
exec "$py" tools/gdal_compare.py "$@"
