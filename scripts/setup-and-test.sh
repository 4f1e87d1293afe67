#!/usr/bin/env bash
# README command 2: install the dependencies, build (Debug: runtime checks on), and run every
# test: the Fortran test programs serially and on two ranks, the command-line tests, pytest.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
source "$root/scripts/mpi-env.sh"
bash "$root/scripts/install-deps.sh"
BUILD_TYPE=${BUILD_TYPE:-Debug} BUILD_DIR=${BUILD_DIR:-$root/build-test} bash "$root/scripts/build.sh"
cd "${BUILD_DIR:-$root/build-test}"
ctest --output-on-failure -j "$(nproc)" "$@"
