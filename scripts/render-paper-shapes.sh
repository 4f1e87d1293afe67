#!/usr/bin/env bash
# Build the paper's seven bead models (after scripts/build.sh) and draw each into
# docs/shapes/<shape>.png (three orthogonal views coloured by depth), to compare with the
# paper's figures. The result files go to run/shapes/. Shapes: the arguments (default all seven);
# the geometry only (-geometry_only); another build directory: $BUILD_DIR.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
source "$root/scripts/mpi-env.sh"
mkdir -p "$root/run/shapes" "$root/docs/shapes"
cd "$root/run/shapes"
shapes=("$@")
[ ${#shapes[@]} -gt 0 ] || shapes=(cone arrowhead crescent_moon ring_1mm ring_2mm ring_3mm ring_4mm)
for shape in "${shapes[@]}"; do
  mpiexec -n "${RANKS:-2}" "${BUILD_DIR:-$root/build}/beadmob" "$root/shapes/$shape.nml" -geometry_only \
    | grep -E "shape|beads:"
  python3 "$root/scripts/beadmob-post" plot-beads "$shape.h5" -o "$root/docs/shapes/$shape.png"
done
