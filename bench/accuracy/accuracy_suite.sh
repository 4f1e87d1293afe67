#!/usr/bin/env bash
# Run time against error, every benchmark in one command (bench/README.md): run time
# against error on the paper shapes and a sphere, the --accuracy rule made from it and built in,
# its check on shapes in and out of the tuning data, the L = 4 check of the reference, the
# convergence in L on small bodies, the bead model's resolution, what each skip saves, and the
# long stress tests. Completed runs are kept (bench/*/*_runs/): a second call redoes only what is
# missing. BUILD_DIR selects the build (default build/, Release).
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
cd "$root"
source scripts/mpi-env.sh
export BUILD_DIR=${BUILD_DIR:-$root/build}
bash scripts/build.sh
python3 bench/accuracy/accuracy.py
python3 bench/accuracy/accuracy_rule.py
bash scripts/build.sh                    # the rule just made, built in
python3 bench/accuracy/accuracy_check.py
python3 bench/accuracy/accuracy.py --shapes arrowhead,sphere --reference L4_tight --repeats 1 --name reference_check \
  --settings L1_tight,L2_rtol1e-2,L2_shell1,L2_shell2,L2_default,L2_tight,L3_default,L3_tight
python3 bench/accuracy/accuracy.py --shapes arrowhead --reference L6_tight --repeats 1 --name l_convergence_arrowhead \
  --settings L1_tight,L2_tight,L2_shell1,L2_default,L3_tight,L4_tight,L5_tight
python3 bench/accuracy/l_convergence.py
python3 bench/resolution/resolution.py
python3 bench/skips/skips.py
BUILD_DIR="$root/build-stress" bash tests/e2e/stress/run-long.sh
