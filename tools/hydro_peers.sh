#!/usr/bin/env bash
# Install hydrology peers from the package registries and compare orogen with
# them on real DEMs (tools/hydro_peers.py prints the figures).
#   GRASS (Debian grass-core: r.fill.dir, r.watershed), SAGA (Debian saga,
#   installed for manual checks), pysheds and RichDEM (PyPI).
# Never fails CI because a peer is missing: prints "skipped: <why>", exits 0.
# Usage: tools/hydro_peers.sh [DEM.tif ...]
set -u
cd "$(dirname "$0")/.."

if command -v apt-get >/dev/null 2>&1 && [ "$(id -u)" = 0 ]; then
    if ! command -v grass >/dev/null 2>&1 || ! command -v saga_cmd >/dev/null 2>&1; then
        apt-get install -y --no-install-recommends grass-core saga >/dev/null 2>&1 \
            || echo "skipped: GRASS/SAGA could not be installed with apt-get"
    fi
else
    echo "skipped: GRASS/SAGA install (needs root and apt-get)"
fi

if ! command -v python3 >/dev/null 2>&1; then
    echo "skipped: no python3"
    exit 0
fi
# pysheds 0.5 and richdem 0.3.4 need numpy < 2 (np.in1d, richdem's pin),
# and so pandas < 3, scipy < 1.15, scikit-image < 0.25 with it
python3 -c 'from pysheds.grid import Grid' 2>/dev/null ||
    pip install pysheds 'numpy<2' 'pandas<3' 'scipy<1.15' 'scikit-image<0.25' >/dev/null 2>&1 ||
    echo "skipped: pip install pysheds failed"
if ! python3 -c 'import richdem' 2>/dev/null; then
    # richdem 0.3.4 needs current pybind11 headers on Python >= 3.11 (see
    # tools/richdem_compare.py for the recipe); try the plain install first.
    pip install richdem >/dev/null 2>&1 || {
        tmp=$(mktemp -d)
        pip install pybind11 >/dev/null 2>&1 &&
            pip download richdem==0.3.4 --no-deps --no-binary :all: -d "$tmp" >/dev/null 2>&1 &&
            (cd "$tmp" && tar xzf richdem-0.3.4.tar.gz && cd richdem-0.3.4 &&
                rm -rf lib/pybind11 &&
                cp -r "$(python3 -c 'import pybind11;print(pybind11.get_include())')/pybind11" lib/ &&
                pip install . >/dev/null 2>&1) ||
            echo "skipped: richdem could not be built"
        rm -rf "$tmp"
    }
fi
python3 -c 'import numpy' 2>/dev/null || { echo "skipped: numpy is not importable"; exit 0; }
python3 tools/hydro_peers.py "$@" || echo "skipped: tools/hydro_peers.py failed (exit $?)"
exit 0
