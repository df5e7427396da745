#!/bin/bash
# The MPI work queue balances uneven work, with the bytes of one process.
#
# Input: a real DEM (default srtm3_N46E008, the Alps, 1201x1201; or a window
# of one) whose odd tile columns (tiles of 128: 10 columns) are set to nodata, so
# half of the tiles cost almost nothing. Round robin deals tile k to rank
# k mod 2, which with 10 tile columns is the tile's column parity: rank 1
# gets every nodata tile. The queue (the default) deals chunks on request.
#
# For fill -> GeoTIFF, fill -> tile store and D8 accumulation -> tile store,
# runs in-process and under `mpirun -n 2 --engine mpi` with
# OROGEN_MPI_SCHEDULE=round-robin and =queue, `cmp`s every output with the
# in-process one, and prints per phase the tiles each rank computed, its
# busy seconds (summed over its workers) and when its last tile finished
# (OROGEN_MPI_STATS lines of rank 0), and the wall time of each run.
#
# Usage: tools/mpi_uneven.sh [--release] [--dem PATH] [--threads N] [--tile N] [--srcwin "X Y W H"]
# (the number of tile columns must be even for round robin to split by
# parity; release builds need larger tiles to take measurable time, e.g.
#  --release --dem ../shared/data/poland_N49-55_E014-025.tif --srcwin "5600 4128 4096 3072" --tile 512)
# (assumes `cargo build [--release] --features mpi`; GDAL's gdal_translate and
# /usr/bin/python3 with numpy, from tools/install_gdal.sh, make the input)
set -euo pipefail
cd "$(dirname "$0")/.."
profile=debug
dem=../shared/data/srtm3_N46E008.tif
threads=1
tile=128
srcwin=""
while [ $# -gt 0 ]; do
    case "$1" in
    --release) profile=release ;;
    --dem) dem="$2"; shift ;;
    --threads) threads="$2"; shift ;;
    --tile) tile="$2"; shift ;;
    --srcwin) srcwin="-srcwin $2"; shift ;;
    *) echo "usage: $0 [--release] [--dem PATH] [--threads N] [--tile N] [--srcwin 'X Y W H']" >&2; exit 2 ;;
    esac
    shift
done
bin="$PWD/target/$profile/orogen"
mpirun_="mpirun --allow-run-as-root --oversubscribe"
work=$(mktemp -d -t orogen-mpi-uneven.XXXXXX)
trap 'rm -rf "$work"' EXIT
fails=0

# Odd tile columns to nodata: through GDAL's raw ENVI format (a flat int16
# file and a header), so only numpy is needed.
gdal_translate -q -of ENVI -ot Int16 $srcwin "$dem" "$work/dem.img"
/usr/bin/python3 - "$work/dem.img" "$work/dem.hdr" "$tile" <<'EOF2'
import sys
import numpy as np
img, hdr, tile = sys.argv[1], sys.argv[2], int(sys.argv[3])
h = {}
for line in open(hdr):
    if "=" in line:
        k, v = line.split("=", 1)
        h[k.strip().lower()] = v.strip()
w, rows = int(h["samples"]), int(h["lines"])
order = "<" if h.get("byte order", "0") == "0" else ">"
a = np.fromfile(img, dtype=order + "i2").reshape(rows, w)
a[:, (np.arange(w) // tile) % 2 == 1] = -32768
a.tofile(img)
EOF2
gdal_translate -q -of GTiff -a_nodata -32768 -co TILED=YES -co COMPRESS=DEFLATE "$work/dem.img" "$work/striped.tif"
in="$work/striped.tif"

steps() {
    local dir="$1" eng="$2"
    shift 2
    mkdir -p "$dir"
    "$@" fill "$in" -o "$dir/fill.tif" --tile $tile -q --threads $threads $eng
    "$@" fill "$in" -o "$dir/fill.tiles" --store-tile $tile -q --threads $threads $eng
    "$@" flow "$in" -o "$dir/d8.tif" --tile $tile -q --threads $threads $eng
    # A store records its input's path: every run reads the same D8 grid.
    "$@" accumulate "$work/d8.tif" -o "$dir/acc.tiles" --store-tile $tile -q --threads $threads $eng
}
"$bin" flow "$in" -o "$work/d8.tif" --tile $tile -q

steps "$work/local" "" "$bin"
for sched in round-robin queue; do
    t0=$(date +%s.%N)
    OROGEN_MPI_SCHEDULE=$sched OROGEN_MPI_STATS=1 steps "$work/$sched" "--engine mpi" \
        $mpirun_ -n 2 "$bin" 2>"$work/$sched.stats"
    t1=$(date +%s.%N)
    echo "== $sched: 2 ranks, $(echo "$t1 - $t0" | bc) s for the four steps"
    /usr/bin/python3 - "$work/$sched.stats" <<'EOF'
import json, sys
for line in open(sys.argv[1]):
    line = line.strip()
    if not line.startswith("{"):
        continue
    j = json.loads(line)
    if not any(j.get("tiles_per_rank", [])):
        continue
    busy = ", ".join(f"{b:.2f}" for b in j["busy_s_per_rank"])
    last = ", ".join(f"{b:.2f}" for b in j["last_tile_s_per_rank"])
    print(f"  {j['mpi_stats']:<10} {j['phase'].split(',')[0][:28]:<28} tiles {j['tiles_per_rank']} busy s [{busy}] last tile at s [{last}] phase {j['seconds']:.2f} s, queue {j['queue_bytes_per_tile']:.1f} B/tile")
EOF
    while IFS= read -r f; do
        if ! cmp -s "$work/local/$f" "$work/$sched/$f"; then
            echo "DIFFER: $sched: $f"
            fails=$((fails + 1))
        fi
    done < <(cd "$work/local" && find . -type f ! -name '.*' | sort)
    n=$(cd "$work/local" && find . -type f ! -name '.*' | wc -l)
    m=$(cd "$work/$sched" && find . -type f ! -name '.*' | wc -l)
    if [ "$n" != "$m" ]; then
        echo "DIFFER: $sched: $n files in-process, $m under MPI"
        fails=$((fails + 1))
    fi
    echo "  $sched: $n files compared with the in-process run"
done
if [ "$fails" != 0 ]; then
    echo "mpi_uneven: $fails difference(s)"
    exit 1
fi
echo "mpi_uneven: identical bytes under both schedules"
