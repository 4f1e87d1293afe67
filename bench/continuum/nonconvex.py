#!/usr/bin/env python3
"""nonconvex.py [--exe BUILD/beadmob] [--budget S] [--bodies KEY,...] [--continuum TEXT] [--keep DIR]
[--reuse DIR] [--reextrapolate DIR] [--out FILE] [--list]: the continuum job (&continuum, docs/theory.md
T18) on non-convex, non-ellipsoidal meshes: what its error bar is made of when the body is not an
ellipsoid.

Bodies (`--bodies` keys), each in its own length unit, meshes made here with numpy (closed,
outward-oriented triangle meshes, OBJ with 17 significant digits), each with bead_diameter = 1/8 of
its smallest feature (the ordinary run's resolution; the continuum job's ladder lies on the grid
bead_diameter * 2^(k/3) and the budget picks its finest level):

* dumbbell: two spheres of radius 1, centres 3 apart on z, joined by a neck (a cylinder) of radius 0.4,
  as one surface of revolution (the union; a sharp concave rim where neck and sphere meet). Profile
  arc-length spacing 0.03, 192 meridians. Feature: the neck's diameter 0.8 (bead_diameter 0.1).
* bent_rod: a tube of radius 0.35 along a circular arc of radius 2 in the xy plane spanning 120
  degrees (-60 ... 60 about the x axis), closed by hemispherical caps; one swept grid, caps included.
  Centre-line spacing 0.025, 128 points round the tube. Feature: the tube's diameter 0.7
  (bead_diameter 0.0875).
* cross: three orthogonal square bars 0.6 x 0.6 x 3 along x, y, z through one centre, the boundary of
  a union of voxels of side 0.3 (10^3 voxels, two triangles per exposed voxel face), its centre moved
  to CROSS_SHIFT so that no face lies on a lattice plane of any level (the lattice's node stays at the
  mesh origin). Feature: the bar width 0.6 (bead_diameter 0.075).
* rough_sphere: radius 1 * (1 + 0.1 f), f a random combination of the real orthonormal spherical
  harmonics of degrees 2 ... 6 (coefficients standard normal, numpy default_rng(ROUGH_SEED)),
  scaled to max |f| = 1 over the mesh's vertices (radius 0.9 ... 1.1); an icosphere of 6 subdivisions
  (81920 triangles) pushed out radially. Feature: half the wavelength of degree 6, pi / 6
  (bead_diameter 0.0654).
* ellipsoid (for comparison): the analytic `spheroid` of semi-axes 1.6, 1.0, 0.7 along x, y, z, no
  mesh. Feature: its thinnest diameter 1.4 (bead_diameter 0.175). Its exact mobility
  (scripts/beadmob_post/ellipsoid.py) is beside the continuum values.

Each mesh is checked before its job: trimesh (when importable: watertight, winding consistent, a
volume) and our own check (every directed edge met by exactly one reverse edge, no degenerate
triangle, V - E + F = 2, positive signed volume); its exact polyhedral volume is compared with
beadmob's (/continuum volume: from the moment fills until 2026-11-29, the polyhedron's since). `deviation`: the largest distance of a
triangle's centroid from the smooth body it stands for (the dumbbell's union, the rod's swept tube,
the rough sphere's radius function; 0 for the cross).

Every job: `&shape ... bead_diameter /`, `&hydrodynamics /`, `&continuum time_budget = S /`
(default 600 s; every other setting default: 7 levels x 2 offsets and 6 control samples, 4 plain offsets before 2026-11-28, 32 moment fills for the analytic shape and, until 2026-11-29, for
meshes) on 2 ranks,
`-keep_checkpoint`, in DIR/<key>/ (default bench/continuum/nonconvex_runs; body.obj, job.nml,
job.h5, job.log, job.h5.continuum_checkpoint, meta.json). `--continuum TEXT` replaces the group's
contents (tiny test jobs: `levels = 3, offsets = 2, finest_bead_diameter = ...`).

The analysis: the six diagonal mobility entries in the body's principal frame, the axes of its
equivalent ellipsoid (/continuum equivalent_axes, ordered by decreasing semi-axis a >= b >= c: t_a
is translation along a, r_a rotation about a), each with beadmob's estimator replayed on that
entry (scripts/beadmob_post/continuum_bar.py: the samples turned, the level means and standard
errors, the weighted quadratic in h) and the bar's three parts: 2 sigma (the fit's standard error,
with the levels' random-effects excess tau^2 since be29465; before, inflated by the reduced chi^2
of the quadratic when above 1), the model spread (the larger distance
of the line through the three finest levels and of the quadratic without the coarsest level from
the value) and the volume term (p / 3 * the volume's relative standard error * |value|); the bar is
what continuum_bar.py's fit_error makes of the first two (their quadrature sum since 241d8d3, their
sum before) plus the volume term. `chi2/dof`: the quadratic's reduced chi^2 over the level means
with weights 1 / s_k^2 alone (above 1: the levels scatter about the quadratic more than their
standard errors say, and the fit adds the excess tau^2). Convergence
of the level means: the relative changes from the third-finest to the second-finest and from there
to the finest level's mean, and the step from the finest level's mean to the continuum value.

--reuse DIR analyses the jobs kept in DIR without solving. --reextrapolate DIR reruns beadmob (this
--exe) on each kept job's own input with its kept checkpoint (`-keep_checkpoint -stop_after_solves
1`: the samples are read, nothing is solved; a build whose checkpoint key differs would solve, and
is stopped after one sample and the old checkpoint restored), keeps the first result as
solved.h5 and reports the new estimate beside it (default --out nonconvex_reextrapolated.md)."""
import argparse
import datetime
import json
import math
import os
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Optional

import h5py
import numpy as np

from continuum_jobs import ENV, RANKS, ROOT
from coverage import icosphere

sys.path.insert(0, str(ROOT / "scripts"))
from beadmob_post.continuum_bar import (combination_bar, combination_level_means, entry_power, principal_diagonal,  # noqa: E402
                                        read_samples)
from beadmob_post.ellipsoid import ellipsoid_friction  # noqa: E402

ROUGH_SEED = 20261127
CROSS_SHIFT = np.array([0.0417, 0.0293, 0.0161])
ENTRIES = ("t_a", "t_b", "t_c", "r_a", "r_b", "r_c")
HERE = Path(__file__).resolve().parent


# ---- meshes: (vertices (V, 3), faces (F, 3) of vertex indices, counter-clockwise seen from outside) ----

def ring_mesh(south, rings, north):
    """A sphere-like grid: a pole, rings (R, U, 3) of U points each (u periodic), a pole."""
    n_rings, n_u, _ = rings.shape
    vertices = np.concatenate([south[None], rings.reshape(-1, 3), north[None]])
    index = 1 + np.arange(n_rings * n_u).reshape(n_rings, n_u)
    i, i1 = np.arange(n_u), (np.arange(n_u) + 1) % n_u
    north_index = len(vertices) - 1
    faces = [np.stack([np.zeros(n_u, int), index[0, i1], index[0, i]], 1)]
    for j in range(n_rings - 1):
        a, b, c, d = index[j, i], index[j, i1], index[j + 1, i1], index[j + 1, i]
        faces += [np.stack([a, b, c], 1), np.stack([a, c, d], 1)]
    faces.append(np.stack([np.full(n_u, north_index), index[-1, i], index[-1, i1]], 1))
    return orient(vertices, np.concatenate(faces))


def signed_volume(vertices, faces):
    t = vertices[faces]
    return float(np.sum(np.einsum("ij,ij->i", t[:, 0], np.cross(t[:, 1], t[:, 2]))) / 6)


def orient(vertices, faces):
    """All faces turned when the mesh's signed volume is negative (built consistently, so one sign)."""
    return (vertices, faces) if signed_volume(vertices, faces) > 0 else (vertices, faces[:, ::-1].copy())


def samples_along(lengths, spacing):
    """Parameters in [0, 1] of the pieces of a polyline of these lengths, about `spacing` apart, every
    piece's ends included: a list of arrays, one per piece (its end points in both neighbours)."""
    return [np.linspace(0.0, 1.0, max(2, math.ceil(length / spacing) + 1)) for length in lengths]


DUMBBELL = dict(radius=1.0, neck=0.4, centres=3.0)


def dumbbell():
    r, rho, half = DUMBBELL["radius"], DUMBBELL["neck"], DUMBBELL["centres"] / 2
    beta0 = math.pi - math.asin(rho / r)      # polar angle from the outer pole to the neck's rim
    z0 = half - math.sqrt(r * r - rho * rho)  # the rims at z = +-z0
    sphere_t, neck_t, _ = samples_along([r * beta0, 2 * z0, r * beta0], 0.03)
    profile = []                              # (radius, z) from the south pole's first ring to the north's last
    for beta in sphere_t[1:] * beta0:
        profile.append((r * math.sin(beta), -half - r * math.cos(beta)))
    for t in neck_t[1:-1]:
        profile.append((rho, -z0 + 2 * z0 * t))
    for beta in (sphere_t[::-1][:-1]) * beta0:
        profile.append((r * math.sin(beta), half + r * math.cos(beta)))
    profile = np.array(profile)
    u = np.linspace(0, 2 * np.pi, 192, endpoint=False)
    rings = np.stack([profile[:, :1] * np.cos(u), profile[:, :1] * np.sin(u), np.repeat(profile[:, 1:], len(u), 1)], -1)
    return ring_mesh(np.array([0, 0, -half - r]), rings, np.array([0, 0, half + r]))


def dumbbell_distance(p):
    r, rho, half = DUMBBELL["radius"], DUMBBELL["neck"], DUMBBELL["centres"] / 2
    z0 = half - math.sqrt(r * r - rho * rho)
    spheres = [np.linalg.norm(p - [0, 0, s * half], axis=1) - r for s in (-1, 1)]
    d = np.stack([np.hypot(p[:, 0], p[:, 1]) - rho, np.abs(p[:, 2]) - z0], 1)
    cylinder = np.minimum(d.max(1), 0) + np.linalg.norm(np.maximum(d, 0), axis=1)
    return np.minimum.reduce([*spheres, cylinder])


ROD = dict(arc=2.0, tube=0.35, span=120.0)


def bent_rod():
    big, rho, half = ROD["arc"], ROD["tube"], np.radians(ROD["span"] / 2)
    cap_t, arc_t, _ = samples_along([rho * np.pi / 2, 2 * big * half, rho * np.pi / 2], 0.025)
    u = np.linspace(0, 2 * np.pi, 128, endpoint=False)

    def ring(theta, psi, side):
        """Points at centre-line angle theta, tilted psi (0 ... pi/2) towards the cap's pole on `side`."""
        centre = big * np.array([np.cos(theta), np.sin(theta), 0])
        tangent, normal = np.array([-np.sin(theta), np.cos(theta), 0]), np.array([np.cos(theta), np.sin(theta), 0])
        binormal = np.array([0.0, 0.0, 1.0])
        circle = np.cos(u)[:, None] * normal + np.sin(u)[:, None] * binormal
        return centre + rho * (side * np.sin(psi) * tangent + np.cos(psi) * circle)

    rings = [ring(-half, psi, -1) for psi in (1 - cap_t[1:-1]) * np.pi / 2]          # south cap, pole excluded
    rings += [ring(theta, 0.0, 1) for theta in -half + 2 * half * arc_t]             # the arc, both rims
    rings += [ring(half, psi, 1) for psi in cap_t[1:-1] * np.pi / 2]                 # north cap
    pole = lambda theta, side: big * np.array([np.cos(theta), np.sin(theta), 0]) + side * rho * np.array(
        [-np.sin(theta), np.cos(theta), 0])
    return ring_mesh(pole(-half, -1), np.array(rings), pole(half, 1))


def bent_rod_distance(p):
    big, rho, half = ROD["arc"], ROD["tube"], np.radians(ROD["span"] / 2)
    theta = np.clip(np.arctan2(p[:, 1], p[:, 0]), -half, half)
    nearest = big * np.stack([np.cos(theta), np.sin(theta), np.zeros(len(p))], 1)
    return np.linalg.norm(p - nearest, axis=1) - rho


CROSS = dict(width=0.6, length=3.0, voxel=0.3)


def cross():
    n = round(CROSS["length"] / CROSS["voxel"])
    bar = round(CROSS["width"] / CROSS["voxel"])
    centre = (np.arange(n) >= (n - bar) // 2) & (np.arange(n) < (n + bar) // 2)
    ci, cj, ck = np.meshgrid(centre, centre, centre, indexing="ij")
    filled = (cj & ck) | (ci & ck) | (ci & cj)
    padded = np.zeros((n + 2,) * 3, bool)
    padded[1:-1, 1:-1, 1:-1] = filled
    corners = {}                          # integer grid corner -> vertex index
    faces = []

    def vertex(c):
        return corners.setdefault(c, len(corners))

    for axis in range(3):
        for sign in (-1, 1):
            step = np.zeros(3, int)
            step[axis] = sign
            neighbour = np.roll(padded, -sign, axis=axis)
            for v in np.argwhere(padded & ~neighbour):
                v = v - 1                                      # voxel index in the unpadded grid
                # the face's corners: the voxel's corner cube on the side `sign` of `axis`
                e1, e2 = np.eye(3, dtype=int)[(axis + 1) % 3], np.eye(3, dtype=int)[(axis + 2) % 3]
                base = v + (step > 0).astype(int) * np.eye(3, dtype=int)[axis]
                quad = [tuple(base), tuple(base + e1), tuple(base + e1 + e2), tuple(base + e2)]
                if sign < 0:
                    quad = quad[::-1]                          # counter-clockwise seen from outside
                a, b, c, d = (vertex(q) for q in quad)
                faces += [(a, b, c), (a, c, d)]
    grid = np.array(list(corners.keys()))
    vertices = (grid - n // 2) * CROSS["voxel"] + CROSS_SHIFT
    faces = np.array(faces)
    if signed_volume(vertices, faces) <= 0:
        raise RuntimeError("cross: the voxel faces came out inward")
    return vertices, faces


def rough_coefficients():
    rng = np.random.default_rng(ROUGH_SEED)
    return {(l, m): rng.standard_normal() for l in range(2, 7) for m in range(-l, l + 1)}


def rough_function(directions, coefficients):
    """sum c_lm Y_lm (real, orthonormal) at unit directions (N, 3)."""
    from scipy.special import sph_harm_y
    polar = np.arccos(np.clip(directions[:, 2], -1, 1))
    azimuth = np.arctan2(directions[:, 1], directions[:, 0])
    f = np.zeros(len(directions))
    for (l, m), c in coefficients.items():
        y = sph_harm_y(l, abs(m), polar, azimuth)
        f += c * (y.real if m == 0 else math.sqrt(2) * (-1) ** m * (y.real if m > 0 else y.imag))
    return f


def rough_scale(coefficients):
    vertices, _ = icosphere(6)
    return 1.0 / np.max(np.abs(rough_function(vertices, coefficients)))


def rough_sphere():
    vertices, faces = icosphere(6)
    coefficients = rough_coefficients()
    scale = rough_scale(coefficients)
    return orient(vertices * (1 + 0.1 * scale * rough_function(vertices, coefficients))[:, None], faces.copy())


def rough_distance(p):
    coefficients = rough_coefficients()
    radius = np.linalg.norm(p, axis=1)
    return radius - (1 + 0.1 * rough_scale(coefficients) * rough_function(p / radius[:, None], coefficients))


# ---- bodies ------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Body:
    key: str
    label: str
    feature: str
    feature_size: float
    mesh: Optional[Callable] = None
    distance: Optional[Callable] = None
    smooth_volume: Optional[float] = None
    semi_axes: Optional[tuple] = None

    @property
    def bead_diameter(self):
        return self.feature_size / 8

    def shape_group(self):
        if self.mesh is None:
            axes = ", ".join(f"{a:g}" for a in self.semi_axes)
            return f"&shape name = 'spheroid', semi_axes = {axes}, bead_diameter = {self.bead_diameter!r} /\n"
        return f"&shape name = 'mesh', file = 'body.obj', bead_diameter = {self.bead_diameter!r} /\n"

    def exact_diagonal(self):
        """The exact mobility's diagonal in the order a >= b >= c (ellipsoid only)."""
        if self.semi_axes is None:
            return None
        order = np.argsort(self.semi_axes)[::-1]
        mobility = np.linalg.inv(ellipsoid_friction(np.asarray(self.semi_axes)[order]))
        return np.diag(mobility)


def _dumbbell_volume():
    r, rho, half = DUMBBELL["radius"], DUMBBELL["neck"], DUMBBELL["centres"] / 2
    z0 = half - math.sqrt(r * r - rho * rho)
    cap = z0 - (half - r)                      # the cap of each sphere inside the neck's slab
    return 2 * (4 / 3 * math.pi * r**3 - math.pi * cap**2 * (3 * r - cap) / 3) + math.pi * rho**2 * 2 * z0


BODIES = [
    Body("dumbbell", "dumbbell", "neck diameter 0.8", 0.8, dumbbell, dumbbell_distance, _dumbbell_volume()),
    Body("bent_rod", "bent rod", "tube diameter 0.7", 0.7, bent_rod, bent_rod_distance,
         math.pi * ROD["tube"]**2 * ROD["arc"] * np.radians(ROD["span"]) + 4 / 3 * math.pi * ROD["tube"]**3),
    Body("cross", "3-D cross", "bar width 0.6", 0.6, cross, None,
         3 * CROSS["width"]**2 * CROSS["length"] - 2 * CROSS["width"]**3),
    Body("rough_sphere", "rough sphere", "half wavelength of degree 6, pi/6", math.pi / 6, rough_sphere,
         rough_distance, None),
    Body("ellipsoid", "ellipsoid 1.6:1:0.7 (analytic)", "thinnest diameter 1.4", 1.4,
         smooth_volume=4 / 3 * math.pi * 1.6 * 1.0 * 0.7, semi_axes=(1.6, 1.0, 0.7)),
]


# ---- mesh checks and files ---------------------------------------------------------------------

def check_mesh(vertices, faces):
    """Our own check and trimesh's (when importable): a dict of what was found."""
    t = vertices[faces]
    areas = np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1) / 2
    directed = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    key = lambda e: e[:, 0].astype(np.int64) * len(vertices) + e[:, 1]
    forward, counts = np.unique(key(directed), return_counts=True)
    reverse = np.isin(key(directed[:, ::-1]), forward)
    edges = len(np.unique(key(np.sort(directed, axis=1))))
    result = dict(vertices=len(vertices), triangles=len(faces), smallest_area=float(areas.min()),
                  directed_edges_unique=bool(np.all(counts == 1)), every_edge_reversed=bool(np.all(reverse)),
                  euler=int(len(vertices) - edges + len(faces)), volume=signed_volume(vertices, faces))
    result["own_ok"] = bool(result["directed_edges_unique"] and result["every_edge_reversed"] and result["euler"] == 2
                            and result["smallest_area"] > 0 and result["volume"] > 0)
    try:
        import trimesh
    except ImportError:
        result["trimesh"] = None
        return result
    mesh = trimesh.Trimesh(vertices=vertices, faces=faces, process=False)
    result["trimesh"] = dict(version=trimesh.__version__, watertight=bool(mesh.is_watertight),
                             winding_consistent=bool(mesh.is_winding_consistent), is_volume=bool(mesh.is_volume),
                             volume=float(mesh.volume))
    return result


def write_obj(path, vertices, faces):
    """OBJ with 17 significant digits: the coordinates exactly as made."""
    lines = [f"v {x:.17g} {y:.17g} {z:.17g}" for x, y, z in vertices]
    lines += [f"f {a} {b} {c}" for a, b, c in faces + 1]
    Path(path).write_text("\n".join(lines) + "\n")


# ---- jobs -----------------------------------------------------------------------------------------

def build_version(exe):
    return subprocess.run([str(exe), "--version"], capture_output=True, text=True).stdout.strip()


def beadmob(exe, folder, log, *options):
    """mpiexec -n RANKS exe job.nml options in folder, output to log: (return code, wall time in s)."""
    start = time.perf_counter()
    with open(folder / log, "w") as out:
        done = subprocess.run(["mpiexec", "-n", str(RANKS), str(exe), "job.nml", *options], cwd=folder, env=ENV,
                              stdout=out, stderr=subprocess.STDOUT)
    return done.returncode, time.perf_counter() - start


def last_error(folder, log):
    lines = [line.strip() for line in (folder / log).read_text().splitlines() if line.strip()]
    return next((line for line in lines if "error" in line.lower()), lines[-1] if lines else "?")


def others_running(pattern):
    """PIDs of processes whose command line matches `pattern` (pgrep -f), this script and its parents excepted."""
    found = subprocess.run(["pgrep", "-f", pattern], capture_output=True, text=True).stdout.split()
    mine, pid = {os.getpid()}, os.getpid()
    while pid > 1:
        pid = int(Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[1])
        mine.add(pid)
    return [int(p) for p in found if int(p) not in mine]


def wait_while(pattern):
    """Wait, polling every 2 minutes, while another process matching `pattern` runs (a shared machine's bench);
    after a wait, go on only when two polls 2 minutes apart find none (a bench between two of its runs)."""
    waited = False
    while pattern:
        if others_running(pattern):
            waited = True
            print(f"waiting: '{pattern}' is running ({time.strftime('%H:%M')})", flush=True)
        elif not waited:
            return
        else:
            waited = False
            print(f"'{pattern}' has ended ({time.strftime('%H:%M')}); checking again in 2 minutes", flush=True)
        time.sleep(120)


def solve(exe, body, continuum, folder):
    folder.mkdir(parents=True, exist_ok=True)
    for stale in ("meta.json", "job.h5", "job.h5.continuum_checkpoint", "solved.h5"):
        (folder / stale).unlink(missing_ok=True)
    meta = dict(body=body.key, continuum=continuum, exe=str(exe), source=build_version(exe),
                date=datetime.date.today().isoformat(), bead_diameter=body.bead_diameter)
    if body.mesh is not None:
        vertices, faces = body.mesh()
        check = check_mesh(vertices, faces)
        if body.distance is not None:
            check["deviation"] = float(np.max(np.abs(body.distance(vertices[faces].mean(axis=1)))))
            check["vertex_deviation"] = float(np.max(np.abs(body.distance(vertices))))
        else:
            check["deviation"] = check["vertex_deviation"] = 0.0
        meta["mesh"] = check
        if not check["own_ok"] or (check["trimesh"] and not (check["trimesh"]["watertight"]
                                                             and check["trimesh"]["winding_consistent"])):
            meta["failed"] = f"the mesh failed its check: {check}"
            (folder / "meta.json").write_text(json.dumps(meta, indent=1))
            return meta
        write_obj(folder / "body.obj", vertices, faces)
    (folder / "job.nml").write_text("&run output = 'job.h5' /\n" + body.shape_group() + "&hydrodynamics /\n"
                                    + f"&continuum {continuum} /\n")
    meta["load_before"] = os.getloadavg()[0]
    code, wall = beadmob(exe, folder, "job.log", "-keep_checkpoint")
    meta["wall"], meta["load_after"] = wall, os.getloadavg()[0]
    if code != 0:
        meta["failed"] = last_error(folder, "job.log")
    (folder / "meta.json").write_text(json.dumps(meta, indent=1))
    return meta


def reextrapolate(exe, folder):
    """Rerun the kept job's input with its checkpoint (nothing solved); the first result kept as solved.h5."""
    meta = json.loads((folder / "meta.json").read_text())
    checkpoint = folder / "job.h5.continuum_checkpoint"
    if "failed" in meta or not checkpoint.exists():
        meta["reextrapolated"] = dict(failed="no finished job with a kept checkpoint here")
        return meta
    if not (folder / "solved.h5").exists():
        shutil.copy2(folder / "job.h5", folder / "solved.h5")
    shutil.copy2(checkpoint, folder / "checkpoint.backup")
    code, wall = beadmob(exe, folder, "reextrapolate.log", "-keep_checkpoint", "-stop_after_solves", "1")
    record = dict(exe=str(exe), source=build_version(exe), date=datetime.date.today().isoformat(), wall=wall)
    if code != 0:
        shutil.copy2(folder / "checkpoint.backup", checkpoint)       # a new key overwrote it: restore
        record["failed"] = last_error(folder, "reextrapolate.log")
        if "stopped after 1 samples" in record["failed"]:
            record["failed"] = ("this build does not take the kept checkpoint (its key of the input differs) and began "
                                "to solve: stopped after one sample, the checkpoint restored")
    (folder / "checkpoint.backup").unlink()
    meta["reextrapolated"] = record
    (folder / "meta.json").write_text(json.dumps(meta, indent=1))
    return meta


# ---- analysis -------------------------------------------------------------------------------------

def replay_check(samples):
    """continuum_bar.replay_discrepancy on the entries that do not vanish: |value| above 1e-4 of the
    largest diagonal entry. An entry that vanishes by symmetry on some lattices and not on others
    (the cross's couplings: 1e-16 at one offset, 4e-4 at another, a value of 1e-9) has level
    standard errors from 1e-16 to 1e-4, and its weighted fit differs between numpy and beadmob by
    rounding. (Largest relative difference of the replayed bars and diagonal values from the
    file's, entries compared.)"""
    worst, compared = 0.0, 0
    scale = np.nanmax(np.abs(np.diagonal(samples.sample_mobility, axis1=1, axis2=2)))   # NaN: control samples
    for row in range(6):
        for column in range(6):
            if abs(samples.mobility[row, column]) < 1e-4 * scale:
                continue
            weights = np.zeros((6, 6))
            weights[row, column] = 1.0
            try:
                value, bar, _ = combination_bar(samples, weights, entry_power(row, column))
            except np.linalg.LinAlgError:
                continue
            compared += 1
            worst = max(worst, abs(bar - samples.mobility_error[row, column])
                        / max(abs(samples.mobility_error[row, column]), 1e-300))
            if row == column:
                worst = max(worst, abs(value - samples.mobility[row, row]) / abs(samples.mobility[row, row]))
    return worst, compared


def principal_axes(path):
    """R (columns: the equivalent ellipsoid's axes, largest semi-axis first) and the semi-axes."""
    with h5py.File(path) as f:
        c = f["continuum"]
        axes = np.asarray(c["equivalent_axes"][()]).T     # h5py rows are the Fortran columns: the axes
        semi = np.asarray(c["equivalent_semi_axes"][()])
    order = np.argsort(semi)[::-1]
    return axes[:, order], semi[order]


def analyse(body, folder, result="job.h5"):
    meta_path = folder / "meta.json"
    if not meta_path.exists():
        return dict(body=body, missing=True)
    meta = json.loads(meta_path.read_text())
    row = dict(body=body, meta=meta)
    if "failed" in meta:
        return row
    path = folder / result
    samples = read_samples(path)
    rotation, semi = principal_axes(path)
    with h5py.File(path) as f:
        c = f["continuum"]
        levels = np.asarray(c.attrs["sample_level"]).reshape(-1)
        beads = np.asarray(c.attrs["sample_beads"]).reshape(-1)
        row.update(diameters=c["bead_diameters"][()], estimated=float(c.attrs["estimated_seconds"]),
                   calibration=float(c.attrs["estimate_calibration"]), converged=int(c.attrs["all_converged"]),
                   chosen_by=str(c.attrs["ladder_chosen_by"]), offsets=int(c.attrs["offsets"]),
                   volume=float(c.attrs["volume"]), volume_error=float(c.attrs["volume_standard_error"]),
                   sample_seconds=float(np.sum(c["sample_seconds"][()])), samples=len(levels))
        refit_by = f.attrs["git_hash"].decode()
    if result != "solved.h5" and (folder / "solved.h5").exists():
        # re-extrapolated (--reextrapolate): the ladder's estimate and calibration are the solve's
        with h5py.File(folder / "solved.h5") as f:
            c = f["continuum"]
            row.update(estimated=float(c.attrs["estimated_seconds"]), calibration=float(c.attrs["estimate_calibration"]),
                       refit_by=refit_by)
    row["beads"] = [float(np.mean(beads[levels == k])) for k in (1, len(row["diameters"]))]
    row["semi_axes"] = semi
    row["replay"], row["replay_entries"] = replay_check(samples)
    q = np.zeros((6, 6))
    q[:3, :3] = q[3:, 3:] = rotation
    exact = body.exact_diagonal()
    row["entries"] = []
    for i, (value, bar, fit) in enumerate(principal_diagonal(samples, rotation)):
        mean, _ = combination_level_means(samples, np.outer(q[:, i], q[:, i]))
        entry = dict(name=ENTRIES[i], value=value, bar=bar, sigma2=2 * fit.standard_error, spread=fit.model_spread,
                     volume_term=bar - fit.fit_error, chi2=getattr(fit, "plain_reduced_chi2", float("nan")), means=mean,
                     changes=(mean[-2] / mean[-3] - 1, mean[-1] / mean[-2] - 1), step=value / mean[-1] - 1)
        if exact is not None:
            entry["exact"] = exact[i]
        row["entries"].append(entry)
    return row


# ---- the tables -----------------------------------------------------------------------------------

def pct(x, digits=3):
    return f"{100 * x:.{digits}f}"


def part_name(entry):
    parts = {"2 sigma": entry["sigma2"], "spread": entry["spread"], "volume": entry["volume_term"]}
    return max(parts, key=parts.get)


def body_table(rows):
    lines = ["| body | mesh: triangles, check, deviation | bead_diameter (feature) | bead diameters coarsest - finest "
             "(feature / d) | beads coarsest - finest | samples | wall (s) | load | estimated (s), calibration | "
             "volume: beadmob +- s.e. | exact volume (mesh) | difference |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for row in rows:
        body = row["body"]
        head = f"| {body.label} |"
        if row.get("missing"):
            lines.append(head + " not run |" + " |" * 10)
            continue
        meta = row["meta"]
        mesh = meta.get("mesh")
        if mesh:
            tm = mesh["trimesh"]
            checks = ("own" + (" + trimesh " + tm["version"] if tm and tm["watertight"] and tm["winding_consistent"]
                               and tm["is_volume"] else "") if mesh["own_ok"] else "**failed**")
            mesh_text = f"{mesh['triangles']}, {checks} ok, {mesh['deviation']:.1e}"
            exact_volume = mesh["volume"]
        else:
            mesh_text = "analytic"
            exact_volume = body.smooth_volume
        if "failed" in meta:
            lines.append(head + f" {mesh_text} | failed: {meta['failed']} |" + " |" * 9)
            continue
        d = row["diameters"]
        difference = row["volume"] / exact_volume - 1
        # every fill alike (a bead diameter that divides the cross's bars): no standard error to count in
        in_errors = ("every fill alike" if row["volume_error"] <= 1e-12 * row["volume"]
                     else f"{difference * exact_volume / row['volume_error']:+.1f} s.e.")
        lines.append(f"{head} {mesh_text} | {body.bead_diameter:.4g} ({body.feature}) | {d[0]:.4f} - {d[-1]:.4f} "
                     f"({body.feature_size / d[0]:.1f} - {body.feature_size / d[-1]:.1f}) | "
                     f"{row['beads'][0]:.0f} - {row['beads'][1]:.0f} | {row['samples']} | {meta['wall']:.0f} | "
                     f"{meta.get('load_before', float('nan')):.1f}, {meta.get('load_after', float('nan')):.1f} | "
                     f"{row['estimated']:.0f}, {row['calibration']:.2f} | {row['volume']:.6f} +- "
                     f"{row['volume_error']:.1e} | {exact_volume:.6f} | {pct(difference)} % "
                     f"({in_errors}) |")
    return "\n".join(lines)


def entry_table(rows, before=None):
    head = ("| body | entry | value | bar % | 2 sigma % | model spread % | volume term % | largest part | chi2/dof | "
            "level means: 3rd -> 2nd finest, 2nd -> finest % | finest -> continuum % |")
    if any(row.get("entries") and "exact" in row["entries"][0] for row in rows):
        head += " error vs exact % |"
    if before:
        head += " change since the solved run (/ bar) |"
    lines = [head, "|" + "---|" * head.count(" |")]
    for row in rows:
        if "entries" not in row:
            continue
        for k, e in enumerate(row["entries"]):
            v = abs(e["value"])
            line = (f"| {row['body'].label if k == 0 else ''} | {e['name']} | {e['value']:.6g} | {pct(e['bar'] / v)} | "
                    f"{pct(e['sigma2'] / v)} | {pct(e['spread'] / v)} | {pct(e['volume_term'] / v)} | {part_name(e)} | "
                    f"{e['chi2']:.2f} | "
                    f"{pct(e['changes'][0])}, {pct(e['changes'][1])} | {pct(e['step'])} |")
            if "exact" in e:
                miss = abs(e["value"] - e["exact"]) > e["bar"]
                line += f" {pct(e['value'] / e['exact'] - 1)}" + (" **miss** |" if miss else " |")
            elif "error vs exact" in head:
                line += " |"
            if before:
                old = before.get(row["body"].key)
                line += (f" {(e['value'] - old[k]['value']) / e['bar']:+.2e} |" if old else " - |")
            lines.append(line)
    return "\n".join(lines)


def summary_table(rows):
    lines = ["| body | translation bars % (t_a, t_b, t_c) | rotation bars % (r_a, r_b, r_c) | "
             "parts / bar, median over the six (2 sigma / spread / volume) | largest part (entries) | "
             "largest level-mean change, last step % (t / r) | largest error against the exact value % (t / r) |",
             "|---|---|---|---|---|---|---|"]
    for row in rows:
        if "entries" not in row:
            continue
        e = row["entries"]
        bars = [100 * x["bar"] / abs(x["value"]) for x in e]
        share = [np.median([x[k] / x["bar"] for x in e]) for k in ("sigma2", "spread", "volume_term")]
        largest = [part_name(x) for x in e]
        largest = ", ".join(f"{name} {largest.count(name)}" for name in ("2 sigma", "spread", "volume")
                            if largest.count(name))
        last = [max(abs(x["changes"][1]) for x in e[:3]), max(abs(x["changes"][1]) for x in e[3:])]
        lines.append(f"| {row['body'].label} | {', '.join(f'{b:.2f}' for b in bars[:3])} | "
                     f"{', '.join(f'{b:.2f}' for b in bars[3:])} | "
                     f"{' / '.join(f'{s:.2f}' for s in share)} | {largest} | {pct(last[0], 2)} / {pct(last[1], 2)} | "
                     + (" / ".join(pct(max(abs(x["value"] / x["exact"] - 1) for x in group), 2) for group in (e[:3], e[3:]))
                        if "exact" in e[0] else "-") + " |")
    return "\n".join(lines)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--exe", default=str(ROOT / "build" / "beadmob"))
    parser.add_argument("--budget", type=float, default=600.0)
    parser.add_argument("--bodies", default=",".join(b.key for b in BODIES))
    parser.add_argument("--continuum", default=None, help="the &continuum group's contents (default: time_budget)")
    parser.add_argument("--keep", default=str(HERE / "nonconvex_runs"))
    parser.add_argument("--reuse", default=None, help="analyse the jobs kept in this folder, solve nothing")
    parser.add_argument("--reextrapolate", default=None, help="rerun the kept jobs' inputs on their checkpoints")
    parser.add_argument("--out", default=None)
    parser.add_argument("--wait-while", default=None, metavar="PATTERN",
                        help="before each job, wait (polling every 2 min) while `pgrep -f PATTERN` finds another process")
    parser.add_argument("--list", action="store_true", help="make and check the meshes, print them and stop")
    arguments = parser.parse_args()
    keys = arguments.bodies.split(",")
    unknown = [k for k in keys if k not in {b.key for b in BODIES}]
    if unknown:
        parser.error(f"unknown bodies: {', '.join(unknown)} (bodies: {', '.join(b.key for b in BODIES)})")
    selected = [b for b in BODIES if b.key in keys]
    if arguments.list:
        for body in selected:
            if body.mesh is None:
                print(body.key, "analytic", body.shape_group().strip())
                continue
            vertices, faces = body.mesh()
            check = check_mesh(vertices, faces)
            if body.distance is not None:
                check["deviation"] = float(np.max(np.abs(body.distance(vertices[faces].mean(axis=1)))))
            print(body.key, "bead_diameter", body.bead_diameter, "smooth volume", body.smooth_volume, check)
        return
    exe = Path(arguments.exe).resolve()
    keep = Path(arguments.reextrapolate or arguments.reuse or arguments.keep)
    continuum = arguments.continuum or f"time_budget = {arguments.budget:g}"
    rows, before = [], {}
    for body in selected:
        folder = keep / body.key
        if arguments.reextrapolate:
            meta = reextrapolate(exe, folder) if (folder / "meta.json").exists() else {}
            state = meta.get("reextrapolated", {"failed": "not run"})
            print(f"{body.key}: re-extrapolated: " + (f"failed: {state['failed']}" if "failed" in state
                                                     else f"{state['wall']:.1f} s"), flush=True)
            if (folder / "solved.h5").exists():
                solved = analyse(body, folder, "solved.h5")
                if "entries" in solved:
                    before[body.key] = solved["entries"]
        elif not arguments.reuse:
            wait_while(arguments.wait_while)
            meta = solve(exe, body, continuum, folder)
            print(f"{body.key}: " + (f"failed: {meta['failed']}" if "failed" in meta else f"{meta['wall']:.0f} s"),
                  flush=True)
        rows.append(analyse(body, folder))

    metas = [row["meta"] for row in rows if "meta" in row]
    command = "bench/continuum/nonconvex.py"
    if arguments.bodies != parser.get_default("bodies"):
        command += f" --bodies {arguments.bodies}"
    settings = sorted({m["continuum"] for m in metas})
    if len(settings) == 1 and settings[0].startswith("time_budget = ") and "," not in settings[0]:
        if settings[0] != "time_budget = 600":
            command += f" --budget {settings[0].split('=')[1].strip()}"
    elif settings:
        command += f" --continuum '{'; '.join(settings)}'"
    dates = sorted({m["date"] for m in metas})
    sources = sorted({m["source"] for m in metas})
    title = "# Continuum jobs on non-convex, non-ellipsoidal meshes"
    how = (f"Written by `{command}" + (f" --reuse {arguments.reuse}`" if arguments.reuse else "`")
           + f" on {datetime.date.today().isoformat()} (2 ranks, this machine; jobs solved {', '.join(dates)} with the "
           f"build of {', '.join(sources)}; each with `-keep_checkpoint`"
           + (f"; the extrapolations redone from the kept checkpoints (no solve, --reextrapolate) by the build of "
              f"{', '.join(sorted({row['refit_by'][:12] for row in rows if 'refit_by' in row}))}"
              if any("refit_by" in row for row in rows) else "") + ").")
    if arguments.reextrapolate:
        title += ": re-extrapolated from the kept checkpoints"
        rebuilt = sorted({m["reextrapolated"].get("source", "?") for m in metas if "reextrapolated" in m})
        how += (f" Re-extrapolated by `bench/continuum/nonconvex.py --reextrapolate {arguments.reextrapolate}` with the "
                f"build of {', '.join(rebuilt)}: the same samples, this build's estimate; the last column is the change "
                f"of the value since the solved run, in units of this bar.")
    failed = [(row["body"].label, row["meta"]["reextrapolated"]["failed"]) for row in rows
              if "reextrapolated" in row.get("meta", {}) and "failed" in row["meta"]["reextrapolated"]]
    if failed:
        how += " Not re-extrapolated (their rows are the kept result's): " + "; ".join(
            f"{label}: {message}" for label, message in failed) + "."
    done = [row for row in rows if "entries" in row]
    replay = max((row["replay"] for row in done), default=float("nan"))
    paragraphs = __doc__.split("\n\n")
    text = (f"{title}\n\n{how}\n\n" + "\n\n".join(paragraphs[1:7])
            + "\n\n## Summary\n\nBars relative to the value (%); each part of the bar over the bar, the median over "
              "the six entries (2 sigma and the spread combine by the estimator's fit_error, so the three need not sum "
              "to 1); which part is the largest, counted over the six entries; the largest relative change between "
              "the two finest levels' means over the three translation (t) and the three rotation (r) entries; for "
              "the ellipsoid, the largest error against its exact mobility.\n\n" + summary_table(rows)
            + "\n\n## Per body\n\n`feature / d`: the smallest feature in bead diameters at the coarsest and the finest "
              "level; beads: the mean over the level's offsets; `wall`: the whole job; `load`: the machine's 1-minute "
              "load average (2 cores) when the job started and ended; `calibration`: the pilot solve's factor on the "
              "dry run's estimates, which chose the ladder (a loaded machine makes it larger and the ladder coarser); "
              "`difference`: beadmob's volume "
              "(the moment fills at the finest level; a mesh's polyhedron's since 2026-11-29) against the mesh's exact "
              "polyhedral volume (the analytic "
              "ellipsoid's: 4 pi abc / 3), relative and in units of beadmob's standard error.\n\n" + body_table(rows)
            + "\n\n## Per entry\n\nIn the principal frame (the equivalent ellipsoid's axes, a >= b >= c); value in the "
              "body's unit (viscosity 1); the bar and its parts relative to the value; the level means' relative "
              "changes over the three finest levels, and the step from the finest level's mean to the continuum "
              f"value. The replayed estimator (continuum_bar.py) gives each job's own bars and diagonal values "
              f"within {replay:.1e} (relative; over the {min((row['replay_entries'] for row in done), default=0)} or "
              f"more of the 36 entries per job that do not vanish: |value| above 1e-4 of the largest diagonal "
              f"entry).\n\n" + entry_table(rows, before) + "\n")
    out = Path(arguments.out or HERE / ("nonconvex_reextrapolated.md" if arguments.reextrapolate else "nonconvex.md"))
    if out.exists() and "\n## Reading" in out.read_text():
        text += "\n## Reading" + out.read_text().split("\n## Reading", 1)[1]
    out.write_text(text)
    print(f"written {out}")


if __name__ == "__main__":
    main()
