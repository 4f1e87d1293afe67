#!/usr/bin/env python3
"""check_continuum_mesh.py BEADMOB MPIEXEC RANKS WORKDIR: the continuum job on a user's own mesh
(src/driver/continuum_job.f90; docs/theory.md T18, "The ladder"; docs/input.md, "The continuum job").

The body is a lumpy triaxial ellipsoid (semi-axes 1.3, 1.0, 0.7 mesh units, its radius modulated
by low spherical harmonics), written here as an OBJ mesh: it has no symmetry plane or axis, so
every entry of its mobility is generic.

1. The ladder comes from the body's size, never from a level without beads: dry runs at the
   default budget of the mesh as made, with the coordinate origin outside the body (its bounding
   box's corner), far from the origin (coordinates ~1e3) and in another unit (coordinates and
   bead_diameter x 1000) all print a ladder whose every level holds at least 100 beads. The size
   survey is exact for a mesh (its polyhedral volume), so the far-off and the unit-changed body get
   the same bead diameters as the original (relative 1e-12 after the unit), and the unit change
   gives the same beads on every level (the same lattice in the body's unit; up to 2 beads that
   graze the surface).
2. True under rotation and translation (2 ranks): the same mesh turned by a generic rotation R and moved
   by t = (1000.3, -2000.1, 500.7) (the origin far outside) gives the continuum mobility R M R^T of
   the unturned one (both about the body's centroid) within the two jobs' error bars, entry by
   entry (the coupling entries depend on the reference point: the centroid must move and turn
   with the body). The check can fail: R M R^T differs from M itself by more than the bars (checked), so a
   job that ignored the turn would be caught.
3. A bead_diameter too coarse for any level (the body below two beads) is refused by name before
   any fill of a level.
4. Turned lattices (&continuum turned_lattices, 2 ranks), on the far-off mesh: every sample's
   lattice axes are a proper rotation, each sample's its own (every level its own turns), and the aligned job's are the
   identity; the pivot is the mesh's polyhedral centroid (computed here with numpy), and the
   body's volume the polyhedron's (exact, no moment fills), the turned samples' bead volumes average
   to it within 4 of their standard errors; one sample,
   rebuilt as an ordinary run of the mesh turned by Q^T about the pivot on that sample's offset and
   bead diameter, has the same beads and, turned back (diag(Q, Q) K diag(Q, Q)^T), the sample's
   friction within the two solves' stated solver error bounds (tests/e2e/solver_promise.py), and its
   control friction and grand resistance (solved first in the job, the order-L start) an order-1
   ordinary run's at the controls' 5e-3 within theirs; both
   are flow jobs, and the sample's grand resistance in the kept checkpoint is the ordinary run's
   turned back by diag(Q, Q, D(Q)) (D: the strain modes' rotation, docs/theory.md T19, computed
   here from the modes' definition) within the same bounds; the turned job's continuum mobility
   agrees with the aligned job's within the two bars. Both jobs of 2. take the mesh's own extent
   along their body x axis (numpy, from the vertices) as the coefficients' length L."""
import re
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from check_mesh_shapes import grid_surface, orient_outward  # noqa: E402
from checklist import check, failures  # noqa: E402
import solver_promise  # noqa: E402

SEMI_AXES = np.array([1.3, 1.0, 0.7])
SHIFT = np.array([1000.3, -2000.1, 500.7])


def lumpy_ellipsoid(n=48):
    """Triangles of the ellipsoid SEMI_AXES with radius factor 1 + 0.12 Y(u, v) (no symmetry)."""
    def point(u, v):
        lump = 1 + 0.12 * np.sin(v) * np.cos(v) * np.cos(u - 0.4) + 0.08 * np.sin(v) ** 2 * np.sin(2 * u + 0.9) \
            + 0.05 * np.cos(v)
        return np.array([SEMI_AXES[0] * lump * np.sin(v) * np.cos(u), SEMI_AXES[1] * lump * np.sin(v) * np.sin(u),
                         SEMI_AXES[2] * lump * np.cos(v)])
    triangles = grid_surface(point, 2 * n, n, closed_v=False)
    return orient_outward(triangles, lambda p: p / SEMI_AXES ** 2)


def write_obj(path, triangles):
    """OBJ with 17 significant digits (float32 STL would round coordinates ~1e3 to 6e-5)."""
    vertices, index = np.unique(triangles.reshape(-1, 3), axis=0, return_inverse=True)
    lines = [f"v {x:.17g} {y:.17g} {z:.17g}" for x, y, z in vertices]
    lines += [f"f {a} {b} {c}" for a, b, c in index.reshape(-1, 3) + 1]
    Path(path).write_text("\n".join(lines) + "\n")


def rotation(seed=7):
    q, r = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


def job(beadmob, mpiexec, ranks, workdir, name, mesh, bead_diameter, continuum, *options, hydrodynamics=""):
    nml = Path(workdir) / f"{name}.nml"
    nml.write_text(f"&run output = '{name}.h5' /\n&shape name = 'mesh', file = '{mesh}', "
                   f"bead_diameter = {bead_diameter!r} /\n&hydrodynamics {hydrodynamics} /\n&continuum {continuum} /\n")
    (Path(workdir) / f"{name}.h5").unlink(missing_ok=True)
    (Path(workdir) / f"{name}.h5.continuum_checkpoint").unlink(missing_ok=True)
    return subprocess.run([mpiexec, "-n", str(ranks), beadmob, str(nml), *options], cwd=workdir,
                          capture_output=True, text=True)


def printed_ladder(stdout):
    """(bead diameters, beads per level) of a dry run's ladder lines."""
    lines = stdout.splitlines()
    start = next(i for i, line in enumerate(lines) if "continuum ladder of" in line)
    diameters = np.array([float(x) for x in lines[start + 1].split()])
    beads = np.array([int(x) for x in re.sub("^ *beads", "", lines[start + 2]).split()])
    return diameters, beads


def turned_within_bars(turn, results):
    """R M R^T of the unturned job against the turned job, within the two bars."""
    (m, bar_m), (t, bar_t) = results["made"], results["turned"]
    big = np.kron(np.eye(2), turn)   # R turns U and Omega alike (a proper rotation)
    expected = big @ m @ big.T
    # The bars turn with the entries: each turned entry is a sum over the unturned ones.
    bar_turned = np.abs(big) @ bar_m @ np.abs(big).T
    difference = np.abs(t - expected)
    check(np.all(difference <= bar_turned + bar_t),
          f"turned and moved: R M R^T within the two jobs' bars (largest |difference| / bars "
          f"{np.max(difference / (bar_turned + bar_t)):.2f})")
    check(np.max(np.abs(expected - m) / (bar_turned + bar_m)) > 1,
          f"the turn matters: R M R^T differs from M beyond the bars (largest ratio "
          f"{np.max(np.abs(expected - m) / (bar_turned + bar_m)):.1f})")


def strain_modes():
    """The five orthonormal traceless symmetric strain modes E_k (E_k : E_l = delta_kl) in beadmob's
    order (src/multipole/linear_flow.f90): xy, xz, yz shears, (xx - yy) / sqrt 2, (2 zz - xx - yy) / sqrt 6."""
    modes = np.zeros((5, 3, 3))
    for k, (a, b) in enumerate(((0, 1), (0, 2), (1, 2))):
        modes[k, a, b] = modes[k, b, a] = 1 / np.sqrt(2)
    modes[3] = np.diag([1, -1, 0]) / np.sqrt(2)
    modes[4] = np.diag([-1, -1, 2]) / np.sqrt(6)
    return modes


def strain_rotation(q):
    """D_kl = E_k : (Q E_l Q^T): a strain given in the frame of axes Q in the input's modes."""
    modes = strain_modes()
    return np.einsum("kab,lab->kl", modes, np.einsum("ac,lcd,bd->lab", q, modes, q))


def polyhedron(triangles):
    """The solid's volume and centroid from signed tetrahedra on its first vertex (no digits lost far off)."""
    a, b, c = (triangles[:, k] - triangles[0, 0] for k in range(3))
    volume = np.einsum("ij,ij->i", a, np.cross(b, c)) / 6
    return volume.sum(), triangles[0, 0] + (volume[:, None] * (a + b + c) / 4).sum(axis=0) / volume.sum()


def turned_lattices(beadmob, mpiexec, ranks, workdir, ladder, triangles, aligned):
    """Section 4: the continuum job on turned lattices, one sample rebuilt by an ordinary run."""
    done = job(beadmob, mpiexec, ranks, workdir, "lattices", "far.obj", 0.125, ladder + ", turned_lattices = .true.",
               "-quiet", "-keep_checkpoint", hydrodynamics="flow = .true.")
    if done.returncode != 0:
        sys.exit(f"the continuum job on turned lattices failed:\n{done.stdout}\n{done.stderr}")
    with h5py.File(workdir / "made.h5", "r") as f:
        check(int(f["continuum"].attrs["turned_lattices"]) == 0
              and np.allclose(f["continuum/sample_lattice_axes"][()], np.eye(3).reshape(-1), atol=0),
              "an aligned job's samples have the input's axes")
    with h5py.File(workdir / "lattices.h5", "r") as f:
        c = f["continuum"]
        axes = [row.reshape(3, 3, order="F") for row in c["sample_lattice_axes"][()]]
        # The last sample solved at order L (with control samples, /continuum sample_full = 1).
        full = np.asarray(c.attrs["sample_full"]).reshape(-1) if "sample_full" in c.attrs else np.ones(len(axes))
        last = int(np.flatnonzero(full == 1)[-1])
        sample = dict(level=int(c.attrs["sample_level"][last]), beads=int(c.attrs["sample_beads"][last]),
                      offset=c["sample_offset"][last], friction=c["sample_friction"][last].reshape(6, 6, order="F"),
                      control=c["sample_control_friction"][last].reshape(6, 6, order="F"))
        d = c["bead_diameters"][sample["level"] - 1]
        pivot = c["lattice_pivot"][()]
        turned = (c["mobility"][()], c["mobility_error"][()])
        body = dict(volume=float(c.attrs["volume"]), error=float(c.attrs["volume_standard_error"]),
                    fills=int(c.attrs["moment_fills"]), samples=np.asarray(c["sample_moments"][()])[:, 0])
        check(int(c.attrs["turned_lattices"]) == 1, "a turned job says so (/continuum turned_lattices = 1)")
    check(all(np.allclose(q.T @ q, np.eye(3), atol=1e-12) and np.linalg.det(q) > 0 for q in axes),
          "every sample's lattice axes are a proper rotation")
    check(all(not np.allclose(axes[i], axes[k], atol=1e-3) for i in range(len(axes)) for k in range(i))
          and not any(np.allclose(q, np.eye(3), atol=1e-3) for q in axes),
          f"each of the {len(axes)} samples (levels x offsets) has its own turn")
    exact_volume, exact_pivot = polyhedron(triangles)
    check(np.allclose(pivot, exact_pivot, rtol=0, atol=1e-9 * np.abs(exact_pivot).max()),
          f"the pivot is the mesh's centroid ({pivot} against {exact_pivot})")
    check(abs(body["volume"] - exact_volume) <= 1e-12 * exact_volume and body["error"] == 0 and body["fills"] == 0,
          f"a mesh's body volume is its polyhedron's, exactly and without fills: {body['volume']} +- {body['error']} "
          f"against {exact_volume} ({body['fills']} fills)")
    # The turned samples' bead volumes N d^3 average to the polyhedron's (their expectation over
    # random offsets and turns: what the moment control relies on).
    relative = body["samples"] / exact_volume - 1
    check(abs(relative.mean()) <= 4 * relative.std(ddof=1) / np.sqrt(len(relative)),
          f"the turned samples' bead volume averages to the polyhedron's: {relative.mean():+.2e} +- "
          f"{relative.std(ddof=1) / np.sqrt(len(relative)):.1e} over {len(relative)} samples")
    # The last sample rebuilt: the mesh turned by Q^T about the pivot, on the sample's lattice.
    q = axes[last]
    write_obj(workdir / "sample.obj", pivot + (triangles - pivot) @ q)

    def ordinary_run(hydrodynamics, what):
        """The sample rebuilt as an ordinary run: its beads, friction, solver bound and grand resistance."""
        nml = workdir / "sample.nml"
        nml.write_text("&run output = 'sample.h5' /\n&shape name = 'mesh', file = 'sample.obj', "
                       f"bead_diameter = {float(d)!r}, lattice_offset = "
                       f"{', '.join(repr(float(x)) for x in sample['offset'])} /\n&hydrodynamics {hydrodynamics} /\n")
        (workdir / "sample.h5").unlink(missing_ok=True)
        run = subprocess.run([mpiexec, "-n", str(ranks), beadmob, str(nml), "-quiet"], cwd=workdir,
                             capture_output=True, text=True)
        if run.returncode != 0:
            sys.exit(f"the {what} of the turned sample failed:\n{run.stdout}\n{run.stderr}")
        with h5py.File(workdir / "sample.h5", "r") as f:
            h = f["hydrodynamics"]
            return (int(f["geometry"].attrs["n_beads"]), h["friction"][()], solver_promise.bound(h),
                    f["flow/grand_resistance"][()])

    beads, friction, bound, grand = ordinary_run("flow = .true.", "ordinary run")
    check(beads == sample["beads"], f"the rebuilt sample has the sample's beads ({beads} against {sample['beads']})")
    big = np.kron(np.eye(2), q)
    allowed = solver_promise.allowed_difference([bound, bound], friction)
    difference = np.abs(big @ friction @ big.T - sample["friction"])
    check(bound is not None and np.all(difference <= allowed),
          f"the sample's friction is the turned ordinary run's, turned back (largest |difference| / allowed "
          f"{np.max(difference / allowed):.2g})")
    # Its control problem (order L - 1 at five times the job's Krylov tolerance, 5e-3), which the job
    # solves first on the same beads and starts the order-L solves from: an ordinary order-1 flow run
    # at that tolerance (its grand resistance with the beads' own stresslets, Faxen's law, as every
    # order-1 job's), turned back, within the two solves' bounds.
    _, low_friction, low_bound, low_grand = ordinary_run("multipole_order = 1, krylov_rtol = 5e-3, flow = .true.",
                                                         "order-1 ordinary run")
    allowed = solver_promise.allowed_difference([low_bound, low_bound], low_friction)
    difference = np.abs(big @ low_friction @ big.T - sample["control"])
    check(low_bound is not None and np.all(difference <= allowed),
          f"the sample's control friction is the turned order-1 ordinary run's at 5e-3, turned back (largest "
          f"|difference| / allowed {np.max(difference / allowed):.2g})")
    # The sample's checkpoint line (after the header): 60 numbers of the sample, then its 11 x 11
    # grand resistance (Fortran order; a controlled job's control numbers follow).
    line = (workdir / "lattices.h5.continuum_checkpoint").read_text().splitlines()[1 + last].split()
    sample_grand = np.array([float(x) for x in line[60:181]]).reshape(11, 11, order="F")
    turn = np.zeros((11, 11))
    turn[:6, :6] = big
    turn[6:, 6:] = strain_rotation(q)
    allowed = solver_promise.allowed_difference([bound, bound], grand)
    difference = np.abs(turn @ grand @ turn.T - sample_grand)
    check(np.all(difference <= allowed),
          f"the sample's grand resistance is the turned ordinary run's, turned back by diag(Q, Q, D(Q)) (largest "
          f"|difference| / allowed {np.max(difference / allowed):.2g})")
    # Then the full sample's flag and control friction (37), the control's grand resistance (121).
    control_grand = np.array([float(x) for x in line[218:339]]).reshape(11, 11, order="F")
    allowed = solver_promise.allowed_difference([low_bound, low_bound], low_grand)
    difference = np.abs(turn @ low_grand @ turn.T - control_grand)
    check(float(line[181]) == 1.0 and np.all(difference <= allowed),
          f"the sample's control grand resistance is the turned order-1 ordinary run's, turned back (largest "
          f"|difference| / allowed {np.max(difference / allowed):.2g})")
    (m, bar_m), (t, bar_t) = aligned, turned
    check(np.all(np.abs(t - m) <= bar_m + bar_t),
          f"turned and aligned lattices: the same mobility within the two bars (largest |difference| / bars "
          f"{np.max(np.abs(t - m) / (bar_m + bar_t)):.2f})")


def main(beadmob, mpiexec, ranks, workdir):
    workdir = Path(workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    body = lumpy_ellipsoid()
    turn = rotation()
    corner = body - body.reshape(-1, 3).min(axis=0) + 0.05   # the origin just outside the bounding box
    variants = {"made": (body, 0.1), "corner": (corner, 0.1), "far": (body + SHIFT, 0.1),
                "millimetres": (body * 1000.0, 100.0)}
    for name, (triangles, _) in variants.items():
        write_obj(workdir / f"{name}.obj", triangles)
    write_obj(workdir / "turned.obj", body @ turn.T + SHIFT)

    # 1. Dry runs at the default budget.
    ladders = {}
    for name, (_, d) in variants.items():
        done = job(beadmob, mpiexec, ranks, workdir, f"dry_{name}", f"{name}.obj", d, "", "--estimate")
        if done.returncode != 0 or "continuum ladder of" not in done.stdout:
            check(False, f"dry run of the {name} mesh: exit {done.returncode}\n{done.stdout}\n{done.stderr}")
            continue
        ladders[name] = printed_ladder(done.stdout)
        check(np.all(ladders[name][1] >= 100), f"{name}: every level holds >= 100 beads ({ladders[name][1]})")
    if len(ladders) == len(variants):
        scale = {"made": 1.0, "corner": 1.0, "far": 1.0, "millimetres": 1000.0}
        for name in ("corner", "far", "millimetres"):
            check(np.allclose(ladders[name][0] / scale[name], ladders["made"][0], rtol=1e-12, atol=0),
                  f"{name}: the same bead diameters as the mesh as made ({ladders[name][0]})")
        check(np.all(np.abs(ladders["millimetres"][1] - ladders["made"][1]) <= 2),
              f"another unit: the same beads per level ({ladders['millimetres'][1]} vs {ladders['made'][1]})")

    # 2. Turned and moved: R M R^T within the two bars (a small fixed ladder: 3 levels x 2 offsets;
    #    on 2 ranks only: the solves are the rank-independent friction job's, checked elsewhere).
    ladder = "levels = 3, offsets = 2, finest_bead_diameter = 0.125"
    results = {}
    for name in ("made", "turned") if int(ranks) == 2 else ():
        done = job(beadmob, mpiexec, ranks, workdir, name, f"{name}.obj", 0.125, ladder, "-quiet")
        if done.returncode != 0:
            sys.exit(f"the continuum job of the {name} mesh failed:\n{done.stdout}\n{done.stderr}")
        with h5py.File(workdir / f"{name}.h5", "r") as f:
            c = f["continuum"]
            results[name] = (c["mobility"][()], c["mobility_error"][()])
            # L of the coefficients: the mesh's own extent along the body x axis (its vertices,
            # numpy here), not the finest bead model's outer size (up to d more).
            x_axis = f["geometry/body_axes"][()][0]
            triangles = body if name == "made" else body @ turn.T + SHIFT
            projection = triangles.reshape(-1, 3) @ x_axis
            extent = projection.max() - projection.min()
            check(abs(c.attrs["reference_length"] - extent) <= 1e-12 * extent
                  and c.attrs["reference_length_from"].decode() == "body",
                  f"{name}: L {c.attrs['reference_length']} is the mesh's extent along the body x axis {extent}")
    if results:
        turned_within_bars(turn, results)
        turned_lattices(beadmob, mpiexec, ranks, workdir, ladder, body + SHIFT, results["made"])

    # 3. Too coarse for any level.
    done = job(beadmob, mpiexec, ranks, workdir, "coarse", "made.obj", 3.0, "")
    check(done.returncode != 0 and "bead(s) at its bead_diameter" in done.stdout + done.stderr
          and not (workdir / "coarse.h5").exists(),
          f"a bead_diameter too coarse is refused: {(done.stderr.strip().splitlines() or [''])[0]!r}")

    if failures:
        sys.exit(f"{len(failures)} check(s) failed")
    print("check_continuum_mesh: all checks passed")


if __name__ == "__main__":
    main(*sys.argv[1:5])
