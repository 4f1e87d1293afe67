#!/bin/bash
# The side-by-side tables of this folder (medians of 3 alternated runs each, this build):
#   fft_planner.md    FFTW plans estimated against measured (no wisdom: every run plans anew)
#   solve_together.md the motions solved together against one KSPSolve after another (both undeflated)
#   deflation.md      the motions solved together, deflated by their right-hand sides or not
# (the last two tables below: -replicate_products)
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
exe=${1:-$here/../../build/beadmob}
python3 "$here/side_by_side.py" --exe "$exe" --a "-fft_planner estimate" --b "-fft_planner measure" \
  --title "FFTW plans: estimated (A) against measured without wisdom (B)" --out "$here/fft_planner.md"
python3 "$here/side_by_side.py" --exe "$exe" --a "-fft_planner estimate -solve_undeflated" \
  --b "-fft_planner estimate -solve_undeflated -solve_apart" \
  --title "The motions solved together (A) against one KSPSolve after another (B)" --out "$here/solve_together.md"
python3 "$here/side_by_side.py" --exe "$exe" --a "-fft_planner estimate" --b "-fft_planner estimate -solve_undeflated" \
  --jittered 2000 --repeats 5 --title "Deflation by the right-hand sides (A, the default) against plain CG in lockstep (B)" \
  --note "The paper cone and the sphere make no coarse space (their symmetry keeps the solved motions apart: the \
same iterations in A and B), so their two columns run the same code: their differences are the machine's noise." \
  --out "$here/deflation.md"
#   replicated_products.md        the operator distributed (A) or whole on every rank (B), 2 ranks
#                                 (replicated_products_busy_day.md: the same on another day);
#   replicated_products_4ranks.md the random bodies on 4 ranks (oversubscribed on 2 cores)
python3 "$here/side_by_side.py" --exe "$exe" --a "-replicate_products no" --b "-replicate_products yes" \
  --random 300,1000,3000 --repeats 5 \
  --title "Products distributed over the ranks (A) against the operator whole on every rank, a batch dealt out (B)" \
  --note "B's products are the same arithmetic on one rank (agree: rounding). Not the default: it pays on no row \
reliably here (replicated_products_busy_day.md, the same comparison on a busier day of the machine: the random 1000 \
job 0.93)." \
  --out "$here/replicated_products.md"
python3 "$here/side_by_side.py" --exe "$exe" --a "-replicate_products no" --b "-replicate_products yes" \
  --random 1000,3000 --random-only --ranks 4 --repeats 5 \
  --title "Products distributed over 4 ranks (A) against the operator whole on every rank (B), oversubscribed on 2 cores" \
  --out "$here/replicated_products_4ranks.md"
