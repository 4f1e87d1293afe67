"""check_fft_wisdom.py BEADMOB MPIEXEC RANKS WORKDIR INPUT: measured FFT plans are remembered
between runs next to the table cache (src/operators/fft_operator.F90, plan_transforms).

1. A run with a fresh cache plans anew (fft_plans_from_wisdom = 0) and writes
   <cache>.fftw_wisdom, with no partial file left beside it.
2. A second run on the same body takes its plans from that wisdom (= 1). Its friction equals the
   first run's within what the solver promises for both (tests/e2e/solver_promise.py): measured
   plans may pick other exact FFT algorithms, whose rounding differs.
3. A damaged wisdom file gives one warning naming it, the run plans anew, succeeds and rewrites it."""
import os
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np

import solver_promise


def run(beadmob, mpiexec, ranks, workdir, input_path, cache):
    env = dict(os.environ, BEADMOB_CACHE=str(cache))
    done = subprocess.run([mpiexec, "-n", str(ranks), beadmob, input_path, "-operator", "fft", "-fft_planner", "measure",
                           "-quiet"], cwd=workdir, env=env, capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"beadmob failed ({done.returncode}):\n{done.stdout}\n{done.stderr}")
    (result,) = list(Path(workdir).glob("*.h5"))
    with h5py.File(result, "r") as f:
        h = f["hydrodynamics"]
        record = {"from_wisdom": int(h.attrs["fft_plans_from_wisdom"]), "friction": h["friction"][()],
                  "multipole_friction": h["multipole_friction"][()], "bound": solver_promise.bound(h)}
    result.unlink()
    return record, done.stderr


def main(beadmob, mpiexec, ranks, workdir, input_path):
    workdir = Path(workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    (workdir / "cache").mkdir(exist_ok=True)
    cache = workdir / "cache" / "wisdom_cache.h5"
    wisdom = Path(str(cache) + ".fftw_wisdom")
    for old in [cache, wisdom, Path(str(wisdom) + ".partial"), *workdir.glob("*.h5")]:
        old.unlink(missing_ok=True)
    failures = []
    first, _ = run(beadmob, mpiexec, ranks, workdir, input_path, cache)
    if first["from_wisdom"] != 0:
        failures.append("first run: plans reported as remembered, but there was no wisdom yet")
    if not wisdom.is_file() or wisdom.stat().st_size == 0:
        failures.append(f"first run: no wisdom file {wisdom}")
    if Path(str(wisdom) + ".partial").exists():
        failures.append("first run: a partial wisdom file was left behind")
    second, _ = run(beadmob, mpiexec, ranks, workdir, input_path, cache)
    if second["from_wisdom"] != 1:
        failures.append("second run: plans not taken from the remembered wisdom")
    if first["bound"] is None or second["bound"] is None:
        failures.append("a run states no solver error bound")
    else:
        allowed = solver_promise.allowed_difference([first["bound"], second["bound"]], first["multipole_friction"])
        difference = np.abs(first["friction"] - second["friction"])
        if not np.all(difference <= allowed):
            failures.append(f"friction differs beyond the solver's promise: {np.max(difference / allowed):.2f} x allowed")
    wisdom.write_text("not FFTW wisdom\n")
    third, stderr = run(beadmob, mpiexec, ranks, workdir, input_path, cache)
    if "could not be read" not in stderr or str(wisdom.name) not in stderr:
        failures.append(f"damaged wisdom: no warning naming the file; stderr was:\n{stderr}")
    if third["from_wisdom"] != 0 or wisdom.read_text().startswith("not FFTW wisdom"):
        failures.append("damaged wisdom: the run did not plan anew and rewrite the file")
    for failure in failures:
        print("FAIL:", failure)
    if failures:
        sys.exit(1)
    print("fft wisdom: remembered, reused, and a damaged file replaced")


if __name__ == "__main__":
    main(*sys.argv[1:6])
