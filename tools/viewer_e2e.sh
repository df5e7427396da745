#!/usr/bin/env bash
# End-to-end check of `orogen tiles` + `orogen view`: cuts a Terrain-RGB
# PMTiles pyramid from an SRTM tile, serves it, renders it in headless
# Chromium (screenshot kept in target/viewer-e2e/), and decodes tiles served
# from an MBTiles copy and read from the PMTiles archive by the independent
# `pmtiles` Python package: their pixels must give the DEM's elevation at
# that point (bilinear between the cells GDAL reads) within Terrain-RGB's 0.1 m step plus
# interpolation. Installs what it needs (npm, Debian chromium, PyPI).
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/install_gdal.sh
bash tools/viewer_setup.sh --browser
python3 -m pip install -q pmtiles pillow >/dev/null 2>&1 || python3 -m pip install -q --break-system-packages pmtiles pillow >/dev/null
OROGEN=${OROGEN:-target/release/orogen}
[ -x "$OROGEN" ] || cargo build --release
out=target/viewer-e2e; rm -rf "$out"; mkdir -p "$out"
dem=../shared/data/srtm3_S33W071.tif
"$OROGEN" tiles "$dem" -o "$out/dem.pmtiles" -o "$out/dem.mbtiles" -q
"$OROGEN" view "$out/dem.pmtiles" --port 0 > "$out/view.log" 2>&1 &
vpid=$!
"$OROGEN" view "$out/dem.mbtiles" --port 0 > "$out/view2.log" 2>&1 &
vpid2=$!
trap 'kill $vpid $vpid2 2>/dev/null || true' EXIT
for _ in $(seq 50); do grep -q http "$out/view.log" && grep -q http "$out/view2.log" && break; sleep 0.2; done
url=$(grep -o 'http://[^ ]*' "$out/view.log"); url2=$(grep -o 'http://[^ ]*' "$out/view2.log")
echo "viewer at $url"
# Points near the DEM's centre, their elevations by GDAL (bilinear); the
# tolerance covers MapLibre's coarser terrain mesh at the view's zoom on
# this steep ground (relief 5 km: a wrong encoding is off by kilometres).
python3 - "$dem" "$out/points.json" <<'PY'
import json, math, struct, sys
sys.path.insert(0, '/usr/lib/python3/dist-packages')
from osgeo import gdal
ds = gdal.Open(sys.argv[1]); b = ds.GetRasterBand(1); gt = ds.GetGeoTransform()
pts = []
for lon, lat in [(-70.5, -32.5), (-70.45, -32.55), (-70.55, -32.45), (-70.4, -32.4)]:
    fx = (lon - gt[0]) / gt[1] - 0.5; fy = (lat - gt[3]) / gt[5] - 0.5
    x0, y0 = int(math.floor(fx)), int(math.floor(fy))
    a, c, d, e = struct.unpack('<4d', b.ReadRaster(x0, y0, 2, 2, buf_type=gdal.GDT_Float64))
    tx, ty = fx - x0, fy - y0
    pts.append([lon, lat, (a * (1 - tx) + c * tx) * (1 - ty) + (d * (1 - tx) + e * tx) * ty, 150.0])
json.dump(pts, open(sys.argv[2], 'w'))
PY
node tools/viewer_check.mjs "$url" "$out/viewer.png" "$out/points.json"
python3 - "$out/dem.pmtiles" "$url2" "$dem" <<'PY'
import io, math, sys, urllib.request, struct
from PIL import Image
sys.path.insert(0, '/usr/lib/python3/dist-packages')
from osgeo import gdal
from pmtiles.reader import Reader, MmapSource
pm, url, dem = sys.argv[1:4]
ds = gdal.Open(dem); band = ds.GetRasterBand(1); gt = ds.GetGeoTransform()
def dem_bilinear(lon, lat):
    # GDAL reads the cells; the bilinear weights are computed here (cell centres at +0.5).
    fx = (lon - gt[0]) / gt[1] - 0.5; fy = (lat - gt[3]) / gt[5] - 0.5
    x0, y0 = int(math.floor(fx)), int(math.floor(fy))
    a, b, c, d = struct.unpack('<4d', band.ReadRaster(x0, y0, 2, 2, buf_type=gdal.GDT_Float64))
    tx, ty = fx - x0, fy - y0
    return (a * (1 - tx) + b * tx) * (1 - ty) + (c * (1 - tx) + d * tx) * ty
def merc_tile(lon, lat, z):
    n = 2 ** z
    x = (lon + 180) / 360 * n
    y = (1 - math.log(math.tan(math.radians(lat)) + 1 / math.cos(math.radians(lat))) / math.pi) / 2 * n
    return x, y
with open(pm, 'rb') as f:
    r = Reader(MmapSource(f))
    h = r.header()
    z = h['max_zoom']
    worst = 0.0
    for lon, lat in [(-70.5, -32.5), (-70.2, -32.8), (-70.9, -32.1), (-70.011, -32.65)]:
        fx, fy = merc_tile(lon, lat, z)
        tx, ty = int(fx), int(fy)
        px, py = int((fx - tx) * 256), int((fy - ty) * 256)
        # pixel centre back to lon/lat
        cx, cy = (tx + (px + 0.5) / 256), (ty + (py + 0.5) / 256)
        clon = cx / 2 ** z * 360 - 180
        clat = math.degrees(math.atan(math.sinh(math.pi * (1 - 2 * cy / 2 ** z))))
        want = dem_bilinear(clon, clat)
        for name, data in [('pmtiles', r.get(z, tx, ty)),
                           ('served mbtiles', urllib.request.urlopen(f'{url}tiles/{z}/{tx}/{ty}.png').read())]:
            R, G, B, A = Image.open(io.BytesIO(data)).convert('RGBA').getpixel((px, py))
            got = -10000 + (R * 65536 + G * 256 + B) * 0.1
            worst = max(worst, abs(got - want))
            print(f'{name} z{z}/{tx}/{ty} px {px},{py}: tile {got:.1f} m, DEM {want:.1f} m')
    assert worst < 1.0, f'worst difference {worst} m'
print(f'tiles decode to the DEM within {worst:.2f} m')
PY
