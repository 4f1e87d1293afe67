#!/usr/bin/env python3
"""check_auto_operator.py BEADMOB MPIEXEC RANKS WORKDIR [offlattice|lattice]: `-operator auto` picks
the operator whose estimated wall time (the dry run's cost model, `-estimate`) is the smaller
(job_plan.f90, choose_operator), and the dry run names it; only dry runs, nothing is solved.

offlattice (default): the direct operator against the pfft. Balls of lattice points scaled by 1.1
and jittered by up to 0.04 d (seed 7) of 123 beads (the direct operator, measured faster at 100:
bench/offlattice/pfft_crossover.md) and 1419 beads (pfft, measured 4-7x faster at 1000-1500 beads
there).

lattice: the direct operator against the FFT operator, cases measured side by side in
bench/operator_check/lattice_crossover.md: a random compact 50-bead body at L = 1 (direct, 1.30x
faster there), lattice balls of radius 6 at L = 1 (925 beads: the FFT operator 2.85x faster) and of
radius 4 at L = 2 (257 beads: 1.73x), both of which the earlier work rule gave to the direct operator."""
import os
import re
import subprocess
import sys

import numpy as np

beadmob, mpiexec, ranks, workdir = sys.argv[1:5]
mode = sys.argv[5] if len(sys.argv) > 5 else "offlattice"
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from eden_body import eden_body  # noqa: E402
os.makedirs(workdir, exist_ok=True)


def ball(radius):
    r = np.arange(-radius, radius + 1)
    return np.array([(x, y, z) for x in r for y in r for z in r if x * x + y * y + z * z <= radius * radius], float)


def jittered_ball(radius):
    points = ball(radius)
    return 1.1 * points + np.random.default_rng(7).uniform(-0.04, 0.04, points.shape)


def estimate(nml, operator):
    out = subprocess.run([mpiexec, "-n", ranks, beadmob, nml, "-estimate", "-operator", operator], cwd=workdir,
                         check=True, capture_output=True, text=True).stdout
    name = re.search(r"operator:\s+(\w+)", out).group(1)
    value, unit = re.search(r"expected wall time:\s+([0-9.]+) (s|min)", out).groups()
    return name, float(value) * (60 if unit == "min" else 1)


if mode == "lattice":
    cases = [(eden_body(50), 1, ("direct", "fft"), "direct"), (ball(6), 1, ("direct", "fft"), "fft"),
             (ball(4), 2, ("direct", "fft"), "fft")]
else:
    cases = [(jittered_ball(3), 2, ("direct", "pfft"), "direct"), (jittered_ball(7), 2, ("direct", "pfft"), "pfft")]
ok = True
for points, order, operators, expected in cases:
    name = f"{mode}_{len(points)}_L{order}"
    beads = os.path.join(workdir, f"{name}.txt")
    np.savetxt(beads, points)
    nml = os.path.join(workdir, f"{name}.nml")
    with open(nml, "w") as f:
        f.write(f"&run output = 'ball.h5' /\n&shape name = 'bead_file', file = '{os.path.basename(beads)}' /\n"
                f"&hydrodynamics multipole_order = {order} /\n")
    chosen, _ = estimate(nml, "auto")
    seconds = {op: estimate(nml, op)[1] for op in operators}
    cheaper = min(seconds, key=seconds.get)
    print(f"{len(points)} beads, L = {order}: auto picks {chosen}; estimates "
          + ", ".join(f"{op} {seconds[op]} s" for op in operators) + f"; expected {expected}")
    # The printed estimates are rounded: where they tie, the pick must still be the expected one.
    ok = ok and chosen == expected and (cheaper == expected or seconds[cheaper] == seconds[expected])
sys.exit(0 if ok else 1)
