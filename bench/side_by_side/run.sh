#!/bin/bash
# The side-by-side tables of issue 24 (medians of 3 alternated runs each, this build):
#   fft_planner.md    FFTW plans estimated against measured (no wisdom: every run plans anew)
#   solve_together.md the motions solved together against one KSPSolve after another
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
exe=${1:-$here/../../build/beadmob}
python3 "$here/side_by_side.py" --exe "$exe" --a "-fft_planner estimate" --b "-fft_planner measure" \
  --title "FFTW plans: estimated (A) against measured without wisdom (B)" --out "$here/fft_planner.md"
python3 "$here/side_by_side.py" --exe "$exe" --a "-fft_planner estimate" --b "-fft_planner estimate -solve_apart" \
  --title "The motions solved together (A) against one KSPSolve after another (B)" --out "$here/solve_together.md"
