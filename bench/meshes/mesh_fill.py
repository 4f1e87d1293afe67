#!/usr/bin/env python3
"""mesh_fill.py [--exe BUILD/beadmob] [--repeats 3]: how long a large mesh takes to become a bead
model (docs/input.md, "Meshes": a 1e6-triangle mesh fills in seconds).

A sphere of radius 1 (mesh units) tessellated into about 1e6 triangles (binary and ascii STL),
filled at bead diameters 1/20, 1/40 and 1/60 (about 3e4, 2.7e5 and 9e5 beads): the whole
`beadmob -geometry_only` process on 2 ranks (reading, the closedness check, the fill, the
geometry checks and the result file), median of --repeats runs, beside the same process for the
analytic `sphere` shape of the same radius in d (the start-up and the geometry checks alone). The
bead counts are compared: the mesh's nodes may differ from the sphere's only within the
polyhedron's distance from the sphere."""
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
sys.path.insert(0, str(ROOT / "tests" / "e2e"))
from check_mesh_shapes import ellipsoid_mesh, write_stl_ascii, write_stl_binary  # noqa: E402

RANKS = 2
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")


def timed_run(exe, shape_group, workdir):
    nml = Path(workdir) / "fill.nml"
    nml.write_text(f"&run output = 'fill.h5' /\n&shape {shape_group} /\n")
    start = time.perf_counter()
    subprocess.run(["mpiexec", "-n", str(RANKS), exe, str(nml), "-geometry_only", "-quiet"], cwd=workdir, env=ENV,
                   check=True, stdout=subprocess.DEVNULL)
    seconds = time.perf_counter() - start
    with h5py.File(Path(workdir) / "fill.h5") as f:
        beads = f["geometry"]["positions"].shape[0]
    return seconds, beads


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--exe", default=str(ROOT / "build" / "beadmob"))
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--out", default=str(Path(__file__).with_name("mesh_fill.md")))
    args = parser.parse_args()
    exe = os.path.abspath(args.exe)
    rows = []
    with tempfile.TemporaryDirectory() as work:
        triangles = ellipsoid_mesh(1.0, 1.0, 1.0, n=500)   # 4 n^2 - 2 n = 998 e3 triangles
        write_stl_binary(Path(work) / "sphere.stl", triangles)
        write_stl_ascii(Path(work) / "sphere_ascii.stl", triangles)
        sizes = {name: (Path(work) / name).stat().st_size / 1e6 for name in ("sphere.stl", "sphere_ascii.stl")}
        for file_name in ("sphere.stl", "sphere_ascii.stl"):
            for per_radius in (20, 40, 60):
                mesh_times, analytic_times = [], []
                for _ in range(args.repeats):
                    seconds, mesh_beads = timed_run(exe, f"name = 'mesh', file = '{file_name}', "
                                                    f"bead_diameter = {1 / per_radius:.17g}", work)
                    mesh_times.append(seconds)
                    seconds, sphere_beads = timed_run(exe, f"name = 'sphere', radius = {per_radius}", work)
                    analytic_times.append(seconds)
                rows.append((file_name, sizes[file_name], per_radius, mesh_beads, sphere_beads,
                             float(np.median(mesh_times)), float(np.median(analytic_times))))
                print(rows[-1], flush=True)
    lines = ["# Filling a 1e6-triangle mesh", "",
             f"Written by `bench/meshes/mesh_fill.py --repeats {args.repeats}`: a sphere of radius 1 as "
             f"{len(triangles)} triangles, {RANKS} ranks, `-geometry_only` whole process (mpiexec to exit), median of "
             f"{args.repeats}; beside it the analytic `sphere` of the same radius in d (start-up and geometry checks "
             "without the mesh).", "",
             "| file | MB | radius (d) | mesh beads | sphere beads | mesh run (s) | sphere run (s) | difference (s) |",
             "|---|---|---|---|---|---|---|---|"]
    for file_name, megabytes, radius, mesh_beads, sphere_beads, mesh_time, sphere_time in rows:
        lines.append(f"| {file_name} | {megabytes:.0f} | {radius} | {mesh_beads} | {sphere_beads} | {mesh_time:.2f} | "
                     f"{sphere_time:.2f} | {mesh_time - sphere_time:.2f} |")
    lines += ["", "Difference: mesh run - sphere run. Both runs build a bead model and check it (overlaps, the "
              "lattice); the mesh run reads, merges, checks and fills the mesh by columns, the sphere run tests every "
              "node of its bounding box, which at large bead counts takes longer than the mesh's columns (a negative "
              "difference). Mesh beads fewer than the sphere's: nodes on or within the polyhedron's distance "
              "(~5e-6 of the radius) of the sphere, which the inscribed polyhedron leaves out."]
    Path(args.out).write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
