#!/usr/bin/env bash
# Scaling study: filled lattice spheres of
# about 1e3 ... 1e6 beads at L = 2 with the default settings (FFT operator, one surface layer,
# symmetry-derived motions, CG tolerance 1e-3), 2 ranks; the 1e5 sphere and the paper cone also on 1
# and 4 ranks (4 oversubscribed on the 2-core machine); before each run the dry run's estimate for
# the same ranks (bench/scaling/scaling.md, "Estimate against measurement"). With PREV_EXE (the beadmob of
# an earlier commit) the 1e5 sphere is run PAIRS times side by side, new and previous in turn.
# One run per row otherwise (the large runs take minutes). Writes bench/scaling/scaling.csv, .md, .png.
# Needs a Release build (scripts/build.sh). SCALING_RADII overrides the 2-rank sphere radii.
# ESTIMATES_ONLY=1 redoes only the dry runs of the kept runs (after a change of the estimate).
# PREV_LABEL names the previous build in the table (e.g. its commit).
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
source "$root/scripts/mpi-env.sh"
exe=${EXE:-${BUILD_DIR:-$root/build}/beadmob}
work=$root/bench/scaling/scaling_runs
mkdir -p "$work"
radii=${SCALING_RADII:-"28.8 41.5 62.1 6.2 13.4 19.3"}
run() {  # run <tag> <ranks> <shape group> [executable] [more &hydrodynamics settings]
  local program=${4:-$exe}
  printf "&run output = '%s.h5' /\n%s\n&hydrodynamics multipole_order = 2%s /\n" "$1" "$3" "${5:-}" > "$work/$1.nml"
  if [ "$program" = "$exe" ]; then
    (cd "$work" && mpirun -n "$2" "$program" --estimate "$1.nml" > "$1.estimate" 2>&1)
  fi
  [ -n "${ESTIMATES_ONLY:-}" ] && return
  (cd "$work" && /usr/bin/time -f "%e" -o "$1.wall" mpirun -n "$2" "$program" "$1.nml" -quiet > "$1.log" 2>&1)
  echo "scaling: $1 done ($(cat "$work/$1.wall") s)"
}
sphere() { echo "&shape name = 'sphere', radius = $1 /"; }
cone="&shape name = 'cone', base_diameter = 20, height = 47 /"
run sphere_r28.8_np2 2 "$(sphere 28.8)"
run sphere_r28.8_np1 1 "$(sphere 28.8)"
run sphere_r28.8_np4 4 "$(sphere 28.8)"
if [ -n "${PREV_EXE:-}" ] && [ -z "${ESTIMATES_ONLY:-}" ]; then
  for k in $(seq 1 "${PAIRS:-3}"); do
    run "pair${k}_new_sphere_r28.8_np2" 2 "$(sphere 28.8)"
    run "pair${k}_previous_sphere_r28.8_np2" 2 "$(sphere 28.8)" "$PREV_EXE"
  done
  # The full model (every bead in the solve, no symmetry-derived motions): the job of the table
  # before the shell default, 97 s on 2 ranks then.
  for k in $(seq 1 "${FULL_PAIRS:-1}"); do
    run "fullpair${k}_new_sphere_r28.8_np2" 2 "$(sphere 28.8)" "$exe" ", shell_layers = 0, use_symmetry = .false."
    run "fullpair${k}_previous_sphere_r28.8_np2" 2 "$(sphere 28.8)" "$PREV_EXE" ", shell_layers = 0, use_symmetry = .false."
  done
fi
for r in $radii; do
  [ -f "$work/sphere_r${r}_np2.h5" ] && [ -z "${ESTIMATES_ONLY:-}" ] || run "sphere_r${r}_np2" 2 "$(sphere "$r")"
done
run cone_np1 1 "$cone"
run cone_np2 2 "$cone"
run cone_np4 4 "$cone"
python3 "$root/bench/scaling/scaling_table.py" "$work" "$root/bench/scaling"
