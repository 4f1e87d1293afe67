#!/usr/bin/env python3
"""check_plan.py BEADMOB MPIEXEC RANKS WORKDIR INPUT...: the dry run and the job follow one plan
(src/solvers/job_plan.f90).

For each input: `beadmob --estimate INPUT` prints the plan (beads in the solve, operator, solves
after symmetries, memory per rank, wall time); the job itself, on the same ranks, records the
plan it ran in its result file (hydrodynamic_beads, operator, planned_solves,
estimated_peak_memory_bytes, estimated_seconds) and what it did (solve_source: 0 = solved).
Passes when the two agree on every item (memory and time to the printed digits) and the job
solved exactly the planned number of motions.
"""
import os
import re
import shutil
import subprocess
import sys

import h5py
import numpy as np
from checklist import check, failures

beadmob, mpiexec, ranks, workdir = sys.argv[1:5]
inputs = sys.argv[5:]
GIB = 2.0 ** 30


def seconds(text):
    value, unit = text.split()
    return float(value) * {"s": 1.0, "min": 60.0, "h": 3600.0}[unit]


for input_path in inputs:
    name = os.path.splitext(os.path.basename(input_path))[0]
    here = os.path.join(workdir, name)
    shutil.rmtree(here, ignore_errors=True)
    os.makedirs(here)
    dry = subprocess.run([mpiexec, "-n", ranks, beadmob, "--estimate", input_path], cwd=here,
                         capture_output=True, text=True, timeout=600)
    print(dry.stdout + dry.stderr)
    check(dry.returncode == 0, f"{name}: the dry run succeeds")
    beads = re.search(r"beads: +(\d+) \((\d+) in the solve\)", dry.stdout)
    operator = re.search(r"operator: +(\w+)", dry.stdout)
    memory = re.search(r"memory per rank: +([0-9.]+) GiB", dry.stdout)
    wall = re.search(r"expected wall time: +([0-9.eE+]+ (?:s|min|h)) .*: (\d+) solve\(s\)", dry.stdout)
    if not (beads and operator and memory and wall):
        check(False, f"{name}: the dry run prints beads, operator, memory and wall time")
        continue
    job = subprocess.run([mpiexec, "-n", ranks, beadmob, input_path], cwd=here, capture_output=True, text=True,
                         timeout=600)
    check(job.returncode == 0, f"{name}: the job succeeds")
    outputs = [f for f in os.listdir(here) if f.endswith(".h5")]
    if job.returncode != 0 or len(outputs) != 1:
        print(job.stdout + job.stderr)
        check(False, f"{name}: one result file")
        continue
    with h5py.File(os.path.join(here, outputs[0]), "r") as f:
        g = f["hydrodynamics"].attrs
        solved = int(np.count_nonzero(np.asarray(g["solve_source"]) == 0))
        check(int(g["hydrodynamic_beads"]) == int(beads.group(2)),
              f"{name}: beads in the solve {g['hydrodynamic_beads']} = dry run's {beads.group(2)}")
        used = g["operator"].decode() if isinstance(g["operator"], bytes) else str(g["operator"])
        check(used == operator.group(1), f"{name}: operator {used} = dry run's {operator.group(1)}")
        check(int(g["planned_solves"]) == int(wall.group(2)),
              f"{name}: planned solves {g['planned_solves']} = dry run's {wall.group(2)}")
        check(solved == int(g["planned_solves"]), f"{name}: the job solved {solved} motions, as planned")
        printed = float(memory.group(1))
        check(abs(float(g["estimated_peak_memory_bytes"]) / GIB - printed) <= 0.005 + 1e-12,
              f"{name}: estimated memory {float(g['estimated_peak_memory_bytes']) / GIB:.4f} GiB, dry run {printed}")
        printed_seconds = seconds(wall.group(1))
        recorded = float(g["estimated_seconds"])
        unit = 1.0 if recorded < 120 else 60.0 if recorded < 7200 else 3600.0
        check(abs(recorded - printed_seconds) <= 0.05 * unit + 1e-12,
              f"{name}: estimated wall time {recorded:.3f} s, dry run {wall.group(1)}")

print("PASS" if not failures else f"{len(failures)} failures")
sys.exit(1 if failures else 0)
