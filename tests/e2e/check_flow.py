#!/usr/bin/env python3
"""check_flow.py BEADMOB MPIEXEC RANKS WORKDIR: the body in an ambient linear flow
(`&hydrodynamics flow = .true.`, /flow, docs/theory.md T19) against exact values and the
program's own promises.

1. One bead at order L = 2: the strain density E.y is in its basis, so the single sphere is solved
   exactly: stresslet per unit strain (20/3) pi eta a^3 I (Einstein 1906; Batchelor 1970, eq. 5.8),
   a = 1/2, and no motion relative to the flow (to 1e-10).
2. A lattice spheroid of semi-axes 10, 5, 5 d about x: its rotation per unit strain against Jeffery's
   (1922) for the exact spheroid, Omega - Omega0 = B p x (E.p), B = (r^2 - 1)/(r^2 + 1), r = 2, within
   1 % (the lattice body's shape error, 0.46 % measured; 6:3:3 d gives 1.3 %, 12:6:6 d 0.02 %), and no translation relative to the
   flow (mirror planes). Its symmetries derive two of the five strains: the same numbers as all
   five solved (use_symmetry = .false.) within 1e-7.
3. A body without symmetry (a union of three boxes) turned by two lattice rotations: velocity and
   stresslet per strain turn as V' = R V D^T, T' = D T D^T (R = diag(Q, Q), D(Q)_kl = E_k : Q E_l Q^T),
   within 1e-6 of the largest entry (the Galerkin method is covariant; Krylov tolerance 1e-10).
4. Its error bar at L = 2 (the companion of order 1) covers the truncation error, the difference from
   L = 4, on every diagonal stresslet entry and every rotation entry above 1e-3 of the largest (1 rank).
5. On 2 ranks: the same numbers as on 1 rank within 1e-7 (Krylov tolerance 1e-10).
6. Refused with a message and a non-zero exit: flow with lubrication, flow with some motions only.
7. The continuum job of a sphere (three levels, two offsets): the exact stresslet within its bar (2 ranks).
8. Two spheres rigidly joined, 2 d and 1.5 d apart, against the two-sphere resistance functions of
   Jeffrey & Onishi (1984): to 1e-10 at L = 12, within the bar at L = 2.
9. Checkpoint and resume of a flow job: the motions and the strains saved are resumed, the rest
   solved, and the result is the uninterrupted run's within 1e-7; with derived strains (the
   spheroid) those are not saved and are derived again.
10. Order L = 1, whose beads get their own stresslets by Faxen's law in the Rotne-Prager-Yamakawa
   fields (src/multipole/bead_stresslet.f90): one bead has the Einstein stresslet (20/3) pi a^3 I to
   1e-12; a doublet's stresslet approaches Jeffrey & Onishi's as the stresslets' neglected mutual
   interaction, ~ (a/r)^3 (within 5 % at r/a = 4, falling 6x or more from r/a = 16 to 32).
"""
import os
import subprocess
import sys

import h5py
import numpy as np

beadmob, mpiexec, ranks, workdir = sys.argv[1:5]
os.makedirs(workdir, exist_ok=True)
failures = []


def check(condition, text):
    print(("ok   " if condition else "FAIL ") + text)
    if not condition:
        failures.append(text)


def run(name, shape_block, hydro="flow = .true., krylov_rtol = 1e-10", n=None, expect_failure=False, extra="",
        options=()):
    nml = os.path.join(workdir, name + ".nml")
    with open(nml, "w") as f:
        f.write(f"&run output = '{name}.h5' /\n{shape_block}\n&hydrodynamics {hydro} /\n{extra}")
    done = subprocess.run([mpiexec, "-n", str(n or ranks), beadmob, nml, "-quiet", *options], cwd=workdir,
                          capture_output=True, text=True)
    if expect_failure:
        return done
    if done.returncode != 0:
        sys.exit(f"{name}: beadmob failed:\n{done.stdout}\n{done.stderr}")
    return h5py.File(os.path.join(workdir, name + ".h5"))


def bead_file(name, positions):
    np.savetxt(os.path.join(workdir, name), positions, fmt="%d")
    return f"&shape name = 'bead_file', file = '{name}' /"


# The strain modes of docs/output.md, and their rotation.
s2, s6 = 1 / np.sqrt(2), 1 / np.sqrt(6)
modes = np.zeros((5, 3, 3))
modes[0, 0, 1] = modes[0, 1, 0] = s2
modes[1, 0, 2] = modes[1, 2, 0] = s2
modes[2, 1, 2] = modes[2, 2, 1] = s2
modes[3, 0, 0], modes[3, 1, 1] = s2, -s2
modes[4] = np.diag([-s6, -s6, 2 * s6])


def strain_rotation(q):
    return np.array([[np.sum(modes[k] * (q @ modes[l] @ q.T)) for l in range(5)] for k in range(5)])


# 1. One bead.
one = run("flow_one_bead", bead_file("one_bead.txt", np.zeros((1, 3))))
flow = one["flow"]
check(np.allclose(flow["strain_modes"][()], modes, atol=1e-15), "strain_modes are the documented E_1 ... E_5")
einstein = 20 / 3 * np.pi * 0.5**3
deviation = np.abs(flow["stresslet_per_strain"][()] - einstein * np.eye(5)).max() / einstein
check(deviation < 1e-10, f"one bead: stresslet per strain = 20/3 pi a^3 I within {deviation:.1e}")
check(np.abs(flow["velocity_per_strain"][()]).max() < 1e-12, "one bead: moves with the flow")

# 2. Jeffery's rotation of a lattice spheroid.
spheroid = run("flow_spheroid", "&shape name = 'spheroid', semi_axes = 10, 5, 5 /")
velocity = spheroid["flow/velocity_per_strain"][()]
r = 2.0
bretherton = (r * r - 1) / (r * r + 1)
p = np.array([1.0, 0.0, 0.0])
jeffery = np.array([bretherton * np.cross(p, modes[k] @ p) for k in range(5)]).T
worst = np.abs(velocity[3:] - jeffery).max() / np.abs(jeffery).max()
check(worst < 1e-2, f"10:5:5 spheroid: rotation per strain within {worst:.2e} of Jeffery's (1922), B = 0.6")
check(np.abs(velocity[:3]).max() < 1e-8 * np.abs(jeffery).max(), "spheroid: no translation relative to the flow")
check(spheroid["flow"].attrs["all_converged"] == 1, "spheroid: every strain solve converged")
# Its four-fold axis x: E_2 (xz) follows from E_1 (xy), E_5 from E_4 (motion_symmetry.F90); the same
# numbers as all five solved, within what the Krylov tolerance 1e-10 promises.
derived = [int(k) for k in spheroid["flow"].attrs["strain_derived_from"]]
every_solved = run("flow_spheroid_all_solved", "&shape name = 'spheroid', semi_axes = 10, 5, 5 /",
                   hydro="flow = .true., krylov_rtol = 1e-10, use_symmetry = .false.")
residuals = spheroid["flow"].attrs["strain_true_relative_residual"]
difference = max(np.abs(spheroid["flow/" + name][()] - every_solved["flow/" + name][()]).max()
                 / np.abs(every_solved["flow/" + name][()]).max() for name in ("grand_resistance", "stresslet_per_strain"))
check(derived == [0, 1, 0, 0, 4] and residuals.max() < 1e-9 and difference < 1e-7,
      f"spheroid: strains {derived} derived by its symmetries (true residuals <= {residuals.max():.1e}), "
      f"the same grand resistance and stresslet as all solved within {difference:.1e}")

# 3. A body without symmetry, turned by lattice rotations.
blocks = [((0, 0, 0), (5, 3, 2)), ((0, 0, 2), (2, 2, 3)), ((3, 1, -2), (2, 2, 2))]
body = np.unique(np.vstack([np.array(np.meshgrid(*[np.arange(o, o + s) for o, s in zip(origin, size)],
                                                 indexing="ij")).reshape(3, -1).T for origin, size in blocks]), axis=0)
plain = run("flow_body", bead_file("body.txt", body), hydro="flow = .true., krylov_rtol = 1e-10, shell_layers = 0")
turns = {"quarter turn about z": np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1]]),
         "third turn about (1, 1, 1)": np.array([[0, 0, 1], [1, 0, 0], [0, 1, 0]])}
for label, q in turns.items():
    name = "flow_body_" + label.split()[0]
    turned = run(name, bead_file(name + ".txt", body @ q.T),
                 hydro="flow = .true., krylov_rtol = 1e-10, shell_layers = 0")
    rot = np.zeros((6, 6))
    rot[:3, :3] = rot[3:, 3:] = q
    d = strain_rotation(q.astype(float))
    expected_v = rot @ plain["flow/velocity_per_strain"][()] @ d.T
    expected_t = d @ plain["flow/stresslet_per_strain"][()] @ d.T
    dv = np.abs(turned["flow/velocity_per_strain"][()] - expected_v).max() / np.abs(expected_v).max()
    dt = np.abs(turned["flow/stresslet_per_strain"][()] - expected_t).max() / np.abs(expected_t).max()
    check(max(dv, dt) < 1e-6, f"body turned by a {label}: V' = R V D^T within {dv:.1e}, T' = D T D^T within {dt:.1e}")

# 4. The bar at L = 2 against the truncation error (the difference from L = 4). On 1 rank only:
#    the bar comes from the order-1 companion, whatever the ranks (5. compares the ranks).
if int(ranks) == 1:
    high = run("flow_body_L4", bead_file("body.txt", body),
               hydro="flow = .true., krylov_rtol = 1e-10, shell_layers = 0, multipole_order = 4")
    for name, entries in (("stresslet_per_strain", lambda a: np.diag(a)), ("velocity_per_strain", lambda a: a[3:].ravel())):
        value, bar = entries(plain["flow/" + name][()]), entries(plain["flow/" + name + "_error"][()])
        truth = entries(high["flow/" + name][()])
        keep = np.abs(truth) > 1e-3 * np.abs(truth).max()
        ratio = bar[keep] / np.abs(value[keep] - truth[keep])
        check(bool(np.all(ratio >= 1)), f"L = 2 bar of {name} covers |L2 - L4| on {keep.sum()} entries "
              f"(bar / error {ratio.min():.2f} ... {ratio.max():.2f})")

# 5. Rank independence.
if int(ranks) > 1:
    serial = run("flow_body_np1", bead_file("body.txt", body),
                 hydro="flow = .true., krylov_rtol = 1e-10, shell_layers = 0", n=1)
    for name in ("grand_resistance", "velocity_per_strain", "stresslet_per_strain"):
        a, b = serial["flow/" + name][()], plain["flow/" + name][()]
        difference = np.abs(a - b).max() / np.abs(a).max()
        check(difference < 1e-7, f"{name}: 1 and {ranks} ranks agree within {difference:.1e}")

# 7. The continuum job: a sphere of radius 1 (three levels, two offsets) holds the exact stresslet
#    (20/3) pi R^3 I within its bar and moves with the flow (/continuum, theory.md T18, T19).
#    On 2 ranks only (its decisions are rank 0's, broadcast; one rank has nothing to share).
if int(ranks) > 1:
    sphere = run("flow_continuum", "&shape name = 'sphere', radius = 1, bead_diameter = 0.15 /",
                 hydro="flow = .true.", extra="&continuum levels = 3, offsets = 2, finest_bead_diameter = 0.15 /\n")
    c = sphere["continuum"]
    stresslet, bar = np.diag(c["stresslet_per_strain"][()]), np.diag(c["stresslet_per_strain_error"][()])
    exact = 20 / 3 * np.pi
    check(bool(np.all(np.abs(stresslet - exact) <= bar)), f"continuum sphere: stresslet {stresslet.min():.4f} ... "
          f"{stresslet.max():.4f} within its bar ({bar.max() / exact:.1%}) of 20/3 pi = {exact:.4f}")
    rotation, rotation_bar = c["velocity_per_strain"][()][3:], c["velocity_per_strain_error"][()][3:]
    check(bool(np.all(np.abs(rotation) <= rotation_bar + 1e-9)), f"continuum sphere: rotation per strain "
          f"{np.abs(rotation).max():.1e} within its bar")

# 8. Two spheres rigidly joined (a doublet) against the Jeffrey & Onishi (1984) / Jeffrey (1992)
#    resistance functions summed to convergence (scripts/beadmob_post/two_sphere_flow.py, itself
#    checked against Wilson's (2013) Lamb's-method values): centres 2 d (r/a = 4, on the lattice)
#    and 1.5 d (r/a = 3, off it) apart. At L = 12 the multipole series has converged (1e-10); at
#    L = 2 each entry lies within its bar.
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scripts"))
from beadmob_post.two_sphere_flow import doublet_flow  # noqa: E402
for distance in (2.0, 1.5):
    exact = doublet_flow(2 * distance, radius=0.5)
    exact_v, exact_t = exact["velocity_per_strain"], exact["stresslet_per_strain"]
    pair = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, distance]])
    np.savetxt(os.path.join(workdir, "pair.txt"), pair)
    for order, bound in ((12, 1e-10), (2, None)):
        g = run(f"flow_doublet_{order}", "&shape name = 'bead_file', file = 'pair.txt' /",
                hydro=f"flow = .true., multipole_order = {order}, krylov_rtol = 1e-12")["flow"]
        v, t = g["velocity_per_strain"][()], g["stresslet_per_strain"][()]
        dv = np.abs(v - exact_v).max() / np.abs(exact_v).max()
        dt = np.abs(t - exact_t).max() / np.abs(exact_t).max()
        if bound is not None:
            check(max(dv, dt) < bound, f"doublet r/a = {2 * distance:g}, L = {order}: V within {dv:.1e}, T within "
                  f"{dt:.1e} of the two-sphere series (B = {exact['bretherton']:.6f})")
        else:
            inside = (np.all(np.abs(v - exact_v) <= g["velocity_per_strain_error"][()] + 1e-12)
                      and np.all(np.abs(t - exact_t) <= g["stresslet_per_strain_error"][()] + 1e-12))
            check(bool(inside), f"doublet r/a = {2 * distance:g}, L = 2: every entry within its bar "
                  f"(errors {dv:.1e}, {dt:.1e})")

# 9. Checkpoint and resume: the body without symmetry stopped after its six motion solves
#    (-stop_after_solves 6) leaves a checkpoint; the rerun resumes every motion and exactly the
#    strains saved in it, solves the others, and gives the uninterrupted run's /flow within 1e-7.
checkpoint = os.path.join(workdir, "flow_resumed.h5.checkpoint.h5")
for stale in (checkpoint, os.path.join(workdir, "flow_resumed.h5")):
    if os.path.exists(stale):
        os.remove(stale)
body_hydro = "flow = .true., krylov_rtol = 1e-10, shell_layers = 0"
stopped = run("flow_resumed", bead_file("body.txt", body), hydro=body_hydro, expect_failure=True,
              options=("-stop_after_solves", "6"))
check(stopped.returncode != 0 and os.path.exists(checkpoint), "interrupted flow job: fails, leaves a checkpoint")
with h5py.File(checkpoint) as f:
    saved_strains = [k for k in range(5) if f"E_{k + 1}" in f]
    saved_motions = sum(name in f for name in ("U_x", "U_y", "U_z", "W_x", "W_y", "W_z"))
resumed = run("flow_resumed", bead_file("body.txt", body), hydro=body_hydro)
strain_resumed = [int(x) for x in resumed["flow"].attrs["strain_resumed"]]
check(saved_motions == 6 and all(int(x) == 1 for x in resumed["hydrodynamics"].attrs["resumed_motions"]),
      "the rerun resumes the six motions")
check(strain_resumed == [int(k in saved_strains) for k in range(5)],
      f"the rerun resumes exactly the strains saved ({[k + 1 for k in saved_strains]}), solves the others")
for name in ("grand_resistance", "velocity_per_strain", "stresslet_per_strain"):
    a, b = plain["flow/" + name][()], resumed["flow/" + name][()]
    difference = np.abs(a - b).max() / np.abs(a).max()
    check(difference < 1e-7, f"resumed {name} within {difference:.1e} of the uninterrupted run's")

# 10. Order 1: the beads' own stresslets.
one_l1 = run("flow_one_bead_L1", bead_file("one_bead.txt", np.zeros((1, 3))),
             hydro="flow = .true., multipole_order = 1")["flow"]
deviation = np.abs(one_l1["stresslet_per_strain"][()] - einstein * np.eye(5)).max() / einstein
check(deviation < 1e-12 and "Faxen" in str(one_l1.attrs["bead_stresslets"]),
      f"L = 1, one bead: stresslet per strain = 20/3 pi a^3 I within {deviation:.1e} (Faxen's law)")
errors = {}
for ratio in (4.0, 16.0, 32.0):
    np.savetxt(os.path.join(workdir, "pair.txt"), np.array([[0.0, 0.0, 0.0], [0.0, 0.0, ratio / 2]]))
    t = run("flow_doublet_L1", "&shape name = 'bead_file', file = 'pair.txt' /",
            hydro="flow = .true., multipole_order = 1, krylov_rtol = 1e-12")["flow/stresslet_per_strain"][()]
    exact_t = doublet_flow(ratio, radius=0.5)["stresslet_per_strain"]
    errors[ratio] = np.abs(t - exact_t).max() / np.abs(exact_t).max()
check(errors[4.0] < 0.05 and errors[16.0] / errors[32.0] > 6,
      f"L = 1 doublet: stresslet within {errors[4.0]:.1e} (r/a = 4), {errors[16.0]:.1e} (16), {errors[32.0]:.1e} (32) "
      "of the two-sphere series")

# 9b. The same with derived strains: the spheroid (strains E_2, E_5 derived) stopped after its
#     first motion solve resumes what was saved, derives the rest again, and gives the
#     uninterrupted run's /flow within 1e-7.
checkpoint = os.path.join(workdir, "flow_spheroid_resumed.h5.checkpoint.h5")
for stale in (checkpoint, os.path.join(workdir, "flow_spheroid_resumed.h5")):
    if os.path.exists(stale):
        os.remove(stale)
spheroid_shape = "&shape name = 'spheroid', semi_axes = 10, 5, 5 /"
stopped = run("flow_spheroid_resumed", spheroid_shape, expect_failure=True, options=("-stop_after_solves", "1"))
with h5py.File(checkpoint) as f:
    saved_derived = [name for name in ("E_2", "E_5") if name in f]
resumed = run("flow_spheroid_resumed", spheroid_shape)
difference = max(np.abs(resumed["flow/" + name][()] - spheroid["flow/" + name][()]).max()
                 / np.abs(spheroid["flow/" + name][()]).max() for name in ("grand_resistance", "stresslet_per_strain"))
check(stopped.returncode != 0 and not saved_derived and
      [int(k) for k in resumed["flow"].attrs["strain_derived_from"]] == [0, 1, 0, 0, 4] and difference < 1e-7,
      f"spheroid stopped and resumed: derived strains not saved, derived again; /flow within {difference:.1e}")

# 6. Refusals.
one_bead = "&shape name = 'bead_file', file = 'one_bead.txt' /"
for label, hydro, extra, words in (
        ("flow with lubrication", "flow = .true., lubrication = .true.", "", "cannot be combined with lubrication"),
        ("flow with some motions", "flow = .true., motions = 'U_x'", "", "needs all six motions")):
    done = run("refused", one_bead, hydro=hydro, expect_failure=True, extra=extra)
    message = done.stdout + done.stderr
    check(done.returncode != 0 and words in message, f"{label}: refused ({[l for l in message.splitlines() if words in l][:1]})")
    check(not os.path.exists(os.path.join(workdir, "refused.h5")), f"{label}: no result file")

if failures:
    sys.exit(f"{len(failures)} check(s) failed")
print("all flow checks passed")
