#!/usr/bin/env bash
# Compare orogen's stream-power solver with fastscapelib (PyPI) on the same
# grid and parameters: max/mean elevation differences and time per step.
# Usage: tools/fastscape_compare.sh [options of tools/fastscape_compare.py]
# Environment: VENV (default: target/fastscape-venv) for the Python packages.
set -euo pipefail
cd "$(dirname "$0")/.."
VENV=${VENV:-target/fastscape-venv}
if [ ! -x "$VENV/bin/python" ]; then
    python3 -m venv "$VENV"
fi
if ! "$VENV/bin/python" -c "import fastscapelib, numpy" 2>/dev/null; then
    "$VENV/bin/pip" install -q "fastscapelib==0.3.0" numpy
fi
cargo build --release --quiet
exec "$VENV/bin/python" tools/fastscape_compare.py --orogen target/release/orogen "$@"
