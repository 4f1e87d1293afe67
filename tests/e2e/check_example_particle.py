#!/usr/bin/env python3
"""check_example_particle.py BEADMOB MPIEXEC RANKS WORKDIR: the README's mesh example runs as
written (shapes/particle.nml, shapes/particle_continuum.nml, the mesh shapes/particle.stl made by
shapes/make_particle_mesh.py).

1. `beadmob -geometry_only shapes/particle.nml` fills the mesh (the file found beside the input)
   with N beads, N d^3 within 3 % of the polyhedron's volume computed here from its triangles
   (the divergence theorem; at d = 0.05 mm the lattice's count scatters by about a surface layer's
   fraction, well under that), and writes particle.h5 where it runs.
2. `beadmob --estimate shapes/particle_continuum.nml` prints a ladder of 7 levels, each with at
   least 100 beads, within the 600 s budget, and writes nothing.
3. `beadmob --estimate shapes/particle_flow.nml` (the particle in a flow) likewise."""
import re
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from checklist import check, failures  # noqa: E402

SHAPES = Path(__file__).resolve().parents[2] / "shapes"


def stl_volume(path):
    data = path.read_bytes()
    n = int(np.frombuffer(data[80:84], dtype="<u4")[0])
    record = np.frombuffer(data[84:84 + 50 * n], dtype=[("normal", "<f4", 3), ("corners", "<f4", (3, 3)),
                                                         ("attribute", "<u2")])
    t = record["corners"].astype(float)
    return np.einsum("ij,ij->i", t[:, 0], np.cross(t[:, 1], t[:, 2])).sum() / 6


def main(beadmob, mpiexec, ranks, workdir):
    workdir = Path(workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    (workdir / "particle.h5").unlink(missing_ok=True)
    done = subprocess.run([mpiexec, "-n", str(ranks), beadmob, "-geometry_only", str(SHAPES / "particle.nml")],
                          cwd=workdir, capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"the example particle failed:\n{done.stdout}\n{done.stderr}")
    with h5py.File(workdir / "particle.h5", "r") as f:
        beads = len(f["geometry"]["positions"])
    volume = stl_volume(SHAPES / "particle.stl")
    check(abs(beads * 0.05**3 / volume - 1) < 0.03,
          f"particle.nml: {beads} beads of 0.05 mm, {beads * 0.05**3:.4f} mm^3 against the mesh's {volume:.4f} mm^3")
    (workdir / "particle_continuum.h5").unlink(missing_ok=True)
    done = subprocess.run([mpiexec, "-n", str(ranks), beadmob, "--estimate", str(SHAPES / "particle_continuum.nml")],
                          cwd=workdir, capture_output=True, text=True)
    lines = done.stdout.splitlines()
    ladder = [i for i, line in enumerate(lines) if "continuum ladder of 7 levels" in line]
    counts = [int(x) for x in re.sub("^ *beads", "", lines[ladder[0] + 2]).split()] if ladder else []
    check(done.returncode == 0 and len(counts) == 7 and min(counts) >= 100
          and not (workdir / "particle_continuum.h5").exists(),
          f"particle_continuum.nml --estimate: a ladder of 7 levels of {counts} beads, nothing written")
    (workdir / "particle_flow.h5").unlink(missing_ok=True)
    done = subprocess.run([mpiexec, "-n", str(ranks), beadmob, "--estimate", str(SHAPES / "particle_flow.nml")],
                          cwd=workdir, capture_output=True, text=True)
    lines = done.stdout.splitlines()
    ladder = [i for i, line in enumerate(lines) if "continuum ladder of 7 levels" in line]
    check(done.returncode == 0 and bool(ladder) and not (workdir / "particle_flow.h5").exists(),
          "particle_flow.nml --estimate: a ladder of 7 levels, nothing written")
    if failures:
        sys.exit(f"{len(failures)} check(s) failed")
    print("check_example_particle: all checks passed")


if __name__ == "__main__":
    main(*sys.argv[1:5])
