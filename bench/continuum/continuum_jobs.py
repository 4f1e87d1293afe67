"""Helpers the continuum benches share (continuum.py, coverage.py): one beadmob job on 2 ranks in a
working folder, and the &shape group of an ellipsoid."""
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
RANKS = 2
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")


class JobFailed(RuntimeError):
    """beadmob exited with an error; the message holds the input and what it printed."""


def run(exe, text, workdir, name="job", fatal=True, options=(), fresh=True):
    """Run `&run output = '<name>.h5', progress = .false. /` + text on RANKS ranks in workdir (the
    input written to <name>.nml, what the job printed to <name>.log; a stale result file and
    continuum checkpoint are removed first): (result file, wall time of the whole process in s).
    A failed job exits the script (fatal) or raises JobFailed. `options`: beadmob's command-line
    options after the input file (e.g. -keep_checkpoint). fresh = False keeps a continuum
    checkpoint of the same input, so the job resumes from (or only re-extrapolates) its samples."""
    workdir = Path(workdir)
    nml, result = workdir / f"{name}.nml", workdir / f"{name}.h5"
    nml.write_text(f"&run output = '{name}.h5', progress = .false. /\n" + text)
    for stale in (result, workdir / f"{name}.h5.continuum_checkpoint") if fresh else (result,):
        stale.unlink(missing_ok=True)
    start = time.perf_counter()
    done = subprocess.run(["mpiexec", "-n", str(RANKS), str(exe), str(nml), *options], cwd=workdir, env=ENV,
                          capture_output=True, text=True)
    wall = time.perf_counter() - start
    (workdir / f"{name}.log").write_text(done.stdout + done.stderr)
    if done.returncode != 0:
        message = f"beadmob failed on\n{text}\n{done.stdout}\n{done.stderr}"
        if fatal:
            sys.exit(message)
        raise JobFailed(message)
    return result, wall


def spheroid(semi_axes, bead_diameter=0.125):
    """&shape (spheroid of these semi-axes along x, y, z in its own unit) and a default &hydrodynamics."""
    return ("&shape name = 'spheroid', semi_axes = " + ", ".join(f"{a:g}" for a in semi_axes) +
            f", bead_diameter = {bead_diameter:g} /\n&hydrodynamics /\n")
