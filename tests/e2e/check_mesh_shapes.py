"""check_mesh_shapes.py BEADMOB MPIEXEC RANKS WORKDIR: triangle meshes as geometry (docs/input.md, "Meshes";
src/geometry/triangle_mesh.f90).

1. Fine meshes of an ellipsoid (semi-axes 7.3, 5.2, 3.6 mesh units), a sphere (radius 6.1) and a
   torus (radii 6.2, 2.3), written here as binary STL, ascii STL and OBJ, with bead_diameter 1.0
   and 0.5 (the resolution: a node every d mesh units), give the same beads as beadmob's analytic
   `spheroid`, `sphere` and `torus` shapes scaled alike, except at nodes within 5e-3 d of the
   continuum surface, where the polyhedron (its chords lie up to 1.6e-3 d inside at the finer
   resolution) may decide the other way. The reference nodes are also checked against the exact inside test computed here.
2. Broken meshes are refused with a non-zero exit and a message naming the problem: a sphere
   with one triangle removed (not closed: an edge with no triangle on its other side), one
   triangle flipped (an edge used twice in the same direction), a degenerate triangle, an
   unknown extension, a missing file, a bad OBJ index and a bad ascii STL vertex line (with the
   line number).
3. The analytic shapes in their own length unit (`bead_diameter` given: sphere, spheroid, torus
   and the paper shapes cone, arrowhead, open ring) are the lattice shapes of lengths /
   bead_diameter, bead for bead; a paper shape in physical units without all its lengths, a box
   (counted in beads) with bead_diameter and a negative bead_diameter are refused."""
import os
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np

GRAZE = 5.0e-3   # d: nodes this close to the continuum surface may go either way


def grid_surface(point, n_u, n_v, closed_v):
    """Triangles (n, 3 corners, 3) of a parametric surface point(u, v) (vectorised over arrays),
    u periodic in [0, 2 pi), v in [0, pi] with a pole at each end (closed_v False: the triangles
    touching a pole are kept whole, the degenerate halves dropped) or periodic in [0, 2 pi)."""
    us = np.linspace(0, 2 * np.pi, n_u, endpoint=False)
    vs = np.linspace(0, 2 * np.pi, n_v, endpoint=False) if closed_v else np.linspace(0, np.pi, n_v + 1)
    grid = snap(np.stack(point(*np.meshgrid(us, vs, indexing="ij")), axis=-1))   # (n_u, len(vs), 3)
    i = np.arange(n_u)[:, None]
    j = np.arange(n_v)[None, :]
    i1, j1 = (i + 1) % n_u, (j + 1) % len(vs)
    a, b, c, d = grid[i, j], grid[i1, j], grid[i1, j1], grid[i, j1]
    first, second = np.stack([a, b, c], axis=2), np.stack([a, c, d], axis=2)
    if not closed_v:
        first, second = first[:, 1:], second[:, :-1]   # at the poles a = b (north), c = d (south)
    return np.concatenate([first.reshape(-1, 3, 3), second.reshape(-1, 3, 3)])


def snap(p):
    """Exact zeros where rounding left 1e-16 (the poles: sin(pi) != 0), so shared corners are equal."""
    return np.where(np.abs(p) < 1e-12, 0.0, p)


def orient_outward(triangles, outward):
    """Flip triangles whose normal points against outward(centroid)."""
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    flip = np.einsum("ij,ij->i", normals, outward(triangles.mean(axis=1))) < 0
    triangles[flip] = triangles[flip][:, [0, 2, 1]]
    return triangles


def ellipsoid_mesh(a, b, c, n=120):
    tri = grid_surface(lambda u, v: np.array([a * np.sin(v) * np.cos(u), b * np.sin(v) * np.sin(u), c * np.cos(v)]),
                       2 * n, n, closed_v=False)
    return orient_outward(tri, lambda p: p / np.array([a, b, c]) ** 2)


def torus_mesh(major, minor, n=120):
    def point(u, v):
        return np.array([(major + minor * np.cos(v)) * np.cos(u), (major + minor * np.cos(v)) * np.sin(u),
                         minor * np.sin(v)])

    def outward(p):
        ring = np.stack([p[:, 0], p[:, 1], np.zeros(len(p))], axis=1)
        ring *= major / np.linalg.norm(ring, axis=1)[:, None]
        return p - ring

    return orient_outward(grid_surface(point, 2 * n, n, closed_v=True), outward)


def write_stl_binary(path, triangles):
    record = np.zeros(len(triangles), dtype=[("normal", "<f4", 3), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])
    record["corners"] = triangles
    with open(path, "wb") as f:
        f.write(b"beadmob test mesh".ljust(80, b" "))
        f.write(np.uint32(len(triangles)).tobytes())
        f.write(record.tobytes())


def write_stl_ascii(path, triangles):
    lines = ["solid test"]
    for t in triangles:
        lines += ["  facet normal 0 0 0", "    outer loop"]
        lines += [f"      vertex {x:.17g} {y:.17g} {z:.17g}" for x, y, z in t]
        lines += ["    endloop", "  endfacet"]
    Path(path).write_text("\n".join(lines + ["endsolid test"]) + "\n")


def write_obj(path, triangles):
    vertices, index = np.unique(triangles.reshape(-1, 3), axis=0, return_inverse=True)
    faces = index.reshape(-1, 3) + 1
    text = ["# beadmob test mesh"] + [f"v {x:.17g} {y:.17g} {z:.17g}" for x, y, z in vertices]
    text += [f"f {a}/{a} {b}//{b} {c}" for a, b, c in faces]   # the a/t/n forms too
    Path(path).write_text("\n".join(text) + "\n")


def run(beadmob, mpiexec, ranks, workdir, shape_group, expect_ok=True):
    nml = Path(workdir) / "mesh.nml"
    nml.write_text(f"&run output = 'mesh.h5' /\n&shape {shape_group} /\n")
    result = Path(workdir) / "mesh.h5"
    result.unlink(missing_ok=True)
    done = subprocess.run([mpiexec, "-n", str(ranks), beadmob, str(nml), "-geometry_only", "-quiet"], cwd=workdir,
                          capture_output=True, text=True)
    if not expect_ok:
        return done
    if done.returncode != 0:
        sys.exit(f"beadmob failed on &shape {shape_group}:\n{done.stdout}\n{done.stderr}")
    with h5py.File(result, "r") as f:
        return f["geometry"]["positions"][()]


def node_set(positions):
    return {tuple(p) for p in np.rint(positions).astype(int)}


def main(beadmob, mpiexec, ranks, workdir):
    workdir = Path(workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    failures = []
    axes = np.array([7.3, 5.2, 3.6])
    bodies = [
        ("ellipsoid", ellipsoid_mesh(*axes),
         lambda s: f"name = 'spheroid', semi_axes = {axes[0] * s:.17g}, {axes[1] * s:.17g}, {axes[2] * s:.17g}",
         lambda p, s: (np.sqrt(np.sum((p / (axes * s)) ** 2, axis=1)) - 1) * axes.min() * s),
        ("sphere", ellipsoid_mesh(6.1, 6.1, 6.1), lambda s: f"name = 'sphere', radius = {6.1 * s:.17g}",
         lambda p, s: np.linalg.norm(p, axis=1) - 6.1 * s),
        ("torus", torus_mesh(6.2, 2.3), lambda s: f"name = 'torus', major_radius = {6.2 * s:.17g}, "
         f"minor_radius = {2.3 * s:.17g}",
         lambda p, s: np.hypot(np.hypot(p[:, 0], p[:, 1]) - 6.2 * s, p[:, 2]) - 2.3 * s),
    ]
    writers = [("stl", write_stl_binary), ("ascii.stl", write_stl_ascii), ("obj", write_obj)]
    for name, triangles, analytic_group, signed_distance in bodies:
        analytic_of = {}
        for diameter in (1.0, 0.5):
            analytic_of[diameter] = run(beadmob, mpiexec, ranks, workdir, analytic_group(1 / diameter))
            # the analytic shape against the exact inside test computed here
            if not np.all(signed_distance(analytic_of[diameter], 1 / diameter) <= 1e-9):
                failures.append(f"{name}: the analytic shape has nodes outside the body")
        for suffix, writer in writers:
            mesh_path = workdir / f"{name}.{suffix}"
            writer(mesh_path, triangles)
            for diameter in (1.0, 0.5):
                scale = 1 / diameter
                from_mesh = node_set(run(beadmob, mpiexec, ranks, workdir,
                                         f"name = 'mesh', file = '{mesh_path.name}', bead_diameter = {diameter}"))
                analytic = analytic_of[diameter]
                differing = np.array(sorted(from_mesh ^ node_set(analytic)), dtype=float).reshape(-1, 3)
                far = differing[np.abs(signed_distance(differing, scale)) > GRAZE] if len(differing) else differing
                label = f"{name} ({suffix}, bead_diameter {diameter})"
                if len(far):
                    failures.append(f"{label}: {len(far)} nodes differ from the analytic shape away from the surface, "
                                    f"e.g. {far[:3].tolist()}")
                elif len(from_mesh) == 0:
                    failures.append(f"{label}: no beads")
                else:
                    print(f"{label}: {len(from_mesh)} beads, {len(differing)} grazing nodes differ")

    # Analytic shapes in their own units: lengths / bead_diameter is the lattice body.
    for physical, lattice in [("name = 'spheroid', semi_axes = 3.65, 2.6, 1.8, bead_diameter = 0.5",
                               "name = 'spheroid', semi_axes = 7.3, 5.2, 3.6"),
                              ("name = 'sphere', radius = 0.61, bead_diameter = 0.05", "name = 'sphere', radius = 12.2"),
                              ("name = 'torus', major_radius = 6.2, minor_radius = 2.3, bead_diameter = 2",
                               "name = 'torus', major_radius = 3.1, minor_radius = 1.15"),
                              ("name = 'cone', base_diameter = 1.0, height = 2.35, bead_diameter = 0.05", "name = 'cone'"),
                              ("name = 'arrowhead', length = 3.0, height = 1.5, middle_height = 0.5, width = 0.4, "
                               "bead_diameter = 0.1", "name = 'arrowhead', length = 30, height = 15, middle_height = 5, "
                               "width = 4"),
                              ("name = 'open_ring', semi_major = 1.6, semi_minor = 1.2, pipe_radius = 0.31, "
                               "gap_half_angle = 30, bead_diameter = 0.1",
                               "name = 'open_ring', semi_major = 16, semi_minor = 12, pipe_radius = 3.1, "
                               "gap_half_angle = 30")]:
        given, scaled = (node_set(run(beadmob, mpiexec, ranks, workdir, group)) for group in (physical, lattice))
        if given != scaled or not given:
            failures.append(f"&shape {physical}: {len(given ^ scaled)} beads differ from &shape {lattice}")
        else:
            print(f"{physical}: the {len(given)} beads of {lattice}")

    sphere = ellipsoid_mesh(4.2, 4.2, 4.2, n=24)
    broken = {
        "open.stl": (np.delete(sphere, 10, axis=0), "is not closed"),
        "flipped.stl": (np.concatenate([sphere[:5], sphere[5:6, [0, 2, 1]], sphere[6:]]), "same direction"),
        "degenerate.stl": (np.concatenate([sphere, sphere[:1, [0, 0, 1]]]), "two equal corners"),
    }
    for file_name, (triangles, expected) in broken.items():
        write_stl_binary(workdir / file_name, triangles)
    (workdir / "bad_index.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n")
    (workdir / "bad_vertex.stl").write_text("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 zero\n")
    (workdir / "mesh.ply").write_text("ply\n")
    cases = [(name, text) for name, (_, text) in broken.items()]
    # physical units without every length of a paper shape, or for a shape counted in beads
    for group, expected in [("name = 'cone', base_diameter = 1.0, bead_diameter = 0.05", "needs height in the same unit"),
                            ("name = 'box', box_beads = 2, 2, 2, bead_diameter = 0.05", "'bead_diameter' is not taken"),
                            ("name = 'sphere', radius = 1, bead_diameter = -1", "bead_diameter must be positive")]:
        done = run(beadmob, mpiexec, ranks, workdir, group, expect_ok=False)
        if done.returncode == 0 or expected not in done.stderr:
            failures.append(f"&shape {group}: expected a refusal with '{expected}', got exit {done.returncode}:\n"
                            f"{done.stderr}")
    cases += [("bad_index.obj", "line 4"), ("bad_vertex.stl", "line 4"), ("mesh.ply", "unknown format"),
              ("missing.stl", "does not exist")]
    for file_name, expected in cases:
        done = run(beadmob, mpiexec, ranks, workdir, f"name = 'mesh', file = '{file_name}', bead_diameter = 0.5",
                   expect_ok=False)
        if done.returncode == 0 or expected not in done.stderr or file_name not in done.stderr:
            failures.append(f"{file_name}: expected a refusal naming the file and '{expected}', got exit "
                            f"{done.returncode}:\n{done.stderr}")
        else:
            print(f"{file_name}: refused: {done.stderr.strip().splitlines()[0]}")
    for failure in failures:
        print("FAIL:", failure)
    if failures:
        sys.exit(1)


if __name__ == "__main__":
    main(*sys.argv[1:5])
