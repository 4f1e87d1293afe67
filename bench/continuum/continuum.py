#!/usr/bin/env python3
"""continuum.py [--exe BUILD/beadmob] [--budget S] [--ellipsoids] [--paper] [--out FILE]: the
continuum job (&continuum, docs/theory.md T18) against exact results, on 2 ranks.

--ellipsoids: six ellipsoids (sphere, prolate 2:1 and 4:1, oblate 1:2 and 1:4, triaxial
  3:2:1), smallest semi-axis 1 in their own unit, bead_diameter 1/8 (the ordinary run), each a
  continuum job with time_budget S (default settings otherwise: 7 levels x 2 offsets and 6 control samples since
  2026-11-28, 4 offsets before). Compared
  with the exact ellipsoid (scripts/beadmob_post/ellipsoid.py: Oberbeck, Jeffery via Carlson's
  integrals) on the six diagonal entries of the mobility (principal frame = input axes):
  deviation = largest |continuum / exact - 1| over translation (t) and rotation (r); the job's
  own error bar on the same scale; `held` = every one of the six exact values lies within the
  job's error bar. Beside it, one ordinary default run at bead_diameter 1/8 (no &continuum).

--paper: the paper's seven particles with their lengths in d of the paper's models
  (shapes/*.nml, bead_diameter = 1, reference_length = the paper's L/d), each a continuum job
  with time_budget S; the continuum coefficients with their error bars beside the paper's
  bead-model table (Table tab_mob_num) and beadmob's ordinary run of shapes/<name>.nml.

Each table's wall times are this machine's (2 ranks); `estimated` is the job's own estimate of
its ladder (the dry run's, calibrated by its pilot solve); `moved` (paper particles): the levels
the ladder moved coarser once its solved levels showed the rest would overrun the budget."""
import argparse
import re
import sys
import tempfile
from pathlib import Path

import h5py
import numpy as np

from continuum_jobs import ROOT, run, spheroid

sys.path.insert(0, str(ROOT / "scripts"))
from beadmob_post.ellipsoid import ellipsoid_friction  # noqa: E402
from beadmob_post.paper import TAB_MOB_NUM  # noqa: E402

BODIES = [("sphere", (1, 1, 1)), ("prolate 2:1", (2, 1, 1)), ("prolate 4:1", (4, 1, 1)),
          ("oblate 1:2", (1, 2, 2)), ("oblate 1:4", (1, 4, 4)), ("triaxial 3:2:1", (3, 2, 1))]


def ellipsoid_rows(exe, budget, workdir):
    rows = []
    for name, semi_axes in BODIES:
        exact = np.diag(np.linalg.inv(ellipsoid_friction(semi_axes)))
        result, wall = run(exe, spheroid(semi_axes) + f"&continuum time_budget = {budget:g} /\n", workdir)
        with h5py.File(result) as f:
            c = f["continuum"]
            mobility, error = np.diag(c["mobility"][()]), np.diag(c["mobility_error"][()])
            estimated, diameters = float(c.attrs["estimated_seconds"]), c["bead_diameters"][()]
            beads = int(max(c.attrs["sample_beads"]))
        single, single_wall = run(exe, spheroid(semi_axes), workdir)
        with h5py.File(single) as f:
            # d units to the body's: M_tt / d, M_rr / d^3
            single_mobility = np.diag(f["hydrodynamics"]["mobility"][()]) / np.array([0.125] * 3 + [0.125**3] * 3)
        deviation = np.abs(mobility / exact - 1)
        bar = error / exact
        single_deviation = np.abs(single_mobility / exact - 1)
        rows.append(f"| {name} | {diameters[0]:.4f} - {diameters[-1]:.4f} | {beads} | {100 * deviation[:3].max():.3f} % | "
                    f"{100 * deviation[3:].max():.3f} % | {100 * bar[:3].max():.3f} % | {100 * bar[3:].max():.3f} % | "
                    f"{'yes' if np.all(np.abs(mobility - exact) <= error) else 'NO'} | {wall:.0f} | {estimated:.0f} | "
                    f"{100 * single_deviation[:3].max():.2f} % | {100 * single_deviation[3:].max():.2f} % |")
        print(rows[-1], flush=True)
    header = ("| body | bead diameters | finest beads | continuum t | continuum r | error bar t | error bar r | "
              "held | wall (s) | estimated (s) | ordinary run t | ordinary run r |\n"
              "|---|---|---|---|---|---|---|---|---|---|---|---|")
    return header + "\n" + "\n".join(rows)


def paper_shape_group(name, reference_length):
    """The &shape group of shapes/<name>.nml with bead_diameter = 1 and the paper's L/d."""
    text = (ROOT / "shapes" / f"{name}.nml").read_text()
    group = re.search(r"&shape(.*?)\n/", text, re.S).group(1)
    group = "\n".join(line.split("!")[0] for line in group.splitlines())
    return f"&shape{group}\n  bead_diameter = 1.0\n  reference_length = {reference_length:g}\n/\n"


def paper_rows(exe, budget, workdir):
    rows = []
    for row in TAB_MOB_NUM:
        shape = paper_shape_group(row.shape, row.length_over_d)
        result, wall = run(exe, shape + "&hydrodynamics /\n" + f"&continuum time_budget = {budget:g} /\n", workdir)
        with h5py.File(result) as f:
            c = f["continuum"]
            values, errors = c["coefficients"][()], c["coefficient_error"][()]
            diameters, estimated = c["bead_diameters"][()], float(c.attrs["estimated_seconds"])
            beads = int(max(c.attrs["sample_beads"]))
            moved = int(c.attrs.get("ladder_moved_coarser", 0))
        ordinary, _ = run(exe, (ROOT / "shapes" / f"{row.shape}.nml").read_text().replace(
            f"output = '{row.shape}.h5'", "output = 'job.h5'"), workdir)
        with h5py.File(ordinary) as f:
            ours = f["hydrodynamics"]["coefficients"][()]
        cells = " | ".join(f"{v:.3f} +- {e:.3f}" for v, e in zip(values, errors))
        rows.append(f"| {row.label} | {row.length_over_d:g} | {diameters[0]:.3f} - {diameters[-1]:.3f} | {beads} | {cells} | "
                    + " ".join(f"{v:.3f}" for v in row.coefficients()) + " | " + " ".join(f"{v:.3f}" for v in ours)
                    + f" | {wall:.0f} | {estimated:.0f} | {moved} |")
        print(rows[-1], flush=True)
    header = ("| particle | L/d | bead diameters (paper d) | finest beads | mu11 | mu22 | mu33 | mu42 | mu51 | "
              "paper's table (bead model) | ordinary beadmob run | wall (s) | estimated (s) | moved |\n"
              "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    return header + "\n" + "\n".join(rows)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--exe", default=str(ROOT / "build" / "beadmob"))
    parser.add_argument("--budget", type=float, default=240.0)
    parser.add_argument("--ellipsoids", action="store_true")
    parser.add_argument("--paper", action="store_true")
    parser.add_argument("--out", default=None)
    arguments = parser.parse_args()
    with tempfile.TemporaryDirectory() as workdir:
        if arguments.ellipsoids:
            table = ellipsoid_rows(arguments.exe, arguments.budget, workdir)
            title = "# Continuum jobs on ellipsoids against the exact ellipsoid"
            command = f"bench/continuum/continuum.py --ellipsoids --budget {arguments.budget:g}"
        else:
            table = paper_rows(arguments.exe, arguments.budget, workdir)
            title = "# Continuum jobs on the paper's seven particles"
            command = f"bench/continuum/continuum.py --paper --budget {arguments.budget:g}"
    paragraphs = __doc__.split("\n\n")
    text = (f"{title}\n\nWritten by `{command}` (2 ranks, this machine).\n\n"
            f"{paragraphs[1 if arguments.ellipsoids else 2]}\n\n{paragraphs[3]}\n\n{table}\n")
    out = Path(arguments.out or Path(__file__).with_name("continuum.md" if arguments.ellipsoids else "paper_particles.md"))
    out.write_text(text)
    print(f"written {out}")


if __name__ == "__main__":
    main()
