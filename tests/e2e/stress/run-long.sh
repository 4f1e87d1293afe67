#!/usr/bin/env bash
# The long stress tests (label stress_long, docs/stress_tests.md): a Release build with
# -DBEADMOB_LONG_TESTS=ON into BUILD_DIR (default build-stress), then ctest -L stress_long (CTest
# adds the default-suite runs these checks compare with). Extra arguments go to ctest.
# The 1000-bead chain took 3.9 GB per rank before the block-table fix; now ~60 MB (docs/stress_tests.md).
set -euo pipefail
root=$(cd "$(dirname "$0")/../../.." && pwd)
build_dir=${BUILD_DIR:-$root/build-stress}
source "$root/scripts/mpi-env.sh"
cmake -S "$root" -B "$build_dir" -DCMAKE_BUILD_TYPE="${BUILD_TYPE:-Release}" -DBEADMOB_LONG_TESTS=ON >/dev/null
cmake --build "$build_dir" -j "$(nproc)"
cd "$build_dir"
ctest --output-on-failure -j "$(nproc)" -L stress_long "$@"
