#!/usr/bin/env python3
"""check_bead_forces.py FILE: the per-bead forces and torques of a beadmob result file add up to
the order-L friction: for each rigid motion m, sum_i F_i = friction[0:3, m] and
sum_i (T_i + (R_i - R_0) x F_i) = friction[3:6, m] about the centre of mass R_0 (the definition
of the body friction, theory.md T5). The per-bead values come from the plain Krylov solutions and
the friction from the variational estimate, so they agree to the solver tolerance (the CTest
runs use -ksp_rtol 1e-9)."""
import sys

import h5py
import numpy as np

with h5py.File(sys.argv[1]) as f:
    forces = f["hydrodynamics/bead_forces"][()].reshape(-1, 6, 6)   # bead, motion, (F, T)
    friction = f["hydrodynamics/multipole_friction"][()]
    positions = f["geometry/positions"][()]
    centre = f["geometry/centre_of_mass"][()]
arms = positions - centre
total = np.zeros((6, 6))
for m in range(6):
    F, T = forces[:, m, 0:3], forces[:, m, 3:6]
    total[0:3, m] = F.sum(axis=0)
    total[3:6, m] = (T + np.cross(arms, F)).sum(axis=0)
error = np.abs(total - friction).max() / np.abs(friction).max()
print(f"bead forces vs friction: largest relative difference {error:.2e} ({len(forces)} beads)")
sys.exit(0 if error < 1e-6 else 1)
