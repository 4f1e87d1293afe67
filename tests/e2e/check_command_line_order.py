#!/usr/bin/env python3
"""check_command_line_order.py BEADMOB MPIEXEC RANKS WORKDIR: the input file is the one argument
that is neither an option nor an option's value, wherever it stands (src/driver/command_line.F90,
find_input_argument; docs/input.md, "Command-line options").

A small job (a sphere of radius 2: 33 beads, written to order.h5) is run with its options before
and after the input file. Each run must run that job, not the built-in default (the paper's cone,
5088 beads, written to beadmob_result.h5), and an option must take effect: -ksp_rtol 1e-6 is the
Krylov tolerance recorded, -operator fft the operator (auto picks direct for 33 beads), -quiet prints no progress line,
-estimate writes nothing. A PETSc option without a value before the input file (-ksp_monitor
job.nml) leaves the input file as it was. Two input files, or a stray word, are refused naming
both, before anything runs (no result file)."""
import subprocess
import sys
from pathlib import Path

import h5py

sys.path.insert(0, str(Path(__file__).resolve().parent))
from checklist import check, failures  # noqa: E402

JOB = "&run output = 'order.h5' /\n&shape name = 'sphere', radius = 2 /\n&hydrodynamics /\n"
SPHERE_BEADS = 33   # lattice nodes with |r| <= 2: 1 + 6 + 12 + 8 + 6 (|r|^2 = 0, 1, 2, 3, 4)


def run(beadmob, mpiexec, ranks, workdir, *args):
    for name in ("order.h5", "beadmob_result.h5"):
        (workdir / name).unlink(missing_ok=True)
    return subprocess.run([mpiexec, "-n", str(ranks), beadmob, *args], cwd=workdir, capture_output=True, text=True)


def result(workdir):
    with h5py.File(workdir / "order.h5", "r") as f:
        hydro = f["hydrodynamics"].attrs
        return len(f["geometry"]["positions"]), hydro["ksp_relative_tolerance"], hydro["operator"]


def main(beadmob, mpiexec, ranks, workdir):
    workdir = Path(workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    (workdir / "job.nml").write_text(JOB)
    (workdir / "other.nml").write_text(JOB)
    runs = [
        (["-quiet", "job.nml"], lambda beads, rtol, op, out: "progress" not in out),
        (["job.nml", "-quiet"], lambda beads, rtol, op, out: "progress" not in out),
        (["-ksp_rtol", "1e-6", "job.nml"], lambda beads, rtol, op, out: abs(rtol - 1e-6) < 1e-18),
        (["-operator", "fft", "job.nml"], lambda beads, rtol, op, out: op == "fft"),
        (["-ksp_monitor", "job.nml", "-quiet"], lambda beads, rtol, op, out: (workdir / "job.nml").read_text() == JOB),
    ]
    for args, effect in runs:
        done = run(beadmob, mpiexec, ranks, workdir, *args)
        ran = done.returncode == 0 and (workdir / "order.h5").exists() and not (workdir / "beadmob_result.h5").exists()
        if not ran:
            check(False, f"beadmob {' '.join(args)}: exit {done.returncode}, order.h5 written: "
                  f"{(workdir / 'order.h5').exists()}\n{done.stdout[-2000:]}\n{done.stderr[-2000:]}")
            continue
        beads, rtol, op = result(workdir)
        op = op.decode() if isinstance(op, bytes) else str(op)
        check(beads == SPHERE_BEADS and effect(beads, rtol, op, done.stdout),
              f"beadmob {' '.join(args)}: the input's sphere ({beads} beads), the option applied "
              f"(tolerance {rtol:g}, operator {op})")
    for option in ("-estimate", "--estimate"):
        done = run(beadmob, mpiexec, ranks, workdir, option, "job.nml")
        check(done.returncode == 0 and f"beads:                {SPHERE_BEADS} " in done.stdout
              and not any((workdir / name).exists() for name in ("order.h5", "beadmob_result.h5")),
              f"beadmob {option} job.nml: the dry run of the input's sphere, nothing written")
    for args in (["job.nml", "other.nml"], ["-quiet", "job.nml", "stray"], ["stray", "-ksp_rtol", "1e-6", "job.nml"]):
        done = run(beadmob, mpiexec, ranks, workdir, *args)
        words = [a for a in args if not a.startswith("-") and a != "1e-6"]
        check(done.returncode != 0 and all(f"'{w}'" in done.stderr for w in words)
              and "two input files" in done.stderr
              and not any((workdir / name).exists() for name in ("order.h5", "beadmob_result.h5")),
              f"beadmob {' '.join(args)}: refused naming {words}: "
              f"{(done.stderr.strip().splitlines() or [''])[0]!r}")
    if failures:
        sys.exit(f"{len(failures)} check(s) failed")
    print("check_command_line_order: all checks passed")


if __name__ == "__main__":
    main(*sys.argv[1:5])
