#!/usr/bin/env bash
# Scaling study (issue "fast operator"): filled lattice spheres of about 1e3, 1e4, 3e4 and 1e5
# beads at L = 2 (FFT operator, default solver settings) on 2 ranks, and strong scaling 1 -> 2
# ranks on the paper's cone and the 1e4 and 1e5 spheres. One run each (the long runs take minutes; see
# bench/README.md for the noise caveat). Writes bench/scaling.csv and bench/scaling.md.
# Needs a Release build (scripts/build.sh). SCALING_RADII overrides the sphere radii.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
source "$root/scripts/mpi-env.sh"
exe=${BUILD_DIR:-$root/build}/beadmob
work=$root/bench/scaling_runs
mkdir -p "$work"
radii=${SCALING_RADII:-"6.2 13.4 19.3 28.8"}
run() {  # run <tag> <ranks> <shape group>
  printf "&run output = '%s.h5' /\n%s\n&hydrodynamics multipole_order = 2 /\n" "$1" "$3" > "$work/$1.nml"
  (cd "$work" && mpirun -n "$2" "$exe" "$1.nml" > "$1.log" 2>&1)
  echo "scaling: $1 done"
}
for r in $radii; do
  run "sphere_r${r}_np2" 2 "&shape name = 'sphere', radius = $r /"
done
run cone_np1 1 "&shape name = 'cone', base_diameter = 20, height = 47 /"
run cone_np2 2 "&shape name = 'cone', base_diameter = 20, height = 47 /"
run "sphere_r13.4_np1" 1 "&shape name = 'sphere', radius = 13.4 /"
run "sphere_r28.8_np1" 1 "&shape name = 'sphere', radius = 28.8 /"
python3 "$root/bench/scaling_table.py" "$work" "$root/bench"
