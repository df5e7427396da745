#!/usr/bin/env bash
# Installs the viewer's browser libraries from the npm registry into
# tools/node_modules (MapLibre GL JS, pmtiles.js) and, with --browser, the
# headless-browser test tools (Debian chromium, playwright-core).
set -euo pipefail
cd "$(dirname "$0")"
if [ ! -f node_modules/maplibre-gl/dist/maplibre-gl.js ] || [ ! -f node_modules/pmtiles/dist/pmtiles.js ]; then
  [ -f package.json ] || echo '{"private": true}' > package.json
  npm install --no-audit --no-fund --silent maplibre-gl@5 pmtiles@4 >/dev/null
fi
if [ "${1:-}" = "--browser" ]; then
  if ! command -v chromium >/dev/null; then
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq && apt-get install -y -qq chromium >/dev/null
  fi
  [ -d node_modules/playwright-core ] || npm install --no-audit --no-fund --silent playwright-core >/dev/null
fi
