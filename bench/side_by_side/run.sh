#!/bin/bash
# The side-by-side tables of issue 24 (medians of 3 alternated runs each, this build):
#   fft_planner.md    FFTW plans estimated against measured (no wisdom: every run plans anew)
#   solve_together.md the motions solved together against one KSPSolve after another (both undeflated)
#   deflation.md      the motions solved together, deflated by their right-hand sides or not
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
exe=${1:-$here/../../build/beadmob}
python3 "$here/side_by_side.py" --exe "$exe" --a "-fft_planner estimate" --b "-fft_planner measure" \
  --title "FFTW plans: estimated (A) against measured without wisdom (B)" --out "$here/fft_planner.md"
python3 "$here/side_by_side.py" --exe "$exe" --a "-fft_planner estimate -solve_undeflated" \
  --b "-fft_planner estimate -solve_undeflated -solve_apart" \
  --title "The motions solved together (A) against one KSPSolve after another (B)" --out "$here/solve_together.md"
python3 "$here/side_by_side.py" --exe "$exe" --a "-fft_planner estimate" --b "-fft_planner estimate -solve_undeflated" \
  --repeats 5 --title "Deflation by the right-hand sides (A, the default) against plain CG in lockstep (B)" \
  --note "The paper cone and the sphere make no coarse space (their symmetry keeps the solved motions apart: the \
same iterations in A and B), so their two columns run the same code: their differences are the machine's noise." \
  --out "$here/deflation.md"
