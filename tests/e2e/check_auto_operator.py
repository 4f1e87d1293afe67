#!/usr/bin/env python3
"""check_auto_operator.py BEADMOB MPIEXEC RANKS WORKDIR: `-operator auto` on an off-lattice model
picks the operator whose estimated wall time (the dry run's cost model, `-estimate`) is the
smaller of the direct and the pfft operator's (job_plan.f90, choose_operator), and the dry run
names it. Models: balls of lattice points scaled by 1.1 and jittered by up to 0.04 d (seed 7) of
123 beads (the direct operator, measured faster at 100: bench/offlattice/pfft_crossover.md) and 1419
beads (pfft, measured 4-7x faster at 1000-1500 beads there); only dry runs, nothing is solved."""
import os
import re
import subprocess
import sys

import numpy as np

beadmob, mpiexec, ranks, workdir = sys.argv[1:5]
os.makedirs(workdir, exist_ok=True)


def ball(radius):
    r = np.arange(-radius, radius + 1)
    points = np.array([(x, y, z) for x in r for y in r for z in r if x * x + y * y + z * z <= radius * radius], float)
    return 1.1 * points + np.random.default_rng(7).uniform(-0.04, 0.04, points.shape)


def estimate(nml, operator):
    out = subprocess.run([mpiexec, "-n", ranks, beadmob, nml, "-estimate", "-operator", operator], cwd=workdir,
                         check=True, capture_output=True, text=True).stdout
    name = re.search(r"operator:\s+(\w+)", out).group(1)
    value, unit = re.search(r"expected wall time:\s+([0-9.]+) (s|min)", out).groups()
    return name, float(value) * (60 if unit == "min" else 1)


ok = True
for radius, expected in ((3, "direct"), (7, "pfft")):
    points = ball(radius)
    beads = os.path.join(workdir, f"ball_{len(points)}.txt")
    np.savetxt(beads, points)
    nml = os.path.join(workdir, f"ball_{len(points)}.nml")
    with open(nml, "w") as f:
        f.write(f"&run output = 'ball.h5' /\n&shape name = 'bead_file', file = '{os.path.basename(beads)}' /\n"
                "&hydrodynamics /\n")
    chosen, _ = estimate(nml, "auto")
    seconds = {op: estimate(nml, op)[1] for op in ("direct", "pfft")}
    cheaper = min(seconds, key=seconds.get)
    print(f"{len(points)} beads: auto picks {chosen}; estimates direct {seconds['direct']} s, pfft {seconds['pfft']} s")
    ok = ok and chosen == cheaper == expected
sys.exit(0 if ok else 1)
