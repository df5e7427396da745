#!/usr/bin/env bash
# orogen's Python package against the Python peers, on the same numpy array:
# makes (or reuses) a venv, installs pysheds and xarray-spatial from PyPI,
# py-richdem when it can be built, and the orogen wheel, then runs
# tools/python_peers.py in it (which prints the checks and the timing table
# and exits non-zero when a check is past its threshold).
#
# Usage: bash tools/python_peers.sh [--wheel WHEEL] [python_peers.py options...]
#   --wheel WHEEL  the orogen wheel to install (default: $OROGEN_WHEEL, else
#                  the newest python/target/wheels/orogen-*.whl; with none,
#                  one is built with `maturin build --release` into
#                  target/python-peers-wheels, which needs cargo)
#   e.g. bash tools/python_peers.sh --wheel /path/orogen-0.1.0-cp39-abi3-*.whl
#        bash tools/python_peers.sh --require-richdem
# Env:   PYTHON (default python3), PYTHON_PEERS_VENV (default
#        target/python-peers-venv), RICHDEM_BUILD_TIMEOUT (seconds, default 900).
#
# The venv (pysheds, xarray-spatial, py-richdem built from its sdist when
# pip cannot install it, and the version pins) is made by peers_venv in
# tools/lib.sh, shared with tools/hydro_peers.sh. If richdem cannot be
# installed, python_peers.py says so and skips it (non-zero only with
# --require-richdem).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
PY=${PYTHON:-python3}
VENV=${PYTHON_PEERS_VENV:-$root/target/python-peers-venv}
wheel=${OROGEN_WHEEL:-}
args=()
while [ $# -gt 0 ]; do
    case "$1" in
        --wheel) wheel=$2; shift 2 ;;
        --wheel=*) wheel=${1#--wheel=}; shift ;;
        *) args+=("$1"); shift ;;
    esac
done

if [ -z "$wheel" ]; then
    wheel=$(ls -t python/target/wheels/orogen-*.whl 2>/dev/null | head -n 1 || true)
fi
if [ -z "$wheel" ]; then
    echo "== no orogen wheel given or found: maturin build --release into target/python-peers-wheels"
    [ -x "$VENV/bin/python" ] || "$PY" -m venv "$VENV"
    "$VENV/bin/python" -m pip install -q maturin
    (cd python && "$VENV/bin/maturin" build --release -q -o "$root/target/python-peers-wheels")
    wheel=$(ls -t target/python-peers-wheels/orogen-*.whl | head -n 1)
fi
[ -f "$wheel" ] || { echo "python_peers: no such wheel: $wheel" >&2; exit 1; }

. tools/lib.sh
peers_venv "$VENV"
vpy="$VENV/bin/python"
echo "== orogen wheel $wheel"
"$vpy" -m pip install -q --force-reinstall --no-deps "$wheel"
status="$VENV/richdem-install.txt"
cat "$status"
export PYTHON_PEERS_RICHDEM_STATUS="$status"
exec "$vpy" tools/python_peers.py "${args[@]+"${args[@]}"}"
