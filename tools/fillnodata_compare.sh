#!/usr/bin/env bash
# orogen fill-nodata against gdal_fillnodata (same -md, no smoothing) in the
# same run, on whole real SRTM tiles:
#  1. the voids of srtm3_N46E008.tif (Swiss Alps, 103,743 void cells):
#     agreement (median / p95 / max |orogen - GDAL| over the voids both
#     fill, voids each leaves), valid cells unchanged, tiled == untiled;
#  2. a hold-out on srtm3_S33W071.tif (Andes, no voids): disks of real data
#     cut out (seeded), filled by both, each compared with the truth;
#  3. the Poland mosaic (95 Mcells, 172 voids): throughput at scale;
#  4. wall time and peak RSS of each (/usr/bin/time -v), ratio GDAL/orogen.
# Usage: bash tools/fillnodata_compare.sh [MAX_DISTANCE_CELLS]   (default 100)
# Needs ../shared/data, python3-gdal with numpy (/usr/bin/python3); installs
# GDAL through tools/install_gdal.sh; builds the release binary unless
# OROGEN names one.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/install_gdal.sh
MD=${1:-100}
OROGEN=${OROGEN:-}
if [ -z "$OROGEN" ]; then cargo build --release -q --bin orogen; OROGEN="$PWD/target/release/orogen"; fi
FILL=$(command -v gdal_fillnodata.py || command -v gdal_fillnodata)
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
VOIDS=../shared/data/srtm3_N46E008.tif
FULL=../shared/data/srtm3_S33W071.tif
POLAND=../shared/data/poland_N49-55_E014-025.tif  # 13201x7201, 172 voids: throughput

# "seconds peak_kib" of a command, from /usr/bin/time -v.
measure() {
  local log=$tmp/time.log
  /usr/bin/time -v "$@" >/dev/null 2>"$log"
  awk -F': ' '/Elapsed \(wall clock\)/{n=split($2,t,":"); s=0; for(i=1;i<=n;i++) s=s*60+t[i]}
              /Maximum resident set size/{r=$2} END{printf "%.3f %d\n", s, r}' "$log"
}

/usr/bin/python3 - "$FULL" "$tmp/holdout.tif" <<'PY'
import sys
import numpy as np
from osgeo import gdal
src = gdal.Open(sys.argv[1])
a = src.ReadAsArray()
rng = np.random.default_rng(20261203)
h, w = a.shape
yy, xx = np.mgrid[0:h, 0:w]
m = np.zeros(a.shape, bool)
for _ in range(120):
    cx, cy, r = rng.uniform(20, w - 20), rng.uniform(20, h - 20), rng.uniform(2, 20)
    m |= (xx - cx) ** 2 + (yy - cy) ** 2 <= r * r
b = a.copy()
b[m] = -32768
d = gdal.GetDriverByName("GTiff").CreateCopy(sys.argv[2], src)
d.GetRasterBand(1).WriteArray(b)
d.GetRasterBand(1).SetNoDataValue(-32768)
d = None
PY

echo "fill-nodata, max distance $MD cells, $(nproc) cores, $(date -u +'%Y-%m-%d %H:%M UTC'), load $(cut -d' ' -f1 /proc/loadavg)"
echo "$("$OROGEN" --version 2>/dev/null || echo orogen) vs $(gdalinfo --version)"
# Outputs: uncompressed GeoTIFF (gdal_fillnodata's default), then DEFLATE for both.
printf "| input | void cells | orogen s | GDAL s | GDAL/orogen | orogen s, DEFLATE | GDAL s, DEFLATE | GDAL/orogen | orogen peak RSS MiB | GDAL peak RSS MiB |\n|---|---|---|---|---|---|---|---|---|---|\n"
for pair in "voids:$VOIDS" "holdout:$tmp/holdout.tif" "poland:$POLAND"; do
  name=${pair%%:*}; dem=${pair#*:}
  read -r os orss < <(measure "$OROGEN" fill-nodata "$dem" -o "$tmp/o_$name.tif" --max-distance "$MD" --compress none -q)
  read -r gs grss < <(measure "$FILL" -q -md "$MD" "$dem" "$tmp/g_$name.tif")
  read -r oz _ < <(measure "$OROGEN" fill-nodata "$dem" -o "$tmp/oz.tif" --max-distance "$MD" -q)
  read -r gz _ < <(measure "$FILL" -q -md "$MD" "$dem" "$tmp/gz.tif" -co COMPRESS=DEFLATE)
  rm -f "$tmp/oz.tif" "$tmp/gz.tif"
  "$OROGEN" fill-nodata "$dem" -o "$tmp/o_${name}_t.tif" --max-distance "$MD" --tile 257 --threads 1 -q
  nv=$(/usr/bin/python3 -c "
from osgeo import gdal
ds = gdal.Open('$dem'); b = ds.GetRasterBand(1)
print(int((b.ReadAsArray() == b.GetNoDataValue()).sum()))")
  awk -v n="$name" -v v="$nv" -v os="$os" -v orss="$orss" -v gs="$gs" -v grss="$grss" -v oz="$oz" -v gz="$gz" 'BEGIN{
    printf "| %s | %d | %.2f | %.2f | %.2fx | %.2f | %.2f | %.2fx | %.0f | %.0f |\n", n, v, os, gs, gs/os, oz, gz, gz/oz, orss/1024, grss/1024 }'
done

/usr/bin/python3 - "$tmp" "$VOIDS" "$FULL" "$POLAND" <<'PY'
import sys
import numpy as np
from osgeo import gdal
d, voids, full, poland = sys.argv[1:5]
def rd(p):
    ds = gdal.Open(p)  # keep the dataset alive while its band is read
    return ds.GetRasterBand(1).ReadAsArray()
ok = True
print()
print("| input | voids filled by both | orogen left | GDAL left | median abs(orogen-GDAL) m | p95 | max | valid cells unchanged | tiled (257, 1 thread) == untiled |")
print("|---|---|---|---|---|---|---|---|---|")
for name, src in (("voids", voids), ("holdout", d + "/holdout.tif"), ("poland", poland)):
    ds = gdal.Open(src)
    b = ds.GetRasterBand(1)
    a, nd = b.ReadAsArray(), b.GetNoDataValue()
    o, g, t = rd(f"{d}/o_{name}.tif"), rd(f"{d}/g_{name}.tif"), rd(f"{d}/o_{name}_t.tif")
    v = a == nd
    both = v & (o != nd) & (g != nd)
    diff = np.abs(o[both].astype(float) - g[both])
    same_valid = bool((o[~v] == a[~v]).all())
    tiled = bool(np.array_equal(o, t))
    ok &= same_valid and tiled
    print(f"| {name} | {both.sum()} | {(v & (o == nd)).sum()} | {(v & (g == nd)).sum()} | "
          f"{np.median(diff):.1f} | {np.percentile(diff, 95):.1f} | {diff.max():.0f} | {same_valid} | {tiled} |")
    if name == "holdout":
        truth = rd(full).astype(float)
        holdout = [(who, np.abs(x[both].astype(float) - truth[both])) for who, x in (("orogen", o), ("gdal_fillnodata", g))]
print()
print("| hold-out on srtm3_S33W071 (cells cut out) | median abs(fill-truth) m | p95 | RMSE |")
print("|---|---|---|---|")
for who, e in holdout:
    print(f"| {who} ({e.size} cells) | {np.median(e):.1f} | {np.percentile(e, 95):.1f} | {np.sqrt((e ** 2).mean()):.1f} |")
sys.exit(0 if ok else 1)
PY
