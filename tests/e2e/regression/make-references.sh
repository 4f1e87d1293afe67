#!/usr/bin/env bash
# Remakes tests/e2e/regression/references.json from the current code (after an intended change of the
# results; commit the new file with the change and say why). Runs the three regression cases on
# 2 ranks with the options CTest uses. Needs a build (scripts/build.sh; BUILD_DIR overrides it).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../../.." && pwd)
source "$root/scripts/mpi-env.sh"
exe=${BUILD_DIR:-$root/build}/beadmob
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for case in cone chain doublet; do
  (cd "$work" && mpirun -n 2 "$exe" "$here/$case.nml" -ksp_rtol 1e-6 -fft_planner estimate > "$case.log")
done
python3 "$here/check_regression.py" --update "$work"
