#!/usr/bin/env python3
"""check_symmetry.py WITH.h5 WITHOUT.h5 SOURCES GROUP_ORDER: motions derived by symmetries of the
bead set (motion_symmetry.F90) against solving all six. The expected orbits are independent of
the code: a filled sphere has the 48 lattice symmetries, its translations are one orbit and its
rotations another (SOURCES 0,1,1,0,4,4); a cone about z with a four-fold axis has 8 (x <-> y:
0,1,0,0,4,0). Both runs at -ksp_rtol 1e-10: the two frictions agree within the sum of the files'
solver error bounds (docs/theory.md T5: entry (m, n) within bound sqrt(zeta_mm zeta_nn) of the
exact solve's), every derived solution passes the true-residual check of a solved one."""
import sys

import h5py
import numpy as np

from solver_promise import allowed_difference, bound

with h5py.File(sys.argv[1]) as a, h5py.File(sys.argv[2]) as b:
    ga, gb = a["hydrodynamics"], b["hydrodynamics"]
    sources = [int(s) for s in sys.argv[3].split(",")]
    failures = []
    if list(ga.attrs["solve_source"]) != sources:
        failures.append(f"derived motions {list(ga.attrs['solve_source'])}, expected {sources}")
    if int(ga.attrs["symmetry_group_order"]) != int(sys.argv[4]):
        failures.append(f"group order {ga.attrs['symmetry_group_order']}, expected {sys.argv[4]}")
    if list(gb.attrs["solve_source"]) != [0] * 6 or int(gb.attrs["use_symmetry"]) != 0:
        failures.append("the run without symmetry derived motions")
    if not np.all(ga.attrs["solve_true_relative_residual"] < 1e-8):
        failures.append(f"true residuals {ga.attrs['solve_true_relative_residual']}")
    if np.any(ga.attrs["solve_iterations"][np.array(sources) > 0] != 0):
        failures.append("a derived motion was iterated")
    for key in [k for k in ("multipole_friction", "friction") if k in ga]:
        x, y = ga[key][()], gb[key][()]
        allowed = allowed_difference([bound(ga), bound(gb)], gb["multipole_friction"][()])
        ratio = (np.abs(x - y) / allowed).max()
        print(f"{key}: largest difference {np.abs(x - y).max():.1e}, {ratio:.2f} of the solver bounds")
        if not ratio <= 1:
            failures.append(f"{key} differs beyond the solver bounds ({ratio:.2f} of them)")
for failure in failures:
    print("FAILED:", failure)
sys.exit(1 if failures else 0)
