#!/usr/bin/env python3
"""Where the FFT operator becomes the cheaper lattice operator, and whether `-operator auto` picks
the faster one: writes bench/operator_check/lattice_crossover.md.

Lattice models from a few beads to a few hundred: random compact bodies (Eden growth,
tests/e2e/eden_body.py: no symmetry, six solves) and lattice balls (every mirror of the lattice:
few solves, products by mirror class), at multipole orders L = 1, 2, 3 with the default settings
(shell model, error bar from L >= 2). Each cell runs the job with `-operator direct` and
`-operator fft` in turn, --repeats times, 2 ranks; the friction job's own time (phase `total` of
the result file) and the whole process are the medians. Beside them: each operator's estimate
(the dry run's cost model, `estimated_seconds` of the result file), the operator `auto` picks
with this build and, with --before, with another build.

usage: python3 bench/operator_check/lattice_crossover.py [--exe build/beadmob] [--before OLD_EXE]
       [--repeats 5]   (needs a Release build: bash scripts/build.sh)
"""
import argparse
import os
import platform
import re
import statistics
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "e2e"))
from eden_body import eden_body  # noqa: E402

HERE = Path(__file__).resolve().parent
WORK = HERE / "lattice_crossover_runs"
RANKS = 2
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
           OMPI_MCA_pml=os.environ.get("OMPI_MCA_pml", "ob1"))


def ball(radius):
    """Lattice points within `radius` of a site: symmetric under every lattice mirror."""
    r = int(np.ceil(radius))
    grid = np.array([(x, y, z) for x in range(-r, r + 1) for y in range(-r, r + 1) for z in range(-r, r + 1)], float)
    return grid[np.sum(grid**2, axis=1) <= radius**2 + 1e-9]


def write_input(name, beads, order):
    np.savetxt(WORK / f"{name}.txt", beads, header=f"{name}: {len(beads)} lattice beads", fmt="%.1f")
    nml = WORK / f"{name}_L{order}.nml"
    nml.write_text(f"&run output = '{name}_L{order}.h5' /\n&shape name = 'bead_file', file = '{name}.txt' /\n"
                   f"&hydrodynamics multipole_order = {order} /\n")
    return nml


def timed_job(exe, nml, operator, cwd, result, read, options=()):
    """One job with `-operator operator` (and further command-line options) on RANKS ranks: (whole
    process in seconds, read(the result file's /hydrodynamics group)). The result file is removed
    first, so a stale one is never read."""
    result.unlink(missing_ok=True)
    start = time.perf_counter()
    subprocess.run(["mpiexec", "-n", str(RANKS), exe, str(nml), "-operator", operator, *options, "-quiet"], cwd=cwd,
                   env=ENV, check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - start
    with h5py.File(result) as f:
        return wall, read(f["hydrodynamics"])


def run(exe, nml, operator):
    """(whole process, friction job, the job's estimated seconds, beads in the solve, solves)."""
    wall, values = timed_job(exe, nml, operator, WORK, nml.with_suffix(".h5"), lambda h: (
        float(h.attrs["phase_seconds"][-1]), float(h.attrs["estimated_seconds"]), int(h.attrs["hydrodynamic_beads"]),
        int(h.attrs["planned_solves"])))
    return (wall,) + values


def auto_pick(exe, nml):
    out = subprocess.run(["mpiexec", "-n", str(RANKS), exe, str(nml), "-estimate"], cwd=WORK, env=ENV, check=True,
                         capture_output=True, text=True).stdout
    return re.search(r"operator:\s+(\w+)", out).group(1)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--exe", default=str(ROOT / "build" / "beadmob"))
    parser.add_argument("--before", help="another build whose `auto` pick is shown beside this one's")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--orders", default="1,2,3")
    args = parser.parse_args()
    WORK.mkdir(exist_ok=True)
    started = time.perf_counter()
    models = [(f"random_{n}", eden_body(n)) for n in (20, 50, 100, 200, 400, 1000)]
    models += [(f"ball_r{r}", ball(r)) for r in (2, 3, 4, 6)]
    rows, costly, costly_before = [], [], []
    for order in [int(s) for s in args.orders.split(",")]:
        for name, beads in models:
            nml = write_input(name, beads, order)
            runs = {"direct": [], "fft": []}
            for _ in range(args.repeats):
                for op in runs:
                    runs[op].append(run(args.exe, nml, op))
            job = {op: statistics.median(r[1] for r in runs[op]) for op in runs}
            wall = {op: statistics.median(r[0] for r in runs[op]) for op in runs}
            estimate = {op: runs[op][-1][2] for op in runs}
            solve_beads, solves = runs["fft"][-1][3], runs["fft"][-1][4]
            faster = min(job, key=job.get)
            picks = auto_pick(args.exe, nml)
            before = auto_pick(args.before, nml) if args.before else None
            # The price of the pick: its job time over the faster one's (1.00 when it is the faster).
            price = job[picks] / job[faster]
            costly.append((price, name, order))
            if args.before:
                costly_before.append((job[before] / job[faster], name, order))
            row = (f"| {name} | {len(beads)} | {solve_beads} | {solves} | {order} | {job['direct']:.3f} | "
                   f"{job['fft']:.3f} | {job['direct'] / job['fft']:.2f} | {wall['direct']:.2f} | {wall['fft']:.2f} | "
                   f"{estimate['direct']:.3f} | {estimate['fft']:.3f} | {picks} | {price:.2f} |")
            if args.before:
                row += f" {before} | {job[before] / job[faster]:.2f} |"
            rows.append(row)
            print(row, flush=True)
    header = ("| model | beads | in the solve | solves | L | direct job (s) | fft job (s) | direct / fft | direct whole (s) "
              "| fft whole (s) | direct estimate (s) | fft estimate (s) | auto picks | its job / the faster's |")
    rule = "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
    if args.before:
        header += " before: auto picked | its job / the faster's |"
        rule += "---|---|"

    def verdict(prices, who):
        worst = max(prices)
        return (f"{who}: {sum(p > 1.10 for p, _, _ in prices)} of {len(prices)} picks more than 10 % slower than the "
                f"faster operator; the dearest {worst[0]:.2f}x ({worst[1]}, L = {worst[2]}).")

    lines = ["# Lattice models: the direct operator against the FFT operator, and the pick of `auto`", "",
             f"Generated by `python3 bench/operator_check/lattice_crossover.py --repeats {args.repeats}"
             + (" --before OLD" if args.before else "") + f"` on the development machine ({platform.machine()}, "
             f"{os.cpu_count()} cores), {RANKS} MPI ranks. Models: random compact lattice bodies (Eden growth, "
             "tests/e2e/eden_body.py; no symmetry) and lattice balls (all mirrors), default settings (shell model, "
             "the error bar's companion from L = 2) at each order L. Job: the friction job's own time (phase "
             "`total`), whole: `mpiexec` to exit; medians of the repetitions, each running both operators in turn. "
             "Estimate: the dry run's expected wall time of the job with that operator (`estimated_seconds`, "
             "src/solvers/job_estimate.f90), which `-operator auto` compares (src/solvers/job_plan.f90, "
             "choose_operator). Last column(s): the job time of the operator `auto` picks over the faster one's; "
             "with --before, the other build's pick (its own dry run) priced by this build's runs of that operator.",
             "", header, rule] + rows
    lines += ["", verdict(costly, "This build")] + (["", verdict(costly_before, "Before")] if args.before else [])
    lines += ["", f"Whole script: {(time.perf_counter() - started) / 60:.1f} min.", ""]
    (HERE / "lattice_crossover.md").write_text("\n".join(lines))
    print("wrote bench/operator_check/lattice_crossover.md")


if __name__ == "__main__":
    main()
