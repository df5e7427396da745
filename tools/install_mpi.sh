#!/bin/sh
# Install what `cargo build --features mpi` needs on Debian/Ubuntu: Open MPI
# (runtime, mpirun, headers and mpicc for rsmpi's build script) and libclang
# (bindgen, used by the mpi-sys crate). Idempotent; needs root (or sudo).
set -eu
pkgs="openmpi-bin libopenmpi-dev libclang-dev clang pkg-config"
missing=""
for p in $pkgs; do
    dpkg -s "$p" >/dev/null 2>&1 || missing="$missing $p"
done
if [ -z "$missing" ]; then
    echo "install_mpi: already installed:$pkgs"
    exit 0
fi
SUDO=""
[ "$(id -u)" = 0 ] || SUDO="sudo"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q
$SUDO apt-get install -y -q --no-install-recommends $missing
mpirun --version | head -1
