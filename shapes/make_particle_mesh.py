#!/usr/bin/env python3
"""make_particle_mesh.py [OUT.stl]: writes shapes/particle.stl, the example particle of the README
and docs/input.md ("Meshes"): a bent, lumpy bean about 1.7 x 1.0 x 0.8 mm (no symmetry plane),
3968 triangles, binary STL in millimetres. Made from a latitude-longitude grid of an ellipsoid of
semi-axes 0.85, 0.5, 0.4, its radius modulated by two low harmonics and its long axis bent in the
xz plane; the triangles are oriented outward (positive enclosed volume). Deterministic: no
random numbers, so rerunning the script gives the same body."""
import sys
from pathlib import Path

import numpy as np

SEMI_AXES = np.array([0.85, 0.5, 0.4])
N_AROUND, N_POLE = 64, 32


def surface_point(u, v):
    """The bean's surface at longitude u in [0, 2 pi), colatitude v in [0, pi]."""
    lump = 1 + 0.08 * np.sin(v) ** 2 * np.cos(2 * u - 0.5) + 0.06 * np.sin(v) * np.cos(v) * np.sin(u + 0.3)
    x = SEMI_AXES[0] * lump * np.sin(v) * np.cos(u)
    y = SEMI_AXES[1] * lump * np.sin(v) * np.sin(u)
    z = SEMI_AXES[2] * lump * np.cos(v)
    return np.stack([x, y, z + 0.35 * (x / SEMI_AXES[0]) ** 2], axis=-1)   # bent: the ends lifted


def bean_triangles():
    us = np.linspace(0, 2 * np.pi, N_AROUND, endpoint=False)
    vs = np.linspace(0, np.pi, N_POLE + 1)
    grid = surface_point(*np.meshgrid(us, vs, indexing="ij"))          # (N_AROUND, N_POLE + 1, 3)
    grid[:, 0] = surface_point(0.0, 0.0)                                # one point at each pole
    grid[:, -1] = surface_point(0.0, np.pi)
    i = np.arange(N_AROUND)[:, None]
    j = np.arange(N_POLE)[None, :]
    a, b, c, d = grid[i, j], grid[(i + 1) % N_AROUND, j], grid[(i + 1) % N_AROUND, j + 1], grid[i, j + 1]
    first = np.stack([a, b, c], axis=2)[:, 1:]     # at the north pole a = b: that half is empty
    second = np.stack([a, c, d], axis=2)[:, :-1]   # at the south pole c = d
    triangles = np.concatenate([first.reshape(-1, 3, 3), second.reshape(-1, 3, 3)])
    volume = np.einsum("ij,ij->i", triangles[:, 0], np.cross(triangles[:, 1], triangles[:, 2])).sum() / 6
    return triangles if volume > 0 else triangles[:, [0, 2, 1]]


def write_binary_stl(path, triangles):
    record = np.zeros(len(triangles), dtype=[("normal", "<f4", 3), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])
    record["corners"] = triangles
    normals = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    record["normal"] = normals / np.linalg.norm(normals, axis=1)[:, None]
    with open(path, "wb") as f:
        f.write(b"beadmob example particle (shapes/make_particle_mesh.py), mm".ljust(80, b" "))
        f.write(np.uint32(len(triangles)).tobytes())
        f.write(record.tobytes())


if __name__ == "__main__":
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).resolve().parent / "particle.stl"
    triangles = bean_triangles()
    write_binary_stl(out, triangles)
    print(f"{out}: {len(triangles)} triangles")
