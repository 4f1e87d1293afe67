#!/usr/bin/env python3
"""pygrpy beside beadmob (bench/offlattice/offlattice.md): the RPY rigid-body mobility of a bead model.

The Rotne-Prager-Yamakawa (RPY) approximation (Rotne & Prager, J. Chem. Phys. 50, 4831 (1969);
Yamakawa, J. Chem. Phys. 53, 436 (1970); rotational blocks: Wajnryb, Mizerski, Zuk & Szymczak,
J. Fluid Mech. 731, R3 (2013)) gives the 6N x 6N grand mobility of N spheres (forces and torques
-> translational and angular velocities). The rigid-body friction about a point x0 is
    zeta = K^T M^-1 K,   K: (U, Omega) -> bead velocities U + Omega x (x_i - x0) and Omega,
and the rigid-body mobility its inverse. beadmob at multipole order L = 1 computes exactly this
(docs/theory.md T7), so beadmob L = 1 against pygrpy measures beadmob's operator error alone.

Units (the same as beadmob's result file): viscosity eta = 1, lengths in bead diameters d, bead
radius a = 0.5; reference point the centroid of the bead centres (beadmob's centre of mass).
The 6x6 mobility reads rows (U, Omega), columns (F, T); single sphere: 1/(6 pi eta a) = 1/(3 pi)
and 1/(8 pi eta a^3) = 1/pi.

pygrpy 0.1.5 (pip install pygrpy; https://github.com/RadostW/PyGRPY) is called as
    pygrpy.grpy_tensors.conglomerateMobilityMatrix(centres - centroid, np.full(N, 0.5))
which builds the 6N x 6N grand mobility `mu` with a Python double loop over bead pairs, inverts it
with LAPACK (dpotrf/dpotri), forms p^T M^-1 p and inverts that: eta = 1 implicitly, radii in the
units of the centres, mobility about the origin of the coordinates given (hence the shift).

Subcommands:
  check            single sphere and two touching beads against closed-form RPY values, and
                   the 200-bead models of bench/offlattice/offlattice.py against this file's own dense numpy
                   implementation (rpy_rigid_friction), to ~1e-10 relative
  time FILE ...    pygrpy on bead files (text, "x y z" in d), each in its own subprocess: wall
                   time of the whole call and of its parts (grand mobility build, the 6N x 6N
                   inverse), peak resident memory (getrusage); rows appended to --csv
  estimate N ...   pygrpy time and memory at N beads from the measured rows of --csv (build ~ N^2,
                   inverse ~ N^3, memory ~ N^2)

usage: python3 bench/offlattice/offlattice_pygrpy.py check
       OPENBLAS_NUM_THREADS=1 python3 bench/offlattice/offlattice_pygrpy.py time FILE.txt [...] [--csv C]
       python3 bench/offlattice/offlattice_pygrpy.py estimate 5000 20000 [--csv C]
"""
import argparse
import csv
import json
import math
import os
import resource
import subprocess
import sys
import time

import numpy as np
import scipy.linalg

HERE = os.path.dirname(os.path.abspath(__file__))   # this study's folder: bench/<study>/
ROOT = os.path.dirname(os.path.dirname(HERE))
TIMES_CSV = os.path.join(HERE, "offlattice_runs", "pygrpy_times.csv")
RADIUS = 0.5


# ----------------------------------------------------------------------------------------------
# pygrpy
def pygrpy_mobility(centres, radius=RADIUS):
    """6x6 RPY rigid-body mobility about the centroid by pygrpy, and the wall seconds of the call.

    centres: (N, 3) bead centres in bead diameters; radius: bead radius in the same units.
    Returns (mobility, seconds): rows (U, Omega), columns (F, T), eta = 1.
    """
    import pygrpy.grpy_tensors as tensors
    centres = np.asarray(centres, float)
    shifted = centres - centres.mean(axis=0)
    start = time.perf_counter()
    mobility = tensors.conglomerateMobilityMatrix(shifted, np.full(len(centres), radius))
    return mobility, time.perf_counter() - start


def pygrpy_friction(centres, radius=RADIUS):
    mobility, seconds = pygrpy_mobility(centres, radius)
    return np.linalg.inv(mobility), seconds


# ----------------------------------------------------------------------------------------------
# Own dense implementation (independent of pygrpy: bead-major ordering, vectorised blocks)
def cross_matrix(v):
    """[v]_x with [v]_x w = v x w; v (..., 3)."""
    v = np.asarray(v, float)
    out = np.zeros(v.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out


def rpy_grand_mobility(centres, a=RADIUS, rotations=True):
    """Dense RPY grand mobility of equal spheres (eta = 1), non-overlapping (r >= 2a).

    rotations=True: 6N x 6N, per bead (F, T) -> (U, Omega), bead-major: rows 6i..6i+5 = (U_i, Omega_i).
    rotations=False: 3N x 3N translational blocks only (point forces, no bead torques).
    Blocks for r = x_i - x_j, e = r/|r| (docs/theory.md T7):
      mu_tt = [(1 + 2a^2/(3r^2)) I + (1 - 2a^2/r^2) e e] / (8 pi r),   self 1/(6 pi a) I
      mu_rr = (3 e e - I) / (16 pi r^3),                               self 1/(8 pi a^3) I
      Omega_i from F_j: F_j x e / (8 pi r^2);  U_i from T_j: T_j x e / (8 pi r^2)
    """
    x = np.asarray(centres, float)
    n = len(x)
    r_vec = x[:, None, :] - x[None, :, :]
    r = np.linalg.norm(r_vec, axis=-1)
    off = ~np.eye(n, dtype=bool)
    if off.any() and r[off].min() < 2 * a * (1 - 1e-9):
        raise ValueError(f"overlapping beads: closest centres {r[off].min()} < 2a = {2 * a}")
    r_safe = np.where(off, r, 1.0)
    e = r_vec / r_safe[..., None]
    eye = np.eye(3)
    ee = e[..., :, None] * e[..., None, :]
    tt = ((1 + 2 * a * a / (3 * r_safe**2))[..., None, None] * eye
          + (1 - 2 * a * a / r_safe**2)[..., None, None] * ee) / (8 * np.pi * r_safe[..., None, None])
    tt[~off] = eye / (6 * np.pi * a)
    if not rotations:
        return tt.transpose(0, 2, 1, 3).reshape(3 * n, 3 * n)
    rr = (3 * ee - eye) / (16 * np.pi * r_safe[..., None, None]**3)
    rr[~off] = eye / (8 * np.pi * a**3)
    # F x e = -[e]_x F: Omega_i = -[e]_x F_j / (8 pi r^2), and U_i = -[e]_x T_j / (8 pi r^2)
    rt = -cross_matrix(e) / (8 * np.pi * r_safe[..., None, None]**2)
    rt[~off] = 0.0
    grand = np.zeros((n, 6, n, 6))
    grand[:, 0:3, :, 0:3] = tt.transpose(0, 2, 1, 3)
    grand[:, 3:6, :, 3:6] = rr.transpose(0, 2, 1, 3)
    grand[:, 3:6, :, 0:3] = rt.transpose(0, 2, 1, 3)    # Omega_i from F_j
    grand[:, 0:3, :, 3:6] = rt.transpose(0, 2, 1, 3)    # U_i from T_j (same block, symmetric M)
    return grand.reshape(6 * n, 6 * n)


def rigid_motion_matrix(centres, reference, rotations=True):
    """K: (U, Omega) of the body about `reference` -> bead (U_i[, Omega_i]), bead-major."""
    d = np.asarray(centres, float) - reference
    n = len(d)
    per = 6 if rotations else 3
    k = np.zeros((n, per, 6))
    k[:, 0:3, 0:3] = np.eye(3)
    k[:, 0:3, 3:6] = -cross_matrix(d)          # Omega x d = -[d]_x Omega
    if rotations:
        k[:, 3:6, 3:6] = np.eye(3)
    return k.reshape(per * n, 6)


def rpy_rigid_friction(centres, a=RADIUS, rotations=True):
    """6x6 RPY rigid-body friction about the centroid: K^T M^-1 K (Cholesky of M). eta = 1."""
    centres = np.asarray(centres, float)
    k = rigid_motion_matrix(centres, centres.mean(axis=0), rotations)
    factor = scipy.linalg.cho_factor(rpy_grand_mobility(centres, a, rotations))
    return k.T @ scipy.linalg.cho_solve(factor, k)


def scaled_difference(a, b):
    """Largest |a - b| entry on the scale sqrt(b_ii b_jj) (the measure of docs/theory.md T14)."""
    d = np.abs(np.diag(b))
    return float(np.max(np.abs(a - b) / np.sqrt(np.outer(d, d))))


# ----------------------------------------------------------------------------------------------
# Closed-form RPY values (derived in `check`, eta = 1)
def touching_pair_mobility():
    """6x6 RPY rigid-body mobility of two touching spheres of radius 1/2 on the x axis (centres
    -1/2 and +1/2), about their midpoint; r = 2a = 1, mu0 = 1/(6 pi a) = 1/(3 pi), mu_rr self = 1/pi.

    - translation along the axis: no bead torques (e x F = 0), U = (mu0 + mu_tt,par) F with
      mu_tt,par = (1 + 1/6 + 1/2)/(8 pi) = 5/(24 pi): friction 2 (24 pi/13), mobility 13/(48 pi);
    - translation across (y): bead forces F, torques +-T z (mirror x -> -x), Omega_i = 0:
      T (1/pi + 1/(16 pi)) + F/(8 pi) = 0 -> T = -2F/17; U = F (1/3 + 7/48 - 1/68)/pi = 379 F/(816 pi);
      total force 2F: mobility 379/(1632 pi);
    - rotation about the axis: forces 0, Omega = T (1/pi + 2/(16 pi)) = 9T/(8 pi); total 2T:
      mobility 9/(16 pi);
    - rotation across (z): bead velocities -+Omega/2 y, forces -+F y, torques T z:
      3F + 2T = 8 pi Omega, 2F + 15T = 16 pi Omega -> T = 32 pi Omega/41, F = 88 pi Omega/41;
      torque about the midpoint 2T + F = 152 pi Omega/41: mobility 41/(152 pi).
    The coupling block vanishes (centre of symmetry at the midpoint).
    """
    diag = np.array([13 / 48, 379 / 1632, 379 / 1632, 9 / 16, 41 / 152, 41 / 152]) / np.pi
    return np.diag(diag)


def check():
    rows = []
    sphere, _ = pygrpy_mobility(np.zeros((1, 3)))
    expect = np.diag([1 / (3 * np.pi)] * 3 + [1 / np.pi] * 3)
    rows.append(("single sphere: pygrpy vs 1/(6 pi a), 1/(8 pi a^3)", scaled_difference(sphere, expect)))
    mine = np.linalg.inv(rpy_rigid_friction(np.zeros((1, 3))))
    rows.append(("single sphere: own vs closed form", scaled_difference(mine, expect)))
    pair = np.array([[-0.5, 0, 0], [0.5, 0, 0]])
    expect = touching_pair_mobility()
    rows.append(("touching pair: pygrpy vs closed form", scaled_difference(pygrpy_mobility(pair)[0], expect)))
    rows.append(("touching pair: own vs closed form",
                 scaled_difference(np.linalg.inv(rpy_rigid_friction(pair)), expect)))
    # the same pair turned and shifted: pygrpy must follow R M R^T (tests the centroid shift too)
    from offlattice import rotation
    q = rotation((1, 2, 3), 30)
    turned = pair @ q.T + np.array([3.0, -1.0, 2.0])
    big_q = np.kron(np.eye(2), q)
    rows.append(("touching pair turned and shifted: pygrpy vs R M R^T",
                 scaled_difference(pygrpy_mobility(turned)[0], big_q @ expect @ big_q.T)))
    print("closed-form checks (largest entry difference on the scale sqrt(M_ii M_jj)):")
    for label, value in rows:
        print(f"  {label}: {value:.2e}")
    worst = max(v for _, v in rows)
    import offlattice   # the benchmark's models, at 200 beads
    os.makedirs(offlattice.WORK, exist_ok=True)
    for kind in ("jittered", "shell", "cone"):
        x = getattr(offlattice, kind)(200)
        zeta_pygrpy, seconds = pygrpy_friction(x)
        start = time.perf_counter()
        zeta_own = rpy_rigid_friction(x)
        own_seconds = time.perf_counter() - start
        zeta_trans = rpy_rigid_friction(x, rotations=False)
        diff = scaled_difference(zeta_own, zeta_pygrpy)
        worst = max(worst, diff)
        print(f"  {kind}_200 ({len(x)} beads): friction own 6N vs pygrpy {diff:.2e} (pygrpy {seconds:.2f} s, "
              f"own {own_seconds:.2f} s); translation-only 3N model vs pygrpy "
              f"{scaled_difference(zeta_trans, zeta_pygrpy):.2e} (a different model: no bead torques)")
    print(f"worst of the checks: {worst:.2e}", "(pass)" if worst < 1e-10 else "(FAIL: above 1e-10)")
    return 0 if worst < 1e-10 else 1


# ----------------------------------------------------------------------------------------------
# Timing
def time_one(path):
    """pygrpy on one bead file, in this process: wall seconds of the whole call and of its parts."""
    import pygrpy
    import pygrpy.grpy_tensors as tensors
    parts = {"build": 0.0, "inverse": 0.0}
    build, inverse = tensors.mu, tensors._lapackinv

    def timed(function, part):
        def wrapper(*args, **kwargs):
            start = time.perf_counter()
            try:
                return function(*args, **kwargs)
            finally:
                parts[part] += time.perf_counter() - start
        return wrapper

    tensors.mu, tensors._lapackinv = timed(build, "build"), timed(inverse, "inverse")
    x = np.loadtxt(path)
    mobility, seconds = pygrpy_mobility(x)
    try:
        from threadpoolctl import threadpool_info
        threads = [p.get("num_threads") for p in threadpool_info() if p.get("user_api") == "blas"]
    except ImportError:
        threads = os.environ.get("OPENBLAS_NUM_THREADS", "default")
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    return {"file": os.path.basename(path), "beads": len(x), "seconds": round(seconds, 3),
            "build_seconds": round(parts["build"], 3), "inverse_seconds": round(parts["inverse"], 3),
            "peak_rss_gib": round(peak / 2**30, 3), "pygrpy": getattr(pygrpy, "__version__", "0.1.5"),
            "numpy": np.__version__, "blas_threads": str(threads),
            "mobility_trace_tt": float(np.trace(mobility[:3, :3])), "when": time.strftime("%Y-%m-%d %H:%M")}


def time_files(paths, out_csv):
    rows = []
    for path in paths:
        out = subprocess.run([sys.executable, os.path.abspath(__file__), "_time_one", path],
                             capture_output=True, text=True, check=True)
        row = json.loads(out.stdout.strip().splitlines()[-1])
        print(row, flush=True)
        rows.append(row)
    new = not os.path.exists(out_csv)
    os.makedirs(os.path.dirname(out_csv), exist_ok=True)
    with open(out_csv, "a", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        if new:
            writer.writeheader()
        writer.writerows(rows)


def estimate(sizes, in_csv):
    """Extrapolate from the largest measured run: build ~ N^2, inverse ~ N^3, memory ~ N^2."""
    with open(in_csv) as f:
        rows = list(csv.DictReader(f))
    ref = max(rows, key=lambda r: int(r["beads"]))
    n0 = int(ref["beads"])
    for n in sizes:
        s = n / n0
        build, inverse = float(ref["build_seconds"]) * s**2, float(ref["inverse_seconds"]) * s**3
        rest = (float(ref["seconds"]) - float(ref["build_seconds"]) - float(ref["inverse_seconds"])) * s**2
        print(f"{n} beads (from {ref['file']}, {n0} beads): ~{(build + inverse + rest) / 60:.1f} min "
              f"(build {build / 60:.1f} min, inverse {inverse / 60:.1f} min), peak memory "
              f"~{float(ref['peak_rss_gib']) * s**2:.1f} GiB (grand mobility alone {(6 * n)**2 * 8 / 2**30:.1f} GiB)")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("check")
    p = sub.add_parser("time")
    p.add_argument("files", nargs="+")
    p.add_argument("--csv", default=TIMES_CSV)
    p = sub.add_parser("estimate")
    p.add_argument("sizes", nargs="+", type=int)
    p.add_argument("--csv", default=TIMES_CSV)
    p = sub.add_parser("_time_one")
    p.add_argument("file")
    args = parser.parse_args()
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    if args.command == "check":
        return check()
    if args.command == "time":
        return time_files(args.files, args.csv)
    if args.command == "estimate":
        return estimate(args.sizes, args.csv)
    print(json.dumps(time_one(args.file)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
