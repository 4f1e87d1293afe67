#!/usr/bin/env python3
"""ellipsoids.py [--exe BUILD/beadmob] [--sizes 3,4,5]: lattice ellipsoids against the exact
ellipsoid (which continuum body a bead model stands for; docs/input.md, "Physical units").

Bodies: a sphere, prolate 2:1 and 4:1, oblate 1:2 and 1:4, and a triaxial 3:2:1
ellipsoid, each with smallest semi-axis s (in bead diameters d) for every s of --sizes, built by
beadmob's `spheroid` shape (the lattice points inside the ellipsoid with those semi-axes), run with
the default settings on 2 ranks. Each run's translational and rotational friction (the diagonal of
the 6x6 friction about the centre, in the frame of the semi-axes, viscosity 1) is compared with
the exact friction (scripts/beadmob_post/ellipsoid.py) of two candidate continuum bodies:

- `centres`: the ellipsoid whose surface the bead centres fill (the same semi-axes);
- `surface`: the ellipsoid grown by the bead radius (semi-axes + d/2), the beads' outer surface.

Deviation = largest |beadmob / exact - 1| over the three axes. The run's own error bar is
`estimated_error` of the result file (the mobility's error, on the scale sqrt(M_ii M_jj), against
the exact mobility of the bead model, docs/accuracy.md)."""
import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "scripts"))
from beadmob_post.ellipsoid import ellipsoid_friction  # noqa: E402

RANKS = 2
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
BODIES = [("sphere", (1, 1, 1)), ("prolate 2:1", (2, 1, 1)), ("prolate 4:1", (4, 1, 1)),
          ("oblate 1:2", (1, 2, 2)), ("oblate 1:4", (1, 4, 4)), ("triaxial 3:2:1", (3, 2, 1))]


def run(exe, semi_axes, workdir):
    nml = Path(workdir) / "body.nml"
    nml.write_text("&run output = 'body.h5' /\n&shape name = 'spheroid', semi_axes = "
                   + ", ".join(f"{a:g}" for a in semi_axes) + " /\n&hydrodynamics /\n")
    start = time.perf_counter()
    subprocess.run(["mpiexec", "-n", str(RANKS), exe, str(nml), "-quiet"], cwd=workdir, env=ENV, check=True,
                   stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - start
    with h5py.File(Path(workdir) / "body.h5") as f:
        h = f["hydrodynamics"]
        friction = h["friction"][()]
        error = float(h.attrs["estimated_error"])
        beads = int(f["geometry"]["positions"].shape[0])
    return np.diag(friction), error, beads, wall


def deviations(diagonal, semi_axes):
    exact = np.diag(ellipsoid_friction(semi_axes))
    relative = np.abs(diagonal / exact - 1)
    return float(relative[:3].max()), float(relative[3:].max())


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--exe", default=str(ROOT / "build" / "beadmob"))
    parser.add_argument("--sizes", default="3,4,5")
    parser.add_argument("--out", default=str(Path(__file__).with_name("ellipsoids.md")))
    args = parser.parse_args()
    sizes = [float(s) for s in args.sizes.split(",")]
    rows = []
    with tempfile.TemporaryDirectory() as work:
        for name, ratio in BODIES:
            for s in sizes:
                semi_axes = np.array(ratio, dtype=float) * s
                diagonal, error, beads, wall = run(os.path.abspath(args.exe), semi_axes, work)
                centres = deviations(diagonal, semi_axes)
                surface = deviations(diagonal, semi_axes + 0.5)
                rows.append((name, s, beads, centres, surface, error, wall))
                print(rows[-1], flush=True)
    lines = ["# Lattice ellipsoids against the exact ellipsoid", "",
             f"Written by `bench/ellipsoids/ellipsoids.py --sizes {args.sizes}` ({RANKS} ranks, default settings: "
             "L = 2, one surface layer, error bar on). Deviation: largest |beadmob / exact - 1| over the three "
             "axes, translation (t) and rotation (r); `centres`: the exact ellipsoid with the semi-axes the "
             "bead centres fill; `surface`: semi-axes + d/2. Error bar: the run's `estimated_error` (against "
             "the exact mobility of its bead model).", "",
             "| body | s (d) | beads | centres t | centres r | surface t | surface r | run's error bar | run (s) |",
             "|---|---|---|---|---|---|---|---|---|"]
    for name, s, beads, centres, surface, error, wall in rows:
        lines.append(f"| {name} | {s:g} | {beads} | {100 * centres[0]:.2f} % | {100 * centres[1]:.2f} % | "
                     f"{100 * surface[0]:.2f} % | {100 * surface[1]:.2f} % | {100 * error:.2f} % | {wall:.1f} |")
    worst = {key: max(r[3][i] if key.startswith("c") else r[4][i] for r in rows)
             for i, key in ((0, "ct"), (1, "cr"), (0, "st"), (1, "sr"))}
    lines += ["", f"Largest deviation over all rows: centres {100 * worst['ct']:.2f} % (translation), "
              f"{100 * worst['cr']:.2f} % (rotation); surface {100 * worst['st']:.2f} %, {100 * worst['sr']:.2f} %."]
    Path(args.out).write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
