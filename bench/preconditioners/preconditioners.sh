#!/usr/bin/env bash
# Krylov iterations per solve against N for each preconditioner: filled
# lattice spheres of about 1e3, 1e4 and 3e4 beads (and the paper cone) at L = 2, 2 ranks, CG at the
# default tolerance, with
#   none        -pc_type none
#   bead        the single-bead blocks (default, PCSHELL)
#   cluster2/3  exact blocks of 2^3 / 3^3 lattice-cell clusters, MUMPS Cholesky (-near_field_cluster)
#   guess       single-bead blocks, initial guess of each solve projected from the earlier
#               solutions (-ksp_guess_type fischer, PETSc KSPGuess)
#   radius1     single-bead blocks plus nearest-neighbour pair blocks, MUMPS Cholesky
#               (-near_field_radius 1; the truncated matrix is not positive definite, see
#               docs/theory.md T11; run on the two smaller spheres only)
# One run per cell (iteration counts do not depend on machine load). Writes
# bench/preconditioners/preconditioners.md. Needs a Release build (scripts/build.sh); BUILD_DIR overrides it.
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
source "$root/scripts/mpi-env.sh"
exe=${BUILD_DIR:-$root/build}/beadmob
work=$root/bench/preconditioners/preconditioner_runs
mkdir -p "$work"
declare -A options=([none]="-pc_type none" [bead]="" [guess]="-ksp_guess_type fischer -ksp_guess_fischer_model 1,6"
                    [cluster2]="-near_field_cluster 2"
                    [cluster3]="-near_field_cluster 3" [radius1]="-near_field_radius 1")
run() {  # run <model tag> <shape group> <variant>
  local tag=$1_$3
  printf "&run output = '%s.h5' /\n%s\n&hydrodynamics multipole_order = 2 /\n" "$tag" "$2" > "$work/$tag.nml"
  # A variant may fail to converge or break down (indefinite preconditioner): recorded, not fatal.
  (cd "$work" && mpirun -n 2 "$exe" "$tag.nml" ${options[$3]} > "$tag.log" 2>&1) || echo "failed" >> "$work/$tag.log"
  echo "preconditioners: $tag done"
}
for variant in bead none guess cluster2 cluster3 radius1; do
  run cone "&shape name = 'cone', base_diameter = 20, height = 47 /" "$variant"
  for r in 6.2 13.4; do
    run "sphere_r$r" "&shape name = 'sphere', radius = $r /" "$variant"
  done
  if [ "$variant" != radius1 ]; then
    run sphere_r19.3 "&shape name = 'sphere', radius = 19.3 /" "$variant"
  fi
done
python3 "$root/bench/preconditioners/preconditioners_table.py" "$work" > "$root/bench/preconditioners/preconditioners.md"
echo "wrote bench/preconditioners/preconditioners.md"
