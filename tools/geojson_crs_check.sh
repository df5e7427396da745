#!/usr/bin/env bash
# GeoJSON outputs placed by GDAL (docs/design/geojson-crs.md): every GeoJSON
# the analysis commands write from a UTM DEM (tests/data/bigtujunga_crop.tif,
# EPSG:32611) -- peaks, saddles, divide tree, ridges, stream links and nodes,
# basin outlines -- is read by `ogrinfo -al -so` as WGS 84 (EPSG:4326) with
# an extent inside the DEM's lon/lat bounds; with --geojson-crs native ogrinfo
# reports the DEM's UTM zone, the extent lies inside the DEM's projected
# bounds and the coordinates equal peaks.csv's projected x/y; a geographic DEM
# (srtm3_N46E008_crop.tif) writes the same bytes in both modes; a DEM in a
# CRS orogen cannot project (EPSG:2056, made with gdal_translate -a_srs) fails
# with the fix named and writes nothing.
#   bash tools/geojson_crs_check.sh            (OROGEN=path/to/orogen to skip the build)
set -euo pipefail
cd "$(dirname "$0")/.."
command -v ogrinfo > /dev/null || bash tools/install_gdal.sh
if [ -z "${OROGEN:-}" ]; then
  cargo build --release -q
  OROGEN="$PWD/target/release/orogen"
fi
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
BT=tests/data/bigtujunga_crop.tif
GEO=tests/data/oro/srtm3_N46E008_crop.tif

run() { "$OROGEN" "$@" -q > "$tmp/log" 2>&1 || { cat "$tmp/log"; exit 1; }; }

for mode in wgs84 native; do
  d="$tmp/$mode"; mkdir -p "$d"
  run peaks "$BT" --min-prominence 20 --geojson-crs "$mode" -o "$d/peaks"
  run ridges "$BT" --min-prominence 20 --no-ppa --geojson-crs "$mode" -o "$d/ridges"
  run fill "$BT" -o "$d/filled.tif"
  run flow "$d/filled.tif" -o "$d/d8.tif"
  run streams "$d/d8.tif" --threshold 50 --geojson-crs "$mode" -o "$d/streams.geojson" --nodes "$d/nodes.geojson"
  run basins "$d/d8.tif" -o "$d/basins.tif" --metrics "$d/bm.csv" --dem "$d/filled.tif" --min-cells 500 --geojson-crs "$mode"
done

/usr/bin/python3 - "$tmp" "$BT" <<'PY'
import json, re, subprocess, sys
tmp, dem = sys.argv[1], sys.argv[2]
info = json.loads(subprocess.check_output(["gdalinfo", "-json", dem]))
ring = info["wgs84Extent"]["coordinates"][0]
lon = [p[0] for p in ring]; lat = [p[1] for p in ring]
ll_box = (min(lon), min(lat), max(lon), max(lat))
cc = info["cornerCoordinates"]
xy_box = (cc["upperLeft"][0], cc["lowerRight"][1], cc["lowerRight"][0], cc["upperLeft"][1])
files = ["peaks/peaks.geojson", "peaks/saddles.geojson", "peaks/divide_tree.geojson",
         "ridges/ridges.geojson", "streams.geojson", "nodes.geojson", "bm.geojson"]

def ogr(path):
    out = subprocess.check_output(["ogrinfo", "-al", "-so", path], text=True)
    m = re.search(r"Extent: \(([-\d.e]+), ([-\d.e]+)\) - \(([-\d.e]+), ([-\d.e]+)\)", out)
    assert m, f"{path}: ogrinfo reports no extent:\n{out}"
    return out, tuple(float(v) for v in m.groups())

def inside(ext, box, slack):
    return (ext[0] >= box[0] - slack and ext[1] >= box[1] - slack
            and ext[2] <= box[2] + slack and ext[3] <= box[3] + slack)

for f in files:
    out, ext = ogr(f"{tmp}/wgs84/{f}")
    assert 'GEOGCRS["WGS 84"' in out and 'ID["EPSG",4326]' in out, f"wgs84/{f}: not EPSG:4326:\n{out}"
    # ogrinfo prints 6 decimals, gdalinfo's wgs84Extent 7: outlines touch the corners
    assert inside(ext, ll_box, 1e-6), f"wgs84/{f}: extent {ext} outside the DEM's lon/lat bounds {ll_box}"
    print(f"ok  wgs84  {f}: EPSG:4326, extent {ext[0]:.5f},{ext[1]:.5f} - {ext[2]:.5f},{ext[3]:.5f}")
    out, ext = ogr(f"{tmp}/native/{f}")
    assert 'UTM zone 11N' in out and 'ID["EPSG",32611]' in out, f"native/{f}: not EPSG:32611:\n{out}"
    assert inside(ext, xy_box, 1e-2), f"native/{f}: extent {ext} outside the DEM's bounds {xy_box}"
    assert "crs" in json.load(open(f"{tmp}/native/{f}")), f"native/{f}: no crs member"
    print(f"ok  native {f}: EPSG:32611, extent inside the DEM")

# native coordinates are the projected cell centres of peaks.csv (y,x columns)
rows = [l.split(",") for l in open(f"{tmp}/native/peaks/peaks.csv").read().splitlines()[1:]]
feats = json.load(open(f"{tmp}/native/peaks/peaks.geojson"))["features"]
assert len(rows) == len(feats) > 0
for r, ft in zip(rows, feats):
    assert ft["geometry"]["coordinates"] == [float(r[1]), float(r[0])], (r[:2], ft["geometry"])
# and wgs84 writes the same features, properties unchanged
wf = json.load(open(f"{tmp}/wgs84/peaks/peaks.geojson"))["features"]
assert [f["properties"] for f in wf] == [f["properties"] for f in feats]
print(f"ok  native peaks.geojson: {len(feats)} points equal peaks.csv's x/y; properties identical in both modes")
PY

for mode in wgs84 native; do
  run peaks "$GEO" --min-prominence 30 --geojson-crs "$mode" -o "$tmp/geo_$mode"
done
for f in peaks.geojson saddles.geojson divide_tree.geojson; do
  cmp "$tmp/geo_wgs84/$f" "$tmp/geo_native/$f"
  grep -q '"crs"' "$tmp/geo_wgs84/$f" && { echo "geographic $f has a crs member"; exit 1; }
done
echo "ok  geographic DEM: the same bytes in both modes, no crs member"

gdal_translate -q -a_srs EPSG:2056 -a_ullr 2600000 1200000 2609030 1193910 "$BT" "$tmp/lv95.tif"
if "$OROGEN" peaks "$tmp/lv95.tif" -q -o "$tmp/lv95" 2> "$tmp/err"; then
  echo "peaks on an EPSG:2056 DEM did not fail"; exit 1
fi
grep -q -- "--geojson-crs native" "$tmp/err" && grep -q "EPSG:2056" "$tmp/err" || { cat "$tmp/err"; exit 1; }
[ ! -e "$tmp/lv95/peaks.geojson" ] || { echo "partial output after the CRS error"; exit 1; }
run peaks "$tmp/lv95.tif" --geojson-crs native -o "$tmp/lv95"
ogrinfo -al -so "$tmp/lv95/peaks.geojson" | grep -q 'ID\["EPSG",2056\]'
echo "ok  EPSG:2056: one error naming --geojson-crs native, nothing written; native places it"
