#!/usr/bin/env bash
# README command 1: install the dependencies, build, and run the main job on its built-in
# default (the paper's cone) on two MPI ranks; the result goes to run/beadmob_result.h5.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
source "$root/scripts/mpi-env.sh"
bash "$root/scripts/install-deps.sh"
bash "$root/scripts/build.sh"
mkdir -p "$root/run"
cd "$root/run"
mpiexec -n "${RANKS:-2}" "$root/build/beadmob" "$@"
python3 "$root/scripts/beadmob-post" info beadmob_result.h5
python3 "$root/scripts/beadmob-post" plot-beads beadmob_result.h5 -o beadmob_result_beads.png
