"""check_mesh_files.py BEADMOB MPIEXEC RANKS WORKDIR: the mesh file variants that exporters write are
read as the same surface (docs/input.md, "Meshes"; src/geometry/triangle_mesh.f90).

One body, a barrel (an ellipsoid of semi-axes 7.3, 5.2, 3.6 mesh units cut flat at |z| = 3.38), is
made here as polygons: quads on its side, a planar 160-gon on each cap. Its vertices lie on a 2^-10
grid, so every file below holds exactly the same coordinates (float32 in a binary STL, 17 digits in
text). The reference is the plain binary STL of the polygons split into fans from their first
corner (as the reader splits them), filled at bead_diameter 0.5 with -geometry_only; its beads are
checked against the exact inside test of the barrel computed here (at nodes farther than GRAZE from
the continuum surface, of which the polygons are chords).

Each variant must give the reference's beads, bead for bead (/geometry/positions, in order):
- binary STL whose 80-byte header begins with "solid" (binary by its size, 84 + 50 n);
- ascii STL with names after solid and endsolid; with CRLF line ends and tab indentation;
- OBJ with v/vt/vn and v/vt faces, vertex colours, vt and vn lines, o, g, s, usemtl and mtllib
  lines and comments; with v//vn faces; with negative (relative) indices; with CRLF line ends and tabs after the keywords;
  the quads and 160-gons as they are (face lines longer than the reader's 1024-character chunk).
Two closed components in one file (the barrel and a sphere beside it, in a binary STL and in an OBJ
of two `o` objects) give the union of the two files' beads. The barrel moved by S = (1000, -1500,
2000.5) mesh units (a whole number of bead diameters, exact in float32 on the grid) gives the
reference's beads + S / d: the same lattice nodes relative to the same vertices. The fill rounds
otherwise at 1e3, which could only decide differently at a node exactly on the surface: such nodes
would be allowed and printed (none is expected).

Messages print coordinates readably: the barrel with one triangle removed is refused as not closed,
naming an edge of the hole by its end points "(x, y, z)" with 4 significant digits (Python's
'.4g'); a small sphere at 1e3 with a hole, whose corners all read alike at 4 digits, with the
fewest digits that tell the two end points apart (more than 4)."""
import re
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np

from checklist import check, failures
from check_mesh_shapes import ellipsoid_mesh, write_stl_binary

DIAMETER = 0.5
AXES = np.array([7.3, 5.2, 3.6])
GRID = 2.0 ** -10           # vertex grid (mesh units): exact in float32 up to |x| < 2^14
GRAZE = 0.02                # d: chords (<= 6e-4 mesh units) and the grid (5e-4) of the continuum surface
SHIFT = np.array([1000.0, -1500.0, 2000.5])
SECOND = np.array([14.0, 0.0, 0.0])   # the sphere beside the barrel (radius 4)
SMALL_AT = np.array([1200.25, -1500.25, 2000.25])   # a sphere of radius 0.2 with a hole


def on_grid(p):
    return np.round(np.asarray(p) / GRID) * GRID + 0.0   # + 0.0: no -0


def barrel(n_u=160, n_v=60, cut=0.35):
    """Vertices (n, 3) and polygons (lists of vertex indices, counter-clockwise seen from outside)."""
    u = np.linspace(0, 2 * np.pi, n_u, endpoint=False)
    v = np.linspace(cut, np.pi - cut, n_v + 1)
    uu, vv = np.meshgrid(u, v, indexing="ij")
    grid = on_grid(np.stack([AXES[0] * np.sin(vv) * np.cos(uu), AXES[1] * np.sin(vv) * np.sin(uu),
                             AXES[2] * np.cos(vv)], axis=-1))
    vertices = grid.reshape(-1, 3)
    index = np.arange(len(vertices)).reshape(n_u, n_v + 1)
    # u grows counter-clockwise about +z, v from the top down: (i, j), (i, j+1), (i+1, j+1), (i+1, j)
    polygons = [[index[i, j], index[i, j + 1], index[(i + 1) % n_u, j + 1], index[(i + 1) % n_u, j]]
                for i in range(n_u) for j in range(n_v)]
    polygons.append([index[i, 0] for i in range(n_u)])             # top cap, normal +z
    polygons.append([index[i, n_v] for i in reversed(range(n_u))])   # bottom cap, normal -z
    return vertices, polygons


def fan(vertices, polygons):
    """Triangles (n, 3 corners, 3) of the polygons split into fans from their first corner."""
    return np.array([vertices[[p[0], p[k], p[k + 1]]] for p in polygons for k in range(1, len(p) - 1)])


def barrel_signed_distance(p):
    """Approximate signed distance to the continuum barrel (mesh units; exact sign)."""
    ellipsoid = (np.linalg.norm(p / AXES, axis=1) - 1) * AXES.min()
    return np.maximum(ellipsoid, np.abs(p[:, 2]) - on_grid(AXES[2] * np.cos(0.35)))


def write_binary_stl(path, triangles, header):
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    record = np.zeros(len(triangles), dtype=[("normal", "<f4", 3), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])
    record["normal"], record["corners"] = normals, triangles
    with open(path, "wb") as f:
        f.write(header.ljust(80, b" "))
        f.write(np.uint32(len(triangles)).tobytes())
        f.write(record.tobytes())


def write_ascii_stl(path, triangles, name, newline="\n", indent="  "):
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    lines = [f"solid {name}"]
    for n, t in zip(normals.tolist(), triangles.tolist()):
        lines += [f"{indent}facet normal {n[0]:e} {n[1]:e} {n[2]:e}", f"{indent * 2}outer loop"]
        lines += [f"{indent * 3}vertex {x!r} {y!r} {z!r}" for x, y, z in t]
        lines += [f"{indent * 2}endloop", f"{indent}endfacet"]
    with open(path, "w", newline="") as f:
        f.write(newline.join(lines + [f"endsolid {name}"]) + newline)


def obj_lines(bodies, face_form="v/vt/vn"):
    """OBJ text of bodies [(name, vertices, polygons)]: mtllib, o, g, usemtl, s lines, vt and vn lines,
    faces in face_form ('v', 'v//vn', or 'v/vt/vn': then every other face v/vt and vertex colours
    after x y z) with absolute indices, or 'relative': each polygon's corners written as v lines
    just before it and indexed from the end (-n ... -1)."""
    lines = ["# exported by a CAD program", "mtllib barrel.mtl"]
    offset = 0
    for name, vertices, polygons in bodies:
        lines += [f"o {name}", f"g {name}_surface", "usemtl grey", "s 1"]
        if face_form == "relative":
            for p in polygons:
                lines += [f"v {x!r} {y!r} {z!r}" for x, y, z in vertices[p].tolist()]
                lines.append("f " + " ".join(str(k - len(p)) for k in range(len(p))))
            continue
        colour = " 0.8 0.6 0.4" if face_form == "v/vt/vn" else ""   # vertex colours after x y z
        lines += [f"v {x!r} {y!r} {z!r}{colour}" for x, y, z in vertices.tolist()]
        lines += ["vt 0.5 0.5", "vt 0.25 0.75"]
        lines += [f"vn {x:.6f} {y:.6f} {z:.6f}" for x, y, z in vertices[:3] / np.linalg.norm(vertices[:3], axis=1)[:, None]]
        lines.append("s off")
        for m, p in enumerate(polygons):
            corners = [k + 1 + offset for k in p]
            if face_form == "v/vt/vn" and m % 2:
                lines.append("f " + " ".join(f"{c}/{1 + c % 2}" for c in corners))   # every other face v/vt
            elif face_form == "v/vt/vn":
                lines.append("f " + " ".join(f"{c}/{1 + c % 2}/{1 + c % 3}" for c in corners))
            elif face_form == "v//vn":
                lines.append("f " + " ".join(f"{c}//{1 + c % 3}" for c in corners))
            else:
                lines.append("f " + " ".join(str(c) for c in corners))
        offset += len(vertices)
    return lines


def write_text(path, lines, newline="\n"):
    with open(path, "w", newline="") as f:
        f.write(newline.join(lines) + newline)


def run(beadmob, mpiexec, ranks, workdir, file_name):
    """(positions or None, the finished process) of -geometry_only on the mesh file."""
    nml = workdir / "mesh.nml"
    nml.write_text(f"&run output = 'mesh.h5' /\n&shape name = 'mesh', file = '{file_name}', "
                   f"bead_diameter = {DIAMETER} /\n")
    result = workdir / "mesh.h5"
    result.unlink(missing_ok=True)
    done = subprocess.run([mpiexec, "-n", str(ranks), beadmob, str(nml), "-geometry_only", "-quiet"], cwd=workdir,
                          capture_output=True, text=True)
    if done.returncode != 0:
        return None, done
    with h5py.File(result, "r") as f:
        return f["geometry"]["positions"][()], done


def node_set(positions):
    return {tuple(p) for p in np.rint(positions).astype(np.int64)}


def on_triangle(points, triangles, tolerance=1e-9):
    """For each point (mesh units), whether it lies within tolerance of one of the triangles."""
    found = []
    for p in points:
        a, b, c = triangles[:, 0], triangles[:, 1], triangles[:, 2]
        n = np.cross(b - a, c - a)
        n /= np.linalg.norm(n, axis=1)[:, None]
        height = np.einsum("ij,ij->i", p - a, n)
        q = p - height[:, None] * n
        inside = np.ones(len(a), dtype=bool)
        for u, v in ((a, b), (b, c), (c, a)):
            inside &= np.einsum("ij,ij->i", np.cross(v - u, q - u), n) >= -tolerance
        found.append(bool(np.any(inside & (np.abs(height) <= tolerance))))
    return np.array(found)


def g(value, digits):
    """value with `digits` significant digits as beadmob prints coordinates (C's and Python's %g)."""
    return format(float(value) + 0.0, f".{digits}g")


def point_text(p, digits):
    return "(" + ", ".join(g(x, digits) for x in p) + ")"


def check_hole_message(beadmob, mpiexec, ranks, workdir, file_name, triangles, removed):
    """The mesh without triangle `removed` is refused naming an edge of the hole readably: its two end
    points at the fewest significant digits (>= 4) that tell them apart. Returns those digits."""
    write_binary_stl(workdir / file_name, np.delete(triangles, removed, axis=0), b"hole")
    positions, done = run(beadmob, mpiexec, ranks, workdir, file_name)
    message = done.stderr.strip()
    check(positions is None and "is not closed" in message and file_name in message,
          f"{file_name}: refused as not closed: {message.splitlines()[0] if message else '(no message)'}")
    number = r"-?\d+(?:\.\d+)?(?:e[+-]\d\d+)?"
    points = re.findall(rf"\(({number}), ({number}), ({number})\)", message)
    check(len(points) == 2, f"{file_name}: the message names two points as (x, y, z): {points}")
    check(not re.search(r"\d[ED][+-]?\d", message) and "*" not in message,
          f"{file_name}: no Fortran number format (E or D exponents, 0.123E-1) in the message")
    if len(points) != 2:
        return
    texts = ["(" + ", ".join(p) + ")" for p in points]
    corners = triangles[removed].astype(np.float32).astype(np.float64)   # as the binary STL holds them
    matched = None
    for k in range(3):
        a, b = corners[(k + 1) % 3], corners[k]   # the hole's edge as its neighbour runs it
        digits = 4
        while digits < 17 and point_text(a, digits) == point_text(b, digits):
            digits += 1
        if texts == [point_text(a, digits), point_text(b, digits)]:
            matched = digits
    check(matched is not None, f"{file_name}: the points {texts[0]}, {texts[1]} are the end points of an edge of the "
          f"hole with the fewest digits >= 4 that tell them apart ({matched})")
    return matched


def main(beadmob, mpiexec, ranks, workdir):
    workdir = Path(workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    vertices, polygons = barrel()
    triangles = fan(vertices, polygons)
    sphere = on_grid(ellipsoid_mesh(4.0, 4.0, 4.0, n=60)) + SECOND
    sphere_vertices, sphere_index = np.unique(sphere.reshape(-1, 3), axis=0, return_inverse=True)
    sphere_polygons = sphere_index.reshape(-1, 3).tolist()

    # The reference and its independent check.
    write_binary_stl(workdir / "barrel.stl", triangles, b"beadmob test mesh")
    write_binary_stl(workdir / "sphere.stl", sphere, b"beadmob test mesh")
    reference, done = run(beadmob, mpiexec, ranks, workdir, "barrel.stl")
    second, done_second = run(beadmob, mpiexec, ranks, workdir, "sphere.stl")
    if reference is None or second is None:
        sys.exit(f"the reference meshes failed:\n{done.stderr}\n{done_second.stderr}")
    for name, beads, distance, radius in (
            ("barrel.stl", reference, barrel_signed_distance, AXES + 1),
            ("sphere.stl", second, lambda p: np.linalg.norm(p - SECOND, axis=1) - 4.0, np.full(3, 5.0))):
        centre = SECOND if name == "sphere.stl" else np.zeros(3)
        axes = [np.arange(np.floor((centre[k] - radius[k]) / DIAMETER), np.ceil((centre[k] + radius[k]) / DIAMETER) + 1)
                for k in range(3)]
        nodes = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        signed = distance(nodes * DIAMETER) / DIAMETER
        found = node_set(beads)
        inside = np.array([tuple(p) in found for p in nodes.astype(np.int64)])
        wrong = nodes[(inside & (signed > GRAZE)) | (~inside & (signed < -GRAZE))]
        check(len(beads) > 1000 and len(wrong) == 0 and len(found) == len(beads),
              f"{name}: {len(beads)} beads = the exact inside test away from the surface "
              f"({np.sum(np.abs(signed) <= GRAZE)} nodes within {GRAZE} d, {len(wrong)} wrong, e.g. {wrong[:3].tolist()})")

    # Variants of the same polygons: the reference's beads, bead for bead.
    write_binary_stl(workdir / "solid_header.stl", triangles, b"solid barrel, binary: exported by a CAD program")
    write_ascii_stl(workdir / "named.stl", triangles, "barrel_v2 exported by CAD 1.0")
    write_ascii_stl(workdir / "crlf_tabs.stl", triangles, "barrel", newline="\r\n", indent="\t")
    bodies = [("barrel", vertices, polygons)]
    longest = max(len(line) for line in obj_lines(bodies, "v/vt/vn") if line.startswith("f "))
    check(longest > 1024, f"the OBJ's longest face line has {longest} characters (> 1024, one read chunk)")
    write_text(workdir / "vtn.obj", obj_lines(bodies, "v/vt/vn"))
    write_text(workdir / "vn.obj", obj_lines(bodies, "v//vn"))
    write_text(workdir / "relative.obj", obj_lines(bodies, "relative"))
    # CR right after an index; a tab after each keyword
    write_text(workdir / "crlf_tabs.obj", ["\t" + line.replace(" ", "\t", 1) for line in obj_lines(bodies, "v")],
               newline="\r\n")
    for file_name in ("solid_header.stl", "named.stl", "crlf_tabs.stl", "vtn.obj", "vn.obj", "relative.obj",
                      "crlf_tabs.obj"):
        positions, done = run(beadmob, mpiexec, ranks, workdir, file_name)
        same = positions is not None and positions.shape == reference.shape and np.array_equal(positions, reference)
        check(same, f"{file_name}: the reference's {len(reference)} beads, bead for bead"
              + ("" if positions is not None else f" (refused: {done.stderr.strip()})")
              + ("" if positions is None or same else f" (got {len(positions)} beads, "
                 f"{len(node_set(positions) ^ node_set(reference))} nodes differ)"))

    # Two closed components in one file: the union of the two files' beads.
    write_binary_stl(workdir / "two.stl", np.concatenate([triangles, sphere]), b"solid two bodies")
    write_text(workdir / "two.obj", obj_lines(bodies + [("sphere", sphere_vertices, sphere_polygons)], "v/vt/vn"))
    union = node_set(reference) | node_set(second)
    for file_name in ("two.stl", "two.obj"):
        positions, done = run(beadmob, mpiexec, ranks, workdir, file_name)
        check(positions is not None and len(positions) == len(reference) + len(second)
              and node_set(positions) == union,
              f"{file_name}: the union of the two bodies' beads ({len(reference)} + {len(second)})"
              + ("" if positions is not None else f" (refused: {done.stderr.strip()})"))

    # Far from the origin: the reference's beads moved by SHIFT / d, exactly.
    moved = SHIFT / DIAMETER
    check(np.all(moved == np.rint(moved)), f"the shift {SHIFT.tolist()} is a whole number of bead diameters")
    far_triangles = triangles + SHIFT
    check(np.array_equal(far_triangles.astype(np.float32).astype(np.float64), far_triangles),
          "the moved vertices are exact in float32")
    write_binary_stl(workdir / "far.stl", far_triangles, b"beadmob test mesh")
    write_text(workdir / "far.obj", obj_lines([("barrel", vertices + SHIFT, polygons)], "v/vt/vn"))
    for file_name in ("far.stl", "far.obj"):
        positions, done = run(beadmob, mpiexec, ranks, workdir, file_name)
        if positions is None:
            check(False, f"{file_name}: read (refused: {done.stderr.strip()})")
            continue
        back = positions - moved
        differing = np.array(sorted(node_set(back) ^ node_set(reference)), dtype=float).reshape(-1, 3)
        on_surface = on_triangle(differing * DIAMETER, triangles)
        check(np.array_equal(back, reference) or (len(differing) > 0 and on_surface.all()),
              f"{file_name}: the reference's beads moved by {moved.tolist()} d, bead for bead "
              f"({len(positions)} beads; nodes differing: {len(differing)}, all on the surface: {on_surface.all()})")
        if len(differing):
            print(f"{file_name}: nodes on the surface decided otherwise at 1e3: {differing.tolist()}")

    # Readable coordinates in messages: a hole at the origin and at 1e3.
    removed = len(triangles) // 3
    digits = check_hole_message(beadmob, mpiexec, ranks, workdir, "hole.stl", triangles, removed)
    check(digits == 4, f"hole.stl: 4 significant digits near the origin ({digits})")
    # a small sphere at 1e3: every corner prints alike at 4 digits, (1200, -1500, 2000)
    small = on_grid(ellipsoid_mesh(0.2, 0.2, 0.2, n=16)) + SMALL_AT
    digits = check_hole_message(beadmob, mpiexec, ranks, workdir, "hole_far.stl", small, 40)
    check(digits is not None and digits > 4, f"hole_far.stl: more than 4 digits tell the end points apart at 1e3 ({digits})")
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main(*sys.argv[1:5])
