#!/bin/bash
# The MPI engine gives the bytes of the in-process engine.
#
# Installs Open MPI (tools/install_mpi.sh), builds orogen with --features mpi,
# then for a real DEM and for the generator (`orogen demo`, reduced size) runs
#   fill, flow (D8), accumulate (D8), peaks --tiled (divide tree),
#   metric (slope + tpi, one pass), erode (thermal)
# in-process and under `mpirun -n 1|2|4` with `--engine mpi`, and `cmp`s
# every output file. Also `orogen run job.toml --engine mpi` with 2 ranks,
# uneven work under both schedules (tools/mpi_uneven.sh) and a killed rank
# (tools/mpi_kill.sh).
#
# Erosion with halo exchange across ranks (hydraulic, thermal, diffusion;
# several exchange intervals, tiles that do not divide the raster) and the
# tiled stream-power solve distributed over the ranks (rounds of the
# exec::iterate driver, perimeters exchanged after every round) are checked
# in their own block below; --only-erosion runs that block alone.
#
# Usage: tools/mpi_check.sh [--release] [--ranks "1 2 4"] [--dem PATH] [--size N] [--tile N] [--only-erosion]
# (defaults: a 367x359 real DEM and a 384x384 generated one in tiles of 128)
# Env:   OROGEN_MPI_STATS=1 prints bytes moved per phase (JSON lines, rank 0).
set -euo pipefail
cd "$(dirname "$0")/.."
. tools/lib.sh
profile=debug
ranks="1 2 4"
dem=../shared/data/pysheds_dem.tif
size=384
tile=128
only_erosion=0
while [ $# -gt 0 ]; do
    case "$1" in
    --release) profile=release ;;
    --ranks) ranks="$2"; shift ;;
    --dem) dem="$2"; shift ;;
    --size) size="$2"; shift ;;
    --tile) tile="$2"; shift ;;
    --only-erosion) only_erosion=1 ;;
    *) echo "usage: $0 [--release] [--ranks \"1 2 4\"] [--dem PATH] [--size N] [--tile N] [--only-erosion]" >&2; exit 2 ;;
    esac
    shift
done

tools/install_mpi.sh
if [ "$profile" = release ]; then
    cargo build --release --features mpi --bin orogen
else
    cargo build --features mpi --bin orogen
fi
bin="$PWD/target/$profile/orogen"
mpirun_="mpirun --allow-run-as-root --oversubscribe"
work=$(mktemp -d -t orogen-mpi-check.XXXXXX)
trap 'rm -rf "$work"' EXIT
fails=0

# pipeline DIR INPUT ENGINE_FLAGS PREFIX...: the steps on INPUT into DIR, each
# run as `PREFIX... COMMAND ARGS ENGINE_FLAGS`.
pipeline() {
    local dir="$1" input="$2" eng="$3"
    shift 3
    mkdir -p "$dir"
    "$@" fill "$input" -o "$dir/fill.tif" --tile "$tile" -q $eng
    "$@" flow "$dir/fill.tif" -o "$dir/d8.tif" --tile "$tile" -q $eng
    "$@" accumulate "$dir/d8.tif" -o "$dir/acc.tif" --tile "$tile" -q $eng
    "$@" peaks "$input" --tiled --min-prominence 20 -o "$dir/peaks" --tile "$tile" -q $eng
    "$@" metric "$input" --metric slope,tpi:radius=5c -o "$dir/metric" --tile "$tile" -q $eng
    "$@" erode "$input" --model thermal --steps 20 --talus 30 -o "$dir/thermal.tif" --tile "$tile" -q $eng
    # Tile-store outputs (only rank 0 creates and locks them) and the steps that
    # write internal stores.
    "$@" ingest "$input" -o "$dir/ingested.tiles" --store-tile "$tile" -q $eng
    "$@" fill "$input" -o "$dir/fill.tiles" --store-tile "$tile" -q $eng
    # Another global step to a store (under MPI each rank writes its own
    # tiles); its input is the shared one, as the store records input paths.
    "$@" flow "$input" -o "$dir/flow.tiles" --store-tile "$tile" -q $eng
    "$@" fill-epsilon "$input" -o "$dir/eps.tif" --tile "$tile" -q $eng
    "$@" accumulate "$dir/fill.tif" --method dinf -o "$dir/dinf.tif" --tile "$tile" -q $eng
    "$@" breach "$input" --method least-cost -o "$dir/lcb.tif" --tile "$tile" -q $eng
}

compare() {
    local a="$1" b="$2" label="$3"
    local n=0
    while IFS= read -r f; do
        n=$((n + 1))
        if ! cmp -s "$a/$f" "$b/$f"; then
            echo "DIFFER: $label: $f"
            fails=$((fails + 1))
        fi
    done < <(cd "$a" && find . -type f ! -name '.*' | sort)
    local m
    m=$(cd "$b" && find . -type f ! -name '.*' | wc -l)
    if [ "$n" != "$m" ] || [ "$n" = 0 ]; then
        echo "DIFFER: $label: $n files in-process, $m under MPI"
        fails=$((fails + 1))
    fi
    echo "$label: $n files compared"
}

# across_ranks CASES LABEL PREFIX: the runs of the function CASES (pipeline or
# halo_cases) on the real DEM and on the generated one, in-process into
# $work/PREFIX<name>-local, then under `mpirun -n N` for each N of $ranks
# into $work/PREFIX<name>-mpiN; each timed, each rank count's outputs
# compared with the in-process ones.
across_ranks() {
    local cases="$1" label="$2" prefix="$3" name input n t0 t1
    for name in real demo; do
        if [ $name = real ]; then input="$dem"; else input="$work/demo/terrain.tif"; fi
        t0=$(date +%s.%N)
        "$cases" "$work/$prefix$name-local" "$input" "" "$bin"
        t1=$(date +%s.%N)
        echo "$label$name: in-process $(echo "$t1 - $t0" | bc) s"
        for n in $ranks; do
            t0=$(date +%s.%N)
            "$cases" "$work/$prefix$name-mpi$n" "$input" "--engine mpi" $mpirun_ -n "$n" "$bin"
            t1=$(date +%s.%N)
            echo "$label$name: mpirun -n $n $(echo "$t1 - $t0" | bc) s"
            compare "$work/$prefix$name-local" "$work/$prefix$name-mpi$n" "$label$name, $n ranks"
        done
    done
}

"$bin" demo --size "$size" --seed 7 -o "$work/demo" -q >/dev/null

# --- Erosion with halo exchange across ranks (docs/design/engine-and-mpi.md#erosion-halo-exchange-across-ranks) -------
# Each rank keeps its tiles' states and receives its ghost zones point to
# point every k substeps; rank 0 writes. Tiles of 100 and 77 do not divide
# the rasters (367x359, 384x384); k = 1, 2, 3, 5, 8; the hydraulic runs write
# two outputs (terrain + water) and one keeps its states on disk (a scratch
# folder per rank); the stream-power runs keep each rank's tiles and
# exchange the changed perimeters after every round. Every output is cmp'd
# with the in-process run.
halo_cases() {
    local dir="$1" input="$2" eng="$3"
    shift 3
    mkdir -p "$dir"
    "$@" erode "$input" --model thermal --steps 20 --talus 30 --exchange 1 --tile 100 -o "$dir/thermal-k1.tif" -q $eng
    "$@" erode "$input" --model thermal --steps 20 --talus 30 --exchange 3 --tile 77 -o "$dir/thermal-k3.tif" -q $eng
    "$@" erode "$input" --model thermal --steps 20 --talus 30 --exchange 8 --tile 100 -o "$dir/thermal-k8.tif" -q $eng
    "$@" erode "$input" --model hydraulic --steps 24 --exchange 2 --tile 100 --water "$dir/water-k2.tif" -o "$dir/hydraulic-k2.tif" -q $eng
    "$@" erode "$input" --model hydraulic --steps 24 --exchange 5 --tile 77 --scratch "$dir" -o "$dir/hydraulic-k5-disk.tif" -q $eng
    "$@" erode "$input" --model diffusion --steps 4 --diffusivity 0.5 --dt 3000 --exchange 3 --tile 77 -o "$dir/diffusion-k3.tif" -q $eng
    # Stream power, tiled: fill routing (levels, flat distances, area and
    # update as rounds), no routing with diffusion and uplift, scratch files.
    "$@" erode "$input" --model stream-power --steps 5 --tiled --tile 100 -o "$dir/sp-fill-t100.tif" -q $eng
    "$@" erode "$input" --model stream-power --steps 4 --tiled --tile 77 --depressions none --uplift 1e-3 --diffusivity 0.5 -o "$dir/sp-none-t77.tif" -q $eng
    "$@" erode "$input" --model stream-power --steps 3 --tiled --tile 77 --uplift 2e-3 --scratch "$dir" -o "$dir/sp-fill-disk.tif" -q $eng
}
across_ranks halo_cases "erosion halo, " halo-
if [ "$only_erosion" = 1 ]; then
    if [ "$fails" != 0 ]; then
        echo "mpi_check: $fails difference(s)"
        exit 1
    fi
    echo "mpi_check: erosion outputs identical to the in-process engine"
    exit 0
fi
# --- end of the erosion block ------------------------------------------------

across_ranks pipeline "" ""

# A job file under mpirun (engine from the command line).
mkdir -p "$work/job"
job_fixture fill_metric.toml TILE="$tile" DEM="$(realpath "$dem")" >"$work/job/job.toml"
cp -r "$work/job" "$work/job-local"
"$bin" run "$work/job-local/job.toml" -q >/dev/null 2>&1
$mpirun_ -n 2 "$bin" run "$work/job/job.toml" --engine mpi -q >/dev/null 2>&1
for f in filled.tif metric/slope.tif; do
    if ! cmp -s "$work/job-local/$f" "$work/job/$f"; then
        echo "DIFFER: job file, 2 ranks: $f"
        fails=$((fails + 1))
    fi
done
echo "job file, 2 ranks: compared"

kill_flags=""
if [ "$profile" = release ]; then kill_flags="--release"; fi

# Uneven work (nodata stripes): the work queue and round robin both give the
# in-process bytes (tools/mpi_uneven.sh; needs GDAL's gdal_translate and numpy).
# GDAL's Python (python3-gdal, which brings python3-numpy) is the system's;
# a pyenv or venv python3 on PATH may have no numpy.
if command -v gdal_translate >/dev/null && /usr/bin/python3 -c 'import numpy' 2>/dev/null; then
    if ! tools/mpi_uneven.sh $kill_flags; then
        echo "DIFFER: uneven work (tools/mpi_uneven.sh)"
        fails=$((fails + 1))
    fi
else
    echo "uneven work: skipped (no gdal_translate or numpy)"
    if [ "${OROGEN_REQUIRE_PEERS:-0}" = 1 ]; then
        echo "error: OROGEN_REQUIRE_PEERS=1: the uneven-work check must run (install gdal-bin and python3-numpy: tools/install_gdal.sh)" >&2
        fails=$((fails + 1))
    fi
fi

# Kill rank 1 mid-job (fill to a tile store), then resume to identical
# bytes (tools/mpi_kill.sh, about 1 min).
if ! tools/mpi_kill.sh $kill_flags; then
    echo "DIFFER: kill a rank (tools/mpi_kill.sh)"
    fails=$((fails + 1))
fi

if [ "$fails" != 0 ]; then
    echo "mpi_check: $fails difference(s)"
    exit 1
fi
echo "mpi_check: all outputs identical to the in-process engine"
