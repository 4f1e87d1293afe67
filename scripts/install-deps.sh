#!/usr/bin/env bash
# Install every dependency of beadmob on Debian 12: native libraries from Debian packages,
# Python packages with pip. Safe to run more than once (apt and pip skip what is present).
set -euo pipefail

debian_packages=(
  gfortran cmake make pkg-config
  libopenmpi-dev openmpi-bin
  petsc-dev libmumps-dev
  libhdf5-openmpi-dev
  libfftw3-dev libfftw3-mpi-dev
  libopenblas-dev
  python3 python3-pip
)
python_packages=(numpy h5py matplotlib scipy pytest)

as_root() { if [ "$(id -u)" -eq 0 ]; then "$@"; else sudo "$@"; fi; }

missing=()
for p in "${debian_packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "install-deps: installing Debian packages: ${missing[*]}"
  as_root apt-get update -q
  DEBIAN_FRONTEND=noninteractive as_root apt-get install -y -q --no-install-recommends "${missing[@]}"
else
  echo "install-deps: Debian packages already present"
fi

# Use the python3 first on PATH (the one the tests will run with).
py=${PYTHON:-python3}
if ! "$py" -c 'import numpy, h5py, matplotlib, scipy, pytest' 2>/dev/null; then
  echo "install-deps: installing Python packages with pip: ${python_packages[*]}"
  "$py" -m pip install -q "${python_packages[@]}" 2>/dev/null \
    || "$py" -m pip install -q --break-system-packages "${python_packages[@]}"
else
  echo "install-deps: Python packages already present"
fi
