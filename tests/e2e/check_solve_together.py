"""check_solve_together.py BEADMOB MPIEXEC RANKS WORKDIR INPUT: the motions solved together
(src/solvers/lockstep_cg.F90, the default; here without the deflation that is the default too,
-solve_undeflated, whose iterations differ by design: check_deflation.py) against one KSPSolve
after another (-solve_apart),
with the FFT operator (batched products) and the direct one (apply_many's plain loop); the
companion too.

lockstep_cg.F90 promises the iterates of KSPCG one system at a time. Checked per run pair:
- every motion's iteration count within 1 of the apart run's (rounding may move a test by one
  iteration on another CPU), the same converged reasons;
- the friction of order L and of the companion within what the solver promises for both runs
  (tests/e2e/solver_promise.py);
- the condition estimate of B A (Lanczos, lockstep_cg.F90's own tridiagonal against PETSc's
  KSPComputeExtremeSingularValues) within 5 %, and the solver error bound stated;
- a Krylov method other than CG (-ksp_type gmres) is solved apart by itself, and succeeds."""
import os
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np

from checklist import check, failures
import solver_promise


def run(beadmob, mpiexec, ranks, workdir, input_path, *options):
    done = subprocess.run([mpiexec, "-n", str(ranks), beadmob, input_path, "-fft_planner", "estimate", *options],
                          cwd=workdir, capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"beadmob {' '.join(options)} failed ({done.returncode}):\n{done.stdout}\n{done.stderr}")
    (result,) = list(Path(workdir).glob("*.h5"))
    with h5py.File(result, "r") as f:
        h = f["hydrodynamics"]
        record = {key: h.attrs[key][()] for key in ("solve_iterations", "solve_converged_reason", "condition_estimate",
                                                   "companion_iterations", "companion_converged_reason",
                                                   "solver_error_bound", "companion_solver_error_bound",
                                                   "solved_together", "companion_solved_together")}
        record.update(friction=h["friction"][()], multipole_friction=h["multipole_friction"][()],
                      companion_friction=h["companion_friction"][()], bound=solver_promise.bound(h),
                      companion_bound=solver_promise.bound(h, "companion_solver_error_bound"))
    result.unlink()
    return record


def compare(together, apart, name):
    for key in ("solved_together", "companion_solved_together"):
        check(int(together[key]) == 1 and int(apart[key]) == 0,
              f"{name}: {key} is 1 together, 0 apart (got {together[key]}, {apart[key]})")
    for level in ("solve", "companion"):
        its_t, its_a = together[f"{level}_iterations"], apart[f"{level}_iterations"]
        check(np.abs(its_t - its_a).max() <= 1, f"{name}, {level}: iterations together {its_t.tolist()}, "
              f"apart {its_a.tolist()}")
        reasons = together[f"{level}_converged_reason"].tolist()
        check(reasons == apart[f"{level}_converged_reason"].tolist(), f"{name}, {level}: the same converged reasons {reasons}")
    check(together["bound"] is not None and apart["bound"] is not None, f"{name}: both runs state a solver bound")
    if together["bound"] is not None and apart["bound"] is not None:
        allowed = solver_promise.allowed_difference([together["bound"], apart["bound"]], apart["multipole_friction"])
        ratio = np.nanmax(np.abs(together["friction"] - apart["friction"]) / allowed)
        check(ratio <= 1, f"{name}: friction together = apart within the solver bounds ({ratio:.2e} of them)")
    if together["companion_bound"] is not None and apart["companion_bound"] is not None:
        allowed = solver_promise.allowed_difference([together["companion_bound"], apart["companion_bound"]],
                                                    apart["companion_friction"])
        ratio = np.nanmax(np.abs(together["companion_friction"] - apart["companion_friction"]) / allowed)
        check(ratio <= 1, f"{name}: companion friction together = apart within the solver bounds ({ratio:.2e})")
    kappa_t, kappa_a = float(together["condition_estimate"]), float(apart["condition_estimate"])
    check(abs(kappa_t - kappa_a) <= 0.05 * kappa_a,
          f"{name}: condition estimate together {kappa_t:.4g}, apart (PETSc) {kappa_a:.4g}")


def main(beadmob, mpiexec, ranks, workdir, input_path):
    workdir = Path(workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    for old in workdir.glob("*.h5"):
        old.unlink()
    for operator in ("fft", "direct"):
        together = run(beadmob, mpiexec, ranks, workdir, input_path, "-operator", operator, "-solve_undeflated")
        apart = run(beadmob, mpiexec, ranks, workdir, input_path, "-operator", operator, "-solve_apart")
        compare(together, apart, f"operator {operator}")
    gmres = run(beadmob, mpiexec, ranks, workdir, input_path, "-ksp_type", "gmres")
    check(gmres["solve_converged_reason"].min() > 0, f"-ksp_type gmres converges: {gmres['solve_converged_reason'].tolist()}")
    check(int(gmres["solved_together"]) == 0, "-ksp_type gmres: solved one KSPSolve after another (solved_together 0)")
    if failures:
        sys.exit(f"{len(failures)} check(s) failed")
    print("check_solve_together: all checks passed")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4], sys.argv[5])
