"""check_mirror_classes.py BEADMOB MPIEXEC RANKS WORKDIR INPUT...: the FFT operator's products by
mirror class (docs/theory.md T4, "Mirror classes"; the default on a bead set with two lattice mirror
planes) against the products on the whole padded box (-fft_whole_box), the same job otherwise.

The two are the same linear operator computed two ways (cosine and sine transforms of the
fundamental beads against the pruned FFT of the whole box), so CG makes the same iterates up to
rounding. Checked per input:
- fft_by_mirror_class is 1 by default and 0 with -fft_whole_box;
- every motion's iteration count at order L within 1 of the other run's (rounding may move a
  test by one iteration on another CPU); not the companion's, which starts from the order-L
  solution, and that differs between the runs within the solver's tolerance, not by rounding;
- the friction of order L and the companion's within what the solver promises for both runs
  (tests/e2e/solver_promise.py)."""
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np

from checklist import check, failures
import solver_promise


def run(beadmob, mpiexec, ranks, workdir, input_path, *options):
    done = subprocess.run([mpiexec, "-n", str(ranks), beadmob, input_path, "-operator", "fft", "-quiet", *options],
                          cwd=workdir, capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"beadmob {input_path} {' '.join(options)} failed ({done.returncode}):\n{done.stdout}\n{done.stderr}")
    (result,) = list(Path(workdir).glob("*.h5"))
    with h5py.File(result, "r") as f:
        h = f["hydrodynamics"]
        record = {key: h.attrs[key][()] for key in ("fft_by_mirror_class", "solve_iterations")}
        record.update(friction=h["friction"][()], multipole_friction=h["multipole_friction"][()],
                      companion_friction=h["companion_friction"][()], bound=solver_promise.bound(h),
                      companion_bound=solver_promise.bound(h, "companion_solver_error_bound"))
    result.unlink()
    return record


def main(beadmob, mpiexec, ranks, workdir, *inputs):
    workdir = Path(workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    for old in workdir.glob("*.h5"):
        old.unlink()
    for input_path in inputs:
        name = Path(input_path).stem
        by_class = run(beadmob, mpiexec, ranks, workdir, input_path)
        whole = run(beadmob, mpiexec, ranks, workdir, input_path, "-fft_whole_box")
        check(int(by_class["fft_by_mirror_class"]) == 1 and int(whole["fft_by_mirror_class"]) == 0,
              f"{name}: fft_by_mirror_class 1 by default, 0 with -fft_whole_box "
              f"(got {by_class['fft_by_mirror_class']}, {whole['fft_by_mirror_class']})")
        a, b = by_class["solve_iterations"], whole["solve_iterations"]
        check(np.abs(a - b).max() <= 1, f"{name}: iterations by class {a.tolist()}, whole box {b.tolist()}")
        for key, bound_key, reference in (("friction", "bound", "multipole_friction"),
                                          ("companion_friction", "companion_bound", "companion_friction")):
            check(by_class[bound_key] is not None and whole[bound_key] is not None, f"{name}: {key}: solver bounds stated")
            if by_class[bound_key] is None or whole[bound_key] is None:
                continue
            allowed = solver_promise.allowed_difference([by_class[bound_key], whole[bound_key]], whole[reference])
            ratio = np.nanmax(np.abs(by_class[key] - whole[key]) / allowed)
            check(ratio <= 1, f"{name}: {key} by class = whole box within the solver bounds ({ratio:.2e} of them)")
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main(*sys.argv[1:])
