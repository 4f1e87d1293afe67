#!/usr/bin/env python3
"""check_operator_accuracy.py BEADMOB MPIEXEC RANKS WORKDIR accuracy|error: the pfft operator's far
field (docs/theory.md T16) against what a run asks for and what it states.

accuracy: a run asks its operator for the accuracy of its Krylov tolerance (job_plan.f90,
choose_operator). 300 jittered beads at L = 1 (the RPY level, docs/theory.md T7), no lubrication,
the full model, krylov_rtol = 1e-11, `-operator auto`: the pfft far field at its default near
radius (about 3e-5 of the largest mobility entry here) would not give it, so the job gets an
operator that does, and its mobility must equal an independent RPY rigid-body mobility (a dense
numpy code below: the 6N x 6N grand mobility with rotations, Rotne & Prager 1969, Wajnryb et al.
2013, its inverse contracted with the rigid motions) within 1e-8 of the largest entry, or the run's
own bound (operator_error and the solver's) must cover the difference. The numpy code itself is
checked first against beadmob's direct operator on 30 beads (2e-15 measured; 1e-12 here). At the
default tolerance the dry run keeps the pfft operator at its default near radius 3 d (a default
run keeps its speed), and at 1e-11 it names the operator and why.

error: every pfft run measures its far field's error and records it (operator_error, relative to
the largest body-frame mobility entry, and its bound entry by entry). A jittered cluster of 200
beads at L = 2 with the pfft operator at near radius 3 d and with the direct operator, both at
tolerance 1e-9: the recorded bound covers the difference of every entry of the body-frame mobility
(the direct run's mobility turned into the pfft run's body frame) and the error bar
(estimated_error) holds the operator's part on top of the truncation's; the direct run records 0.
"""
import os
import re
import subprocess
import sys

import h5py
import numpy as np

beadmob, mpiexec, ranks, workdir, mode = sys.argv[1:6]
os.makedirs(workdir, exist_ok=True)
failures = []


def check(ok, message):
    print(("ok: " if ok else "FAILED: ") + message)
    if not ok:
        failures.append(message)


def jittered(n, seed=1):
    """The n lattice points nearest a centre, scaled by 1.1 and shifted by up to 0.04 d per
    coordinate (as bench/offlattice/offlattice.py)."""
    g = np.arange(-8, 9)
    points = np.array(np.meshgrid(g, g, g, indexing="ij")).reshape(3, -1).T.astype(float)
    points = points[np.argsort((points**2).sum(1), kind="stable")][:n]
    return 1.1 * points + np.random.default_rng(seed).uniform(-0.04, 0.04, (n, 3))


def run(name, points, hydro, *options):
    np.savetxt(os.path.join(workdir, f"{name}.txt"), points)
    nml = os.path.join(workdir, f"{name}.nml")
    with open(nml, "w") as f:
        f.write(f"&run output = '{name}.h5' /\n&shape name = 'bead_file', file = '{name}.txt' /\n"
                f"&hydrodynamics {hydro} /\n")
    done = subprocess.run([mpiexec, "-n", ranks, beadmob, nml, "-quiet", *options], cwd=workdir,
                          capture_output=True, text=True)
    if done.returncode != 0:
        print(done.stdout[-3000:], done.stderr[-3000:])
    check(done.returncode == 0, f"{name}: beadmob {' '.join(options)} ran")
    return done


def hydrodynamics(name):
    return h5py.File(os.path.join(workdir, f"{name}.h5"), "r")["hydrodynamics"]


def rpy_friction(points):
    """The 6x6 rigid-body friction about the centroid at the RPY level with bead rotations (radius
    1/2, viscosity 1): zeta = K^T M^-1 K, M the 6N x 6N grand mobility (force and torque to velocity
    and angular velocity; docs/theory.md T7's blocks, written here independently)."""
    a = 0.5
    n = len(points)
    mobility = np.zeros((6 * n, 6 * n))
    eye = np.eye(3)
    for i in range(n):
        mobility[6 * i:6 * i + 3, 6 * i:6 * i + 3] = eye / (6 * np.pi * a)
        mobility[6 * i + 3:6 * i + 6, 6 * i + 3:6 * i + 6] = eye / (8 * np.pi * a**3)
        for j in range(n):
            if i == j:
                continue
            r = points[i] - points[j]
            d = np.linalg.norm(r)
            e = r / d
            ee = np.outer(e, e)
            cross = np.array([[0, -e[2], e[1]], [e[2], 0, -e[0]], [-e[1], e[0], 0]])
            tt = ((1 + 2 * a * a / (3 * d * d)) * eye + (1 - 2 * a * a / (d * d)) * ee) / (8 * np.pi * d)
            rr = (3 * ee - eye) / (16 * np.pi * d**3)
            rt = -cross / (8 * np.pi * d * d)   # angular velocity of i from the force on j, and the converse
            mobility[6 * i:6 * i + 3, 6 * j:6 * j + 3] = tt
            mobility[6 * i + 3:6 * i + 6, 6 * j + 3:6 * j + 6] = rr
            mobility[6 * i + 3:6 * i + 6, 6 * j:6 * j + 3] = rt
            mobility[6 * i:6 * i + 3, 6 * j + 3:6 * j + 6] = rt
    arm = points - points.mean(axis=0)
    k = np.zeros((6 * n, 6))
    for axis in range(3):
        unit = np.zeros(3)
        unit[axis] = 1.0
        k[6 * np.arange(n) + axis, axis] = 1.0
        k[6 * np.arange(n)[:, None] + np.arange(3), 3 + axis] = np.cross(unit, arm)
        k[6 * np.arange(n) + 3 + axis, 3 + axis] = 1.0
    return k.T @ np.linalg.solve(mobility, k)


def solver_allowance(*runs):
    """The mobility's solver error relative to its largest entry, from the runs' bounds (theory.md
    T5) as tests/e2e/compare_result_files.py derives it: 1.1 x 36 b cond(zeta)."""
    b = sum(max(float(np.max(h.attrs["solver_error_bound"])), 0.0) for h in runs)
    return 1.1 * 36 * b * np.linalg.cond(runs[0]["friction"][()])


def largest_relative(a, b):
    return float(np.abs(a - b).max() / np.abs(b).max())


if mode == "accuracy":
    # The independent code against beadmob's exact (direct) operator on 30 beads.
    small = jittered(30)
    run("rpy_30", small, "multipole_order = 1, shell_layers = 0, krylov_rtol = 1e-12", "-operator", "direct")
    difference = largest_relative(hydrodynamics("rpy_30")["friction"][()], rpy_friction(small))
    check(difference <= 1e-12, f"30 beads, direct operator: friction = the numpy RPY code's to {difference:.1e}")

    beads = jittered(300)
    # The dry run: at the default tolerance the pfft operator at 3 d; at 1e-11 another operator.
    default = run("dry_default", beads, "multipole_order = 1, shell_layers = 0", "-estimate").stdout
    operator = re.search(r"operator:\s+(\w+)", default).group(1)
    radius = re.search(r"pfft near radius:\s+([0-9.]+) d", default)
    check(operator == "pfft" and radius is not None and float(radius.group(1)) == 3.0,
          f"300 beads at the default tolerance: the dry run keeps the pfft operator at 3 d (got {operator}, "
          f"{radius.group(1) if radius else 'no radius'})")
    tight = run("dry_tight", beads, "multipole_order = 1, shell_layers = 0, krylov_rtol = 1e-11", "-estimate").stdout
    chosen = re.search(r"chosen:\s+(.*)", tight)
    check(chosen is not None and "1e-11" in chosen.group(1),
          f"at 1e-11 the dry run says why: {chosen.group(1) if chosen else 'no chosen line'}")

    run("rpy_300", beads, "multipole_order = 1, shell_layers = 0, lubrication = .false., krylov_rtol = 1e-11")
    h = hydrodynamics("rpy_300")
    name = h.attrs["operator"].decode() if isinstance(h.attrs["operator"], bytes) else str(h.attrs["operator"])
    reference = rpy_friction(beads)
    friction_difference = largest_relative(h["friction"][()], reference)
    mobility_difference = largest_relative(h["mobility"][()], np.linalg.inv(reference))
    covered = float(h.attrs["operator_error"]) + solver_allowance(h)
    print(f"300 beads at 1e-11: operator {name} (near radius {h.attrs['pfft_near_radius']}), friction "
          f"{friction_difference:.1e}, mobility {mobility_difference:.1e} from the numpy RPY code; operator_error "
          f"{h.attrs['operator_error']:.1e}")
    check(max(friction_difference, mobility_difference) <= 1e-8 or mobility_difference <= covered,
          f"300 beads at krylov_rtol 1e-11 ({name}): within 1e-8 of the exact RPY mobility, or within its own bound")
    check(name != "pfft" or float(h.attrs["pfft_near_radius"]) > 3.0,
          "300 beads at 1e-11: not the pfft operator at its default near radius")
else:
    beads = jittered(200, seed=3)
    hydro = "multipole_order = 2, shell_layers = 0, krylov_rtol = 1e-9"
    run("far_pfft", beads, hydro, "-operator", "pfft", "-pfft_near_radius", "3")
    run("far_direct", beads, hydro, "-operator", "direct")
    p, d = hydrodynamics("far_pfft"), hydrodynamics("far_direct")
    check(float(d.attrs["operator_error"]) == 0.0, "direct operator: operator_error 0")
    error = float(p.attrs["operator_error"])
    method = p.attrs["operator_error_method"]
    method = method.decode() if isinstance(method, bytes) else str(method)
    check(error > 0 and "rows" in method, f"pfft operator: operator_error recorded ({error:.2e}; {method})")
    # The direct run's mobility in the pfft run's body frame (row k of body_axes: axis k).
    axes = p["body_axes"][()]
    turn = np.zeros((6, 6))
    turn[:3, :3] = axes
    turn[3:, 3:] = axes
    exact = turn @ d["mobility"][()] @ turn.T
    approximate = p["body_mobility"][()]
    bound = p["operator_body_mobility_error"][()]
    solver = solver_allowance(p, d) * np.abs(approximate).max()
    true = np.abs(approximate - exact)
    check(np.all(bound + solver >= true),
          f"the bound covers all 36 entries of the body-frame mobility (largest true {true.max():.2e}, largest bound "
          f"{bound.max():.2e}, ratio {bound.max() / true.max():.2f})")
    relative = true.max() / np.abs(exact).max()
    check(error >= relative, f"operator_error {error:.2e} >= the largest true difference {relative:.2e} "
          "(relative to the largest entry)")
    scaled = p["scaled_body_mobility_error"][()]
    truncation = float(p.attrs["truncation_estimated_error"])
    check(abs(float(p.attrs["estimated_error"]) - scaled.max()) <= 1e-12 * scaled.max() and
          float(p.attrs["estimated_error"]) > truncation and
          np.all(scaled >= p["scaled_operator_body_mobility_error"][()] * (1 - 1e-12)),
          f"the error bar holds the operator's part: estimated_error {float(p.attrs['estimated_error']):.3e} "
          f"> truncation's {truncation:.3e}")

print(f"{len(failures)} failed")
sys.exit(1 if failures else 0)
