#!/usr/bin/env bash
# Installs GDAL's command-line tools and Python bindings (Debian packages) if missing.
set -euo pipefail
if command -v gdaldem >/dev/null && /usr/bin/python3 -c "from osgeo import gdal" 2>/dev/null; then
  exit 0
fi
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq gdal-bin python3-gdal time >/dev/null
