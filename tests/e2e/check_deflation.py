"""check_deflation.py BEADMOB MPIEXEC RANKS WORKDIR: the motions solved together with deflation by
the coarse space of their preconditioned right-hand sides (src/solvers/deflation_space.F90, the
default) against plain CG in lockstep (-solve_undeflated), on a random compact lattice body
without symmetry (Eden growth, 300 beads: all six motions coupled), fft and direct operators.

Checked, per operator:
- the deflated run used six coarse vectors for the solves and six for the companion's, the plain
  run none;
- every motion converged, and deflation saved iterations: no motion needs more than plain CG
  and the total is at least 10 % smaller (measured 25 % on a 1000-bead body);
- the friction of order L and of the companion equal within what the solver promises for both
  runs (tests/e2e/solver_promise.py: each within its stated bound of the exact solve);
- the condition estimate of B A, which the bound uses, within 30 % of plain CG's Lanczos estimate
  (deflation_space.F90 takes the largest eigenvalue from the coarse space).
And on the paper cone with its symmetry (symmetry_cone.nml: U_x, U_z, W_x, W_z solved, each pair
kept apart by a mirror of the group) no coarse space is made: it could not save an iteration."""
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np

from checklist import check, failures
from eden_body import eden_body
import solver_promise


def run(beadmob, mpiexec, ranks, workdir, input_path, *options):
    done = subprocess.run([mpiexec, "-n", str(ranks), beadmob, str(input_path), "-fft_planner", "estimate", "-quiet",
                           *options], cwd=workdir, capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"beadmob {' '.join(options)} failed ({done.returncode}):\n{done.stdout}\n{done.stderr}")
    (result,) = list(Path(workdir).glob("*.h5"))
    with h5py.File(result, "r") as f:
        h = f["hydrodynamics"]
        record = {key: h.attrs[key] for key in h.attrs}
        record.update(friction=h["friction"][()], multipole_friction=h["multipole_friction"][()],
                      companion_friction=h["companion_friction"][()], bound=solver_promise.bound(h),
                      companion_bound=solver_promise.bound(h, "companion_solver_error_bound"))
    result.unlink()
    return record


def within_promise(a, b, key, bound_key, name):
    if a[bound_key] is None or b[bound_key] is None:
        check(False, f"{name}: both runs state a solver bound ({bound_key})")
        return
    allowed = solver_promise.allowed_difference([a[bound_key], b[bound_key]], b[key])
    ratio = np.nanmax(np.abs(a[key] - b[key]) / allowed)
    check(ratio <= 1, f"{name}: {key} deflated = plain within the solver bounds ({ratio:.2e} of them)")


def main(beadmob, mpiexec, ranks, workdir):
    workdir = Path(workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    for old in workdir.glob("*.h5"):
        old.unlink()
    np.savetxt(workdir / "eden_300.txt", eden_body(300, seed=7), fmt="%.1f", header="x y z (bead diameters)")
    nml = workdir / "eden_300.nml"
    nml.write_text("&run output = 'eden_300.h5' /\n&shape name = 'bead_file', file = 'eden_300.txt' /\n"
                   "&hydrodynamics /\n")
    for operator in ("fft", "direct"):
        name = f"operator {operator}"
        deflated = run(beadmob, mpiexec, ranks, workdir, nml, "-operator", operator)
        plain = run(beadmob, mpiexec, ranks, workdir, nml, "-operator", operator, "-solve_undeflated")
        check(int(deflated["deflation_vectors"]) == 6 and int(deflated["companion_deflation_vectors"]) == 6,
              f"{name}: six coarse vectors for the solves and the companion's "
              f"({deflated['deflation_vectors']}, {deflated['companion_deflation_vectors']})")
        check(int(plain["deflation_vectors"]) == 0, f"{name}: -solve_undeflated makes no coarse space")
        for level in ("solve", "companion"):
            its_d, its_p = deflated[f"{level}_iterations"], plain[f"{level}_iterations"]
            check(deflated[f"{level}_converged_reason"].min() > 0, f"{name}, {level}: every motion converged")
            check(np.all(its_d <= its_p) and its_d.sum() <= 0.9 * its_p.sum(),
                  f"{name}, {level}: iterations deflated {its_d.tolist()} against plain {its_p.tolist()}")
        within_promise(deflated, plain, "friction", "bound", name)
        within_promise(deflated, plain, "companion_friction", "companion_bound", name)
        kappa_d, kappa_p = float(deflated["condition_estimate"]), float(plain["condition_estimate"])
        check(abs(kappa_d - kappa_p) <= 0.3 * kappa_p, f"{name}: condition estimate deflated {kappa_d:.4g}, "
              f"plain {kappa_p:.4g}")
    cone = run(beadmob, mpiexec, ranks, workdir, Path(__file__).parent / "inputs" / "symmetry_cone.nml")
    check(int(cone["deflation_vectors"]) == 0 and int(cone["companion_deflation_vectors"]) == 0,
          f"the symmetric cone's motions are kept apart by its mirrors: no coarse space "
          f"({cone['deflation_vectors']}, {cone['companion_deflation_vectors']})")
    if failures:
        sys.exit(f"{len(failures)} check(s) failed")
    print("check_deflation: all checks passed")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4])
