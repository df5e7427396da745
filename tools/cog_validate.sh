#!/usr/bin/env bash
# Writes Cloud-Optimized GeoTIFFs with orogen from real DEMs (an int16 SRTM
# tile, float slope, u8 D8 codes with nearest overviews, a zstd BigTIFF) and
# checks each with GDAL's own validator (python3-gdal's
# validate_cloud_optimized_geotiff, --full-check=yes: block order, leaders,
# trailers). Needs ../shared/data; installs GDAL through tools/install_gdal.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/install_gdal.sh
OROGEN=${OROGEN:-target/release/orogen}
[ -x "$OROGEN" ] || cargo build --release
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
dem=../shared/data/srtm3_S33W071.tif
validate() {
  local out
  out=$(/usr/bin/python3 -m osgeo_utils.samples.validate_cloud_optimized_geotiff --full-check=yes "$1" 2>&1 || true)
  case "$out" in
    *"is a valid cloud optimized GeoTIFF"*) ;;
    *) echo "FAIL: $1 is not a valid COG:"; echo "$out"; exit 1 ;;
  esac
  echo "valid COG: $(basename "$1") ($(gdalinfo "$1" | grep -c 'Overviews:' ) overview line, $(stat -c %s "$1") bytes)"
}
"$OROGEN" export "$dem" -o "$tmp/dem.tif" --cog -q
validate "$tmp/dem.tif"
"$OROGEN" slope "$dem" -o "$tmp/slope.tif" --cog --block 512 -q
validate "$tmp/slope.tif"
"$OROGEN" fill "$dem" -o "$tmp/filled.tif" -q
"$OROGEN" flow "$tmp/filled.tif" -o "$tmp/d8.tif" --cog --overviews nearest -q
validate "$tmp/d8.tif"
"$OROGEN" export "$dem" -o "$tmp/big.tif" --cog --compress zstd --bigtiff yes -q
validate "$tmp/big.tif"
# GDAL reads the same full-resolution values as orogen's plain GeoTIFF.
"$OROGEN" export "$dem" -o "$tmp/plain.tif" -q
/usr/bin/python3 - "$tmp/dem.tif" "$tmp/plain.tif" <<'PY'
import sys
from osgeo import gdal
ds = [gdal.Open(p) for p in sys.argv[1:3]]  # keep datasets alive while bands are used
a, b = (d.GetRasterBand(1) for d in ds)
assert a.ReadRaster() == b.ReadRaster(), "COG full resolution differs from the plain GeoTIFF"
assert a.GetOverviewCount() >= 1
print("COG full resolution identical to the plain GeoTIFF; overviews:",
      [(a.GetOverview(i).XSize, a.GetOverview(i).YSize) for i in range(a.GetOverviewCount())])
PY
