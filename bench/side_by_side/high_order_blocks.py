#!/usr/bin/env python3
"""Two builds side by side on lattice jobs at high multipole order, where a block of nb x nb
(120 x 120 at L = 6) makes the lattice set-up's dense products count: writes
bench/side_by_side/high_order_blocks.md.

Random compact lattice bodies (Eden growth, tests/e2e/eden_body.py) at L = 4 and 6, each job
with `-operator fft` and `-operator direct`, the two builds alternated, medians of --repeats
runs on 2 ranks: the friction job's own time (phase `total`), its blocks phase and the whole
process; and whether the two builds' friction agrees within what the solver promises
(tests/e2e/solver_promise.py).

usage: python3 bench/side_by_side/high_order_blocks.py --before OLD_EXE [--exe build/beadmob] [--repeats 5]
"""
import argparse
import os
import statistics
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "e2e"))
sys.path.insert(0, str(ROOT / "bench" / "operator_check"))
from eden_body import eden_body  # noqa: E402
import solver_promise  # noqa: E402
from lattice_crossover import RANKS, timed_job  # noqa: E402  (the same launch)

PHASES = ["blocks", "near_field", "solve", "companion", "lubrication", "total"]


def run(exe, nml, operator, work):
    """(whole process, job, blocks phase, friction, solver bound) of one run."""
    wall, values = timed_job(exe, nml, operator, work, work / "result.h5", lambda h: (
        float(h.attrs["phase_seconds"][-1]), float(h.attrs["phase_seconds"][PHASES.index("blocks")]),
        h["multipole_friction"][()], solver_promise.bound(h)))
    return (wall,) + values


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--exe", default=str(ROOT / "build" / "beadmob"))
    parser.add_argument("--before", required=True)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--title", default="")
    args = parser.parse_args()
    builds = [("this", os.path.abspath(args.exe)), ("before", os.path.abspath(args.before))]
    rows = []
    with tempfile.TemporaryDirectory() as work:
        work = Path(work)
        for n, order in ((100, 4), (400, 4), (100, 6)):
            np.savetxt(work / "beads.txt", eden_body(n), fmt="%.1f")
            nml = work / "job.nml"
            nml.write_text("&run output = 'result.h5' /\n&shape name = 'bead_file', file = 'beads.txt' /\n"
                           f"&hydrodynamics multipole_order = {order} /\n")
            for operator in ("fft", "direct"):
                runs = {key: [] for key, _ in builds}
                for _ in range(args.repeats):
                    for key, exe in builds:
                        runs[key].append(run(exe, nml, operator, work))
                med = {key: [statistics.median(r[i] for r in runs[key]) for i in range(3)] for key, _ in builds}
                this, before = runs["this"][-1], runs["before"][-1]
                allowed = solver_promise.allowed_difference([this[4], before[4]], this[3])
                agree = float(np.nanmax(np.abs(this[3] - before[3]) / allowed))
                rows.append(f"| random {n} | {order} | {operator} | {med['this'][1]:.2f} | {med['before'][1]:.2f} | "
                            f"{med['before'][1] / med['this'][1]:.2f} | {med['this'][2]:.2f} | {med['before'][2]:.2f} | "
                            f"{med['this'][0]:.2f} | {med['before'][0]:.2f} | {agree:.2f} |")
                print(rows[-1], flush=True)
    lines = [f"# High-order lattice jobs side by side{': ' + args.title if args.title else ''}", "",
             f"Written by `bench/side_by_side/high_order_blocks.py`: {RANKS} ranks, medians of {args.repeats} runs, "
             "the two builds alternated; random compact lattice bodies (Eden growth, seed 1). Job: the friction "
             "job's own time (phase `total`); blocks: its blocks phase (block table, kernel or expanded table); "
             "whole: `mpiexec` to exit. Agreement: the largest |friction (this) - friction (before)| over the sum "
             "of the two runs' solver bounds (tests/e2e/solver_promise.py), last runs; at most 1 is within what "
             "the solver promises.", "",
             "| body | L | operator | job, this (s) | job, before (s) | before / this | blocks, this (s) | "
             "blocks, before (s) | whole, this (s) | whole, before (s) | friction difference / allowed |",
             "|---|---|---|---|---|---|---|---|---|---|---|"] + rows
    (Path(__file__).with_name("high_order_blocks.md")).write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
