#!/usr/bin/env python3
"""check_motions.py PART.h5 FULL.h5: a run that computed only U_x (&hydrodynamics motions) against
one that computed all six, both at -ksp_rtol 1e-10. Only U_x is solved; the friction entries in
its row and column (11 of 36) equal the full run's within the files' solver error bounds b
(docs/theory.md T5) on the scale sqrt(zeta_mm zeta_nn): b for the variational entries, sqrt(b)
for the first-order Galerkin products c_m . q_x of the partial run (|c_m . e_x| <= |c_m| |e_x| in
the energy norms); every other entry and the mobility are NaN, not invented."""
import sys

import h5py
import numpy as np

from solver_promise import bound, entry_scale

with h5py.File(sys.argv[1]) as a, h5py.File(sys.argv[2]) as b:
    ga, gb = a["hydrodynamics"], b["hydrodynamics"]
    failures = []
    if list(ga.attrs["solve_source"]) != [0, -1, -1, -1, -1, -1]:
        failures.append(f"solve_source {list(ga.attrs['solve_source'])}")
    if list(ga.attrs["solve_iterations"][1:]) != [0] * 5 or ga.attrs["solve_iterations"][0] <= 0:
        failures.append(f"iterations {list(ga.attrs['solve_iterations'])}")
    if int(ga.attrs["all_converged"]) != 1:
        failures.append("all_converged is not 1")
    for key in ("multipole_friction", "friction"):
        x, y = ga[key][()], gb[key][()]
        known = np.isfinite(x)
        expected = np.zeros((6, 6), bool)
        expected[0, :] = expected[:, 0] = True
        if not np.array_equal(known, expected):
            failures.append(f"{key}: known entries\n{known.astype(int)}")
            continue
        part_bound, full_bound = bound(ga), bound(gb)
        scale = entry_scale(gb["multipole_friction"][()])
        allowed = (np.sqrt(part_bound) + full_bound) * scale
        allowed[0, 0] = (part_bound + full_bound) * scale[0, 0]
        ratio = (np.abs(x - y)[known] / allowed[known]).max()
        print(f"{key}: largest difference of the known entries {np.abs(x - y)[known].max():.1e}, "
              f"{ratio:.2f} of the solver bounds")
        if not ratio <= 1:
            failures.append(f"{key} differs beyond the solver bounds ({ratio:.2f} of them)")
    if np.isfinite(ga["mobility"][()]).any() or np.isfinite(ga["coefficients"][()]).any():
        failures.append("a mobility was reported from a partial friction")
for failure in failures:
    print("FAILED:", failure)
sys.exit(1 if failures else 0)
