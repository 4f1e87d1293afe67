#!/usr/bin/env python3
"""check_shell_model.py SHELL.h5 FULL.h5: the shell model (surface layer only) of a filled sphere
against the full bead model. The rigid-body friction is carried by the surface traction, so the
two must agree closely; the bound, 1 % on the translational and rotational friction, is well
above what bench/accuracy/accuracy.md measures for one layer and far below the change from dropping a
surface layer instead (a sphere of radius 3 instead of 4: ~20 % in friction, Stokes' law ~ radius).
Also: the shell run solved for fewer beads and records its layer count."""
import sys

import h5py
import numpy as np

with h5py.File(sys.argv[1]) as shell, h5py.File(sys.argv[2]) as full:
    s, f = shell["hydrodynamics"], full["hydrodynamics"]
    n_shell, n_full = int(s.attrs["hydrodynamic_beads"]), int(f.attrs["hydrodynamic_beads"])
    assert int(s.attrs["shell_layers"]) == 1 and int(f.attrs["shell_layers"]) == 0
    assert n_full == int(full["geometry"].attrs["n_beads"]) and n_shell < n_full, (n_shell, n_full)
    zs, zf = s["multipole_friction"][()], f["multipole_friction"][()]
    tt = abs(np.trace(zs[:3, :3]) / np.trace(zf[:3, :3]) - 1)
    rr = abs(np.trace(zs[3:, 3:]) / np.trace(zf[3:, 3:]) - 1)
    print(f"shell {n_shell} of {n_full} beads: translational friction differs by {tt:.2e}, rotational {rr:.2e}")
    sys.exit(0 if tt < 0.01 and rr < 0.01 else 1)
