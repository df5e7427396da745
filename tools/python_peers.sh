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
# Versions: pysheds 0.5 calls np.in1d and richdem 0.3.4 is built against
# numpy 1, so numpy < 2, and with it pandas < 3, scipy < 1.15,
# scikit-image < 0.25 (as tools/hydro_peers.sh). richdem 0.3.4 (the last
# release) does not build on Python >= 3.11 with its bundled pybind11: it is
# built from the sdist with the current pybind11 headers swapped in (the
# recipe of tools/richdem_compare.py). If that fails, python_peers.py says
# so and skips richdem (non-zero only with --require-richdem).
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

if [ ! -x "$VENV/bin/python" ]; then
    echo "== venv $VENV"
    "$PY" -m venv "$VENV"
fi
vpy="$VENV/bin/python"
"$vpy" -m pip install -q --upgrade pip
echo "== pysheds, xarray-spatial (PyPI)"
"$vpy" -m pip install -q pysheds xarray-spatial 'numpy<2' 'pandas<3' 'scipy<1.15' 'scikit-image<0.25'
echo "== orogen wheel $wheel"
"$vpy" -m pip install -q --force-reinstall --no-deps "$wheel"

status="$VENV/richdem-install.txt"
if "$vpy" -c 'import richdem' 2>/dev/null; then
    echo "richdem: installed ($("$vpy" -m pip show richdem 2>/dev/null | sed -n 's/^Version: //p'))" >"$status"
else
    echo "== richdem: pip install richdem, else the sdist with current pybind11 headers"
    log="$VENV/richdem-build.log"
    tmp=$(mktemp -d)
    if timeout "${RICHDEM_BUILD_TIMEOUT:-900}" "$vpy" -m pip install richdem >"$log" 2>&1; then
        echo "richdem: installed from PyPI as is" >"$status"
    elif timeout "${RICHDEM_BUILD_TIMEOUT:-900}" bash -c '
            set -e
            "$0" -m pip install -q pybind11 setuptools wheel
            "$0" -m pip download richdem==0.3.4 --no-deps --no-binary :all: -d "$1"
            cd "$1" && tar xzf richdem-0.3.4.tar.gz && cd richdem-0.3.4
            rm -rf lib/pybind11
            cp -r "$("$0" -c "import pybind11; print(pybind11.get_include())")/pybind11" lib/
            "$0" -m pip install --no-build-isolation .
        ' "$vpy" "$tmp" >>"$log" 2>&1 && "$vpy" -c 'import richdem' 2>>"$log"; then
        echo "richdem: built from the 0.3.4 sdist with pybind11 $("$vpy" -c 'import pybind11; print(pybind11.__version__)') headers" >"$status"
    else
        echo "richdem: could not be installed (pip install richdem and the sdist rebuild both failed; last lines of $log: $(tail -n 3 "$log" | tr '\n' ' '))" >"$status"
    fi
    rm -rf "$tmp"
fi
cat "$status"
export PYTHON_PEERS_RICHDEM_STATUS="$status"
exec "$vpy" tools/python_peers.py "${args[@]+"${args[@]}"}"
