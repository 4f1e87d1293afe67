#!/usr/bin/env bash
# The paper's Table tab_mob_num (settlers paper) recomputed: the seven paper shapes at L = 2 on
# 2 ranks, $REPEATS runs each (default 3, wall times as medians) with the lubrication correction
# on (cutoff given below), which also records the order-L friction alone. Writes
# bench/paper_table/paper_table.md (or $PAPER_TABLE) and the result files to bench/paper_table/paper_runs/. Needs a
# Release build (scripts/build.sh; another build directory: $BUILD_DIR). Extra PETSc options:
# $PAPER_OPTIONS; extra &hydrodynamics settings: $PAPER_HYDRO (default none: beadmob's defaults).
#   bench/paper_table/paper_table.md:        PAPER_HYDRO='shell_layers = 0, use_symmetry = .false.' (full model)
#   bench/paper_table/paper_table_shell1.md: PAPER_TABLE=bench/paper_table/paper_table_shell1.md (the default settings)
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
source "$root/scripts/mpi-env.sh"
exe=${BUILD_DIR:-$root/build}/beadmob
out=$root/bench/paper_table/paper_runs
cutoff=${LUBRICATION_CUTOFF:-1.0}
mkdir -p "$out"
repeats=${REPEATS:-3}   # wall times are reported as the median of the repeated runs
shapes=(cone crescent_moon arrowhead ring_1mm ring_2mm ring_3mm ring_4mm)
rm -f "$out/wall_times.txt.new"
for repeat in $(seq "$repeats"); do
  for s in "${shapes[@]}"; do
    # The shape file with its &run output redirected and the hydrodynamics settings of this table.
    sed -e "s|output = '[^']*'|output = '$s.h5'|" -e '/^&hydrodynamics/d' "$root/shapes/$s.nml" > "$out/$s.nml"
    echo "&hydrodynamics multipole_order = 2, lubrication = .true., lubrication_cutoff = $cutoff${PAPER_HYDRO:+, $PAPER_HYDRO} /" >> "$out/$s.nml"
    start=$(date +%s%N)
    (cd "$out" && mpirun -n 2 "$exe" "$s.nml" ${PAPER_OPTIONS:-} > "$s.log")
    echo "$s $(( ($(date +%s%N) - start) / 1000000 ))" >> "$out/wall_times.txt.new"
    echo "paper-table: $s done (run $repeat of $repeats)"
  done
done
mv "$out/wall_times.txt.new" "$out/wall_times.txt"
table=${PAPER_TABLE:-$root/bench/paper_table/paper_table.md}
python3 "$root/bench/paper_table/paper_table.py" "$out" > "$table"
echo "wrote $table"
