#!/usr/bin/env bash
# The README's orbit pictures: the paper's cone and a triaxial lattice ellipsoid (semi-axes 12, 8, 4 d)
# in simple shear u = gamma y e_x, from runs with &hydrodynamics flow = .true. (docs/theory.md T19)
# and `beadmob-post orbit` (docs/postprocessing.md). Usage, from the top of a built clone:
#   bash docs/figures/flow/make_flow_figures.sh [BUILD_DIR]
set -euo pipefail
root=$(cd "$(dirname "$0")/../../.." && pwd)
build=${1:-$root/build}
here=$root/docs/figures/flow
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
source "$root/scripts/mpi-env.sh"
sed "s/output = 'cone.h5'/output = 'cone_flow.h5'/; s/&hydrodynamics multipole_order = 2/\&hydrodynamics flow = .true., multipole_order = 2/" \
  "$root/shapes/cone.nml" > "$work/cone_flow.nml"
cat > "$work/triaxial_flow.nml" <<'NML'
&run output = 'triaxial_flow.h5' /
&shape name = 'spheroid', semi_axes = 12, 8, 4 /
&hydrodynamics flow = .true. /
NML
(cd "$work" && mpirun -n 2 "$build/beadmob" cone_flow.nml -quiet && mpirun -n 2 "$build/beadmob" triaxial_flow.nml -quiet)
# The cone's axis starts 21 degrees from the vorticity: a Jeffery orbit (closed, period printed).
"$root/scripts/beadmob-post" orbit "$work/cone_flow.h5" --initial-axis 0.3,0.2,0.93 --strain 100 \
  --plot "$here/cone_orbit.png" | tee "$here/cone_orbit.txt"
# The triaxial body's long axis likewise: no closed orbit (quasi-periodic tumbling).
"$root/scripts/beadmob-post" orbit "$work/triaxial_flow.h5" --axis x --initial-axis 0.2,0.3,0.93 --strain 200 \
  --plot "$here/triaxial_orbit.png" | tee "$here/triaxial_orbit.txt"
