#!/usr/bin/env bash
# Install the hydrology peers from the package registries and compare orogen
# with them on real DEMs (tools/hydro_peers.py prints the figures and exits 1
# when a comparison is past its gate):
#   GRASS (Debian grass-core: r.fill.dir, r.watershed), SAGA (Debian saga),
#   pysheds and RichDEM (PyPI, in the venv of tools/lib.sh's peers_venv,
#   shared with tools/python_peers.sh).
# A peer that cannot be installed prints "skipped: <why>"; with
# OROGEN_REQUIRE_PEERS=1 (as tools/e2e.sh runs it) that is an error.
# Usage: tools/hydro_peers.sh [DEM.tif ...]
# Env:   PYTHON_PEERS_VENV (default target/python-peers-venv), OROGEN_BIN.
set -euo pipefail
cd "$(dirname "$0")/.."
. tools/lib.sh
VENV=${PYTHON_PEERS_VENV:-$PWD/target/python-peers-venv}
have() { command -v "$1" >/dev/null 2>&1; }
if ! have grass || ! have saga_cmd; then
    if [ "$(id -u)" = 0 ] && have apt-get; then
        echo "== GRASS and SAGA (apt-get install grass-core saga)"
        (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends grass-core saga) \
            >/dev/null 2>&1 || echo "skipped: GRASS/SAGA could not be installed with apt-get"
    else
        echo "skipped: GRASS/SAGA install (needs root and apt-get)"
    fi
fi
peers_venv "$VENV"
cat "$VENV/richdem-install.txt"
exec "$VENV/bin/python" tools/hydro_peers.py "$@"
