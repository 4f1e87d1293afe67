#!/usr/bin/env python3
"""check_stress.py CHECK FILE...: numerical stress checks of beadmob result files (docs/stress_tests.md).

Every check first asserts the health of each file (``health``): every number in the file finite,
the friction and the order-L friction symmetric and positive definite (recomputed here with
numpy), the file's flags (friction_finite, _positive_definite, _symmetric, _well_conditioned,
_condition_number, _min_eigenvalue) equal to that recomputation, and every Krylov solve converged.
Then the physics check named CHECK against a reference independent of beadmob:

  health FILE...             only the above
  flagged FILE               a run that must be flagged: all_converged = 0 or a friction flag
                             at 0, the flags consistent with numpy, and still no NaN in the file
  nonfinite FILE             a run whose solves overflowed (Release builds only; Debug builds
                             trap): the file written all the same, friction_finite = 0,
                             all_converged = 0, the mobility NaN, the rest of the file finite
  slender FILE...            straight chains (any order of N): slender-body theory
  gaps FILE...               bead pairs, first at contact, then gaps increasing: Stimson-Jeffery
  gap_chain FILE TOUCHING    six beads with gaps 1e-2 ... 1e-6 against the touching chain
  far ORIGIN FILE...         the same body shifted far from the origin: same friction
  pair_contact FILE          touching pair at large L with lubrication
  cube LOW HIGH              2 x 2 x 2 box at two orders L (LOW < HIGH)
  plate FILE                 square plate n x n x 1

Exit status 0 when every assertion holds; each failure is printed.
"""
import argparse
import math
import sys

import h5py
import numpy as np

PI = math.pi
BEAD_RADIUS = 0.5
CONDITION_THRESHOLD = 1e12     # friction_diagnostics.f90
ASYMMETRY_THRESHOLD = 1e-8     # friction_diagnostics.f90
#: Riemann zeta(3) (Apery's constant).
ZETA3 = 1.2020569031595942

failures = []


def expect(condition, message):
    if not condition:
        failures.append(message)
        print("FAIL: " + message)
    return condition


def close(actual, expected, rtol, what):
    return expect(abs(actual - expected) <= rtol * abs(expected),
                  f"{what}: {actual:.10g}, expected {expected:.10g} within {rtol:g} relative")


def solver_margin(run, i, j, runs=1):
    """What the solver error may make of entry (i, j): the file's own bound on the variational
    friction (docs/theory.md T5, "Solver error bound") on the scale sqrt(zeta_ii zeta_jj) of the
    order-L friction, once per run whose entry enters the comparison."""
    zeta = run["multipole_friction"]
    return runs * float(run["attrs"]["solver_error_bound"]) * math.sqrt(abs(zeta[i, i] * zeta[j, j]))


def load(path):
    """friction, multipole_friction, the /hydrodynamics attributes and the positions of a file."""
    with h5py.File(path, "r") as f:
        h = f["hydrodynamics"]
        return {"path": path, "friction": h["friction"][()], "multipole_friction": h["multipole_friction"][()],
                "attrs": {k: h.attrs[k] for k in h.attrs}, "positions": f["geometry/positions"][()],
                "n_beads": int(f["geometry"].attrs["n_beads"])}


def every_number(path):
    """(name, array) of every numeric dataset and attribute of a file."""
    found = []
    with h5py.File(path, "r") as f:
        def visit(name, obj):
            for attr, value in obj.attrs.items():
                value = np.asarray(value)
                if value.dtype.kind in "fiu":
                    found.append((f"{name}@{attr}", value))
            if isinstance(obj, h5py.Dataset) and obj.dtype.kind in "fiu":
                found.append((name, obj[()]))
        f.visititems(visit)
    return found


def diagnose(zeta):
    """The numpy counterpart of friction_diagnostics.f90."""
    eig = np.linalg.eigvalsh(0.5 * (zeta + zeta.T))
    asym = np.linalg.norm(zeta - zeta.T) / np.linalg.norm(zeta)
    cond = np.abs(eig).max() / np.abs(eig).min()
    return eig, asym, cond


def flags_consistent(run, name):
    """The file's flags of `name` (friction or multipole_friction) equal numpy's recomputation."""
    a = run["attrs"]
    eig, asym, cond = diagnose(run[name])
    p = f"{run['path']}: {name}"
    expect(a[f"{name}_finite"] == 1, f"{p}_finite = {a[f'{name}_finite']} for a finite matrix")
    expect(a[f"{name}_positive_definite"] == int(eig[0] > 0), f"{p}_positive_definite disagrees with numpy")
    expect(a[f"{name}_symmetric"] == int(asym <= ASYMMETRY_THRESHOLD), f"{p}_symmetric disagrees with numpy")
    expect(a[f"{name}_well_conditioned"] == int(cond <= CONDITION_THRESHOLD),
           f"{p}_well_conditioned disagrees with numpy")
    expect(np.allclose(a[f"{name}_eigenvalues"], eig, rtol=1e-10, atol=1e-12 * np.abs(eig).max()),
           f"{p}_eigenvalues {a[f'{name}_eigenvalues']} differ from numpy {eig}")
    close(a[f"{name}_condition_number"], cond, 1e-8, f"{p}_condition_number")
    expect(a[f"{name}_asymmetry"] <= max(10 * asym, 1e-15), f"{p}_asymmetry {a[f'{name}_asymmetry']} vs {asym}")
    return eig, asym, cond


def health(path, flagged=False):
    """Finite everywhere; symmetric, positive definite, flags consistent; converged (unless flagged)."""
    for name, value in every_number(path):
        expect(np.all(np.isfinite(value)), f"{path}: non-finite values in {name}")
    run = load(path)
    for name in ("friction", "multipole_friction"):
        if not np.all(np.isfinite(run[name])):
            continue   # reported above
        eig, asym, cond = flags_consistent(run, name)
        if not flagged:
            expect(eig[0] > 0, f"{path}: {name} not positive definite (eigenvalues {eig})")
            expect(asym <= ASYMMETRY_THRESHOLD, f"{path}: {name} asymmetry {asym:.3g}")
            expect(cond <= CONDITION_THRESHOLD, f"{path}: {name} condition number {cond:.3g}")
    if not flagged:
        expect(run["attrs"]["all_converged"] == 1,
               f"{path}: all_converged = 0 (reasons {run['attrs']['solve_converged_reason']})")
    print(f"{path}: friction condition number {diagnose(run['friction'])[2]:.4g}, eigenvalues "
          f"{np.array2string(diagnose(run['friction'])[0], precision=5)}, iterations "
          f"{run['attrs']['solve_iterations']}")
    return run


def check_flagged(path):
    """A run driven into trouble must say so in its file (and never write NaN)."""
    run = health(path, flagged=True)
    a = run["attrs"]
    reasons = np.asarray(a["solve_converged_reason"])
    flags = [a[f"{n}_{k}"] for n in ("friction", "multipole_friction")
             for k in ("finite", "positive_definite", "symmetric", "well_conditioned")]
    expect(a["all_converged"] == 0 or min(flags) == 0, f"{path}: nothing flagged")
    expect(a["all_converged"] == int(np.all(reasons > 0)), f"{path}: all_converged disagrees with the reasons")
    print(f"{path}: all_converged {a['all_converged']}, reasons {reasons}, friction positive definite "
          f"{a['friction_positive_definite']}, smallest eigenvalue {a['friction_min_eigenvalue']:.4g}")


def check_nonfinite(path):
    """A friction with Inf/NaN entries: flagged, never passed off as a result."""
    run = load(path)
    a = run["attrs"]
    expect(not np.all(np.isfinite(run["friction"])), f"{path}: the friction is finite; this check expects otherwise")
    expect(a["friction_finite"] == 0 and a["friction_positive_definite"] == 0 and a["friction_well_conditioned"] == 0,
           f"{path}: a non-finite friction not flagged")
    expect(a["all_converged"] == 0 and np.any(np.asarray(a["solve_converged_reason"]) < 0),
           f"{path}: the diverged solves are not flagged")
    with h5py.File(path, "r") as f:
        expect(np.all(np.isnan(f["hydrodynamics/mobility"][()])), f"{path}: mobility of a non-finite friction not NaN")
        expect(np.all(np.isfinite(f["geometry/positions"][()])), f"{path}: geometry not finite")
    print(f"{path}: friction_finite {a['friction_finite']}, reasons {a['solve_converged_reason']}")


def check_slender(paths):
    """Straight chains of N touching beads along x. Slender-body theory (Batchelor, J. Fluid Mech. 44,
    419 (1970); Keller & Rubinow, J. Fluid Mech. 75, 705 (1976)): the force per length on a straight
    slender body is f_par = 4 pi U / (Lambda - 1) along the axis and f_perp = 8 pi U / (Lambda + 1)
    across it, Lambda ~ 2 ln(length / radius) whatever the cross-section, so
      D(N) = 4 pi N / zeta_perp - 2 pi N / zeta_par -> 1   (the cross-section drops out),
    and zeta_par / zeta_perp -> 1/2 from above, slowly (as 1/ln N)."""
    runs = sorted((health(p) for p in paths), key=lambda r: r["n_beads"])
    previous = None
    for run in runs:
        n, zeta = run["n_beads"], run["friction"]
        par, perp = zeta[0, 0], zeta[1, 1]
        ratio = par / perp
        d = 4 * PI * n / perp - 2 * PI * n / par
        print(f"N = {n}: axial friction per bead {par / n:.6f}, transverse {perp / n:.6f}, ratio {ratio:.5f}, "
              f"D(N) = {d:.5f}")
        expect(0.5 < ratio < 1.0, f"N = {n}: axial/transverse friction ratio {ratio:.5f} outside (1/2, 1)")
        expect(abs(d - 1) < (0.01 if n >= 1000 else 0.03), f"N = {n}: slender-body D(N) = {d:.5f}, expected 1")
        expect(abs(zeta[2, 2] - perp) <= solver_margin(run, 1, 2, runs=2),
               f"N = {n}: transverse friction y = z (axial symmetry) beyond the solver bound")
        if previous is not None:
            p_n, p_par, p_ratio = previous
            expect(par / n < p_par, f"axial friction per bead does not decrease from N = {p_n} to {n}")
            expect(ratio < p_ratio, f"friction ratio does not decrease towards 1/2 from N = {p_n} to {n}")
        previous = (n, par / n, ratio)


def stimson_jeffery(separation):
    """Drag per sphere / (6 pi a U) of two equal spheres translating along their line of centres,
    centre distance `separation` (units of the diameter 2a): Stimson & Jeffery, Proc. R. Soc. A 111,
    110 (1926); Happel & Brenner (1965), sec. 6.3, eq. 6-3.57. Own implementation of the series."""
    alpha = math.acosh(separation)
    n = np.arange(1.0, 200000.0)
    x = (2 * n + 1) * alpha
    with np.errstate(over="ignore", invalid="ignore"):
        fraction = (4 * np.sinh(x / 2) ** 2 - (2 * n + 1) ** 2 * math.sinh(alpha) ** 2) / \
                   (2 * np.sinh(x) + (2 * n + 1) * math.sinh(2 * alpha))
    fraction = np.where(x > 600, 1.0, fraction)
    terms = n * (n + 1) / ((2 * n - 1) * (2 * n + 3)) * (1 - fraction)
    return 4.0 / 3.0 * math.sinh(alpha) * math.fsum(terms)


def per_sphere(zeta):
    """Diagonal of the doublet friction (pair along x, about its midpoint) in the single-sphere units:
    translations / (6 pi a), rotations / (8 pi a^3), per sphere."""
    return np.diag(zeta) / (2 * np.array([6 * PI * BEAD_RADIUS] * 3 + [8 * PI * BEAD_RADIUS ** 3] * 3))


def check_gaps(paths):
    """Two beads at contact and at gaps 1e-6 ... 1e-2 d, lubrication on. A rigid doublet has no
    relative motion, so its friction stays finite at contact and *decreases* as the gap closes (the
    spheres shield each other); the 1/gap lubrication singularity belongs to the squeezing mode,
    which a rigid body does not have (tested on the series itself: test_near_contact)."""
    runs = [health(p) for p in paths]
    separations = [np.linalg.norm(r["positions"][1] - r["positions"][0]) for r in runs]
    expect(separations[0] == 1.0 and all(np.diff(separations) > 0), f"separations {separations}: "
           "expected contact first, then increasing gaps")
    contact = per_sphere(runs[0]["friction"])
    # Literature contact values: axial translation 0.645 (Stimson & Jeffery 1926); co-rotation about
    # the line of centres 3 zeta(3) / 4 (Takagi, J. Phys. Soc. Japan 36, 875 (1974)).
    expect(abs(contact[0] - 0.645) < 5e-4, f"contact: axial drag per sphere {contact[0]:.6f}, literature 0.645")
    close(contact[3], 0.75 * ZETA3, 1e-7, "contact: axial co-rotation torque per sphere (3 zeta(3) / 4)")
    previous = {"friction": None, "multipole_friction": None}
    for run, separation in zip(runs, separations):
        values = per_sphere(run["friction"])
        gap = separation - 1
        print(f"gap {gap:.1e}: per sphere (lubrication) {np.array2string(values, precision=10)}; order L "
              f"{np.array2string(per_sphere(run['multipole_friction']), precision=8)}")
        if gap > 0:
            close(values[0], stimson_jeffery(separation), 1e-6, f"gap {gap:.0e}: axial drag vs Stimson-Jeffery")
        if gap <= 1e-5:   # the co-rotation torque changes by ~2 gap near contact (measured)
            close(values[3], 0.75 * ZETA3, 1e-4, f"gap {gap:.0e}: co-rotation torque vs contact 3 zeta(3)/4")
        # Galerkin: the order-L friction is a lower bound of the exact one (theory.md T5), and with
        # lubrication a lone doublet gets the exact values.
        excess = np.linalg.eigvalsh(run["friction"] - run["multipole_friction"])
        expect(excess.min() > -1e-10 * np.abs(run["friction"]).max(),
               f"gap {gap:.0e}: order-L friction exceeds the exact one (eigenvalues {excess})")
        for name in previous:
            diag = per_sphere(run[name])
            if previous[name] is not None:
                expect(np.all(diag > previous[name]), f"gap {gap:.0e}: {name} diagonal does not grow with the gap")
                if gap <= 1e-6:   # contact (lattice blocks) and 1e-6 (pair-block store) are continuous
                    expect(np.all(np.abs(diag - previous[name]) < 1e-5 * previous[name]),
                           f"{name} jumps between contact and gap {gap:.0e}")
            previous[name] = diag


def check_gap_chain(path, touching):
    """Six beads along x with gaps 1e-2 ... 1e-6 d (a lubrication table of five near-contact
    distances) against the touching chain: sum of gaps 0.0111 d, so within a few percent."""
    run, ref = health(path), health(touching)
    with h5py.File(path, "r") as f:
        distances = f["hydrodynamics/lubrication_distances"][()]
    expect(np.sum(distances < 1.02) == 5, f"{path}: expected 5 distinct near-contact distances, got {distances}")
    for name in ("friction", "multipole_friction"):
        a, b = np.diag(run[name]), np.diag(ref[name])
        rel = np.abs(a - b) / b
        print(f"{name}: relative difference to the touching chain {np.array2string(rel, precision=3)}")
        expect(np.all(rel < 0.03), f"{name} of the gap chain differs from the touching chain by {rel.max():.3g}")


def check_far(origin, paths):
    """The same body shifted by 1e6 d: the friction about the centre of mass must not change
    (translation invariance of Stokes flow); the lattice is found relative to the lowest corner, so a
    non-integer shift keeps a lattice body on the lattice (on_lattice recorded)."""
    ref = health(origin)
    for path in paths:
        run = health(path)
        shift = run["positions"].mean(axis=0) - ref["positions"].mean(axis=0)
        expect(np.abs(run["positions"] - ref["positions"] - shift).max() < 1e-9,
               f"{path}: not a rigid shift of {origin}")
        expect(run["attrs"]["on_lattice"] == ref["attrs"]["on_lattice"], f"{path}: on_lattice differs from {origin}")
        # Each run within its solver bound of its exact solve; the relative bead positions agree to
        # 1e-9 (checked above), which moves the exact friction by as much relatively (x10).
        allowed = np.array([[solver_margin(run, i, j) + solver_margin(ref, i, j) for j in range(6)]
                            for i in range(6)]) + 1e-8 * np.abs(ref["friction"]).max()
        for name in ("friction", "multipole_friction"):
            change = np.abs(run[name] - ref[name])
            print(f"{path}: shift {shift}, on_lattice {run['attrs']['on_lattice']}, {name} largest change "
                  f"{change.max():.2e}, {(change / allowed).max():.2f} of the promised")
            expect(np.all(change <= allowed), f"{path}: {name} changes beyond the solver bounds under the shift {shift}")


def check_pair_contact(path):
    """Touching pair at large L with lubrication: the lubricated friction is the exact doublet's
    (literature: 0.645 axial, Stimson & Jeffery 1926; co-rotation 3 zeta(3)/4, Takagi 1974) and the
    order-L friction a Galerkin lower bound close below it."""
    run = health(path)
    exact, approx = per_sphere(run["friction"]), per_sphere(run["multipole_friction"])
    print(f"L = {run['attrs']['multipole_order']}: exact {exact}, order L {approx}, relative deficit "
          f"{(exact - approx) / exact}")
    expect(abs(exact[0] - 0.645) < 5e-4, f"axial drag per sphere {exact[0]:.6f}, literature 0.645")
    close(exact[3], 0.75 * ZETA3, 1e-7, "axial co-rotation torque per sphere")
    expect(np.all(approx <= exact * (1 + 1e-12)), "order-L friction above the exact one")
    expect(np.all(exact - approx < 2e-3 * exact), "order-L friction more than 2e-3 below the exact one")


def check_cube(low_path, high_path):
    """2 x 2 x 2 box: cubic symmetry makes the translational and rotational friction isotropic and
    uncouples them about the centre; Galerkin monotonicity (theory.md T5: the order-L friction is
    c^T A_L^-1 c over nested bases) makes zeta(high L) - zeta(low L) positive semi-definite; Stokes
    drag grows with the body (Hill & Power, Q. J. Mech. Appl. Math. 9, 313 (1956)): above the
    touching doublet it contains moving along its axis (0.645 per sphere, Stimson & Jeffery 1926), below
    the sphere of radius sqrt(3)/2 + 1/2 containing it."""
    low, high = health(low_path), health(high_path)
    zeta = high["friction"]
    scale = np.abs(zeta).max()
    # To the solver error: entries of different solves, each within the file's bound of the exact
    # (isotropic, uncoupled) friction.
    margin = np.array([[solver_margin(high, i, j, runs=2) for j in range(6)] for i in range(6)])
    expect(np.all(np.abs(zeta[:3, :3] - zeta[0, 0] * np.eye(3)) <= margin[:3, :3]), "translation not isotropic")
    expect(np.all(np.abs(zeta[3:, 3:] - zeta[3, 3] * np.eye(3)) <= margin[3:, 3:]), "rotation not isotropic")
    expect(np.all(np.abs(zeta[:3, 3:]) <= margin[:3, 3:]), "translation-rotation coupling about the centre")
    gain = np.linalg.eigvalsh(zeta - low["friction"])
    print(f"L {low['attrs']['multipole_order']} -> {high['attrs']['multipole_order']}: friction gain eigenvalues "
          f"{gain}, translational friction {zeta[0, 0]:.8f}")
    expect(gain.min() > -1e-9 * scale, f"friction decreased with L (eigenvalues {gain})")
    expect(gain.max() < 1e-2 * scale, f"friction still changes by {gain.max() / scale:.3g} relative between the orders")
    doublet = 2 * 6 * PI * BEAD_RADIUS * 0.645
    expect(doublet < zeta[0, 0] < 6 * PI * (math.sqrt(3) / 2 + 0.5), f"translational friction {zeta[0, 0]}")


def check_plate(path):
    """Square plate of n x n x 1 beads (side s = n d). Thin-disk limit: edgewise / broadside friction
    2/3 (16 a broadside, 32 a / 3 edgewise: Happel & Brenner 1965, sec. 4-26); Hubbard & Douglas,
    Phys. Rev. E 47, R2983 (1993): the orientation-averaged translational friction ~ 6 pi C with C
    the electrostatic capacitance, for the unit square 0.3667874 s (Read, J. Comput. Phys. 133, 1
    (1997)); within a few percent for plates (disk: +3.7 %), the beads' thickness adds a little."""
    run = health(path)
    zeta = run["friction"]
    side = np.ptp(run["positions"][:, 0]) + 1
    # To the solver error: entries of different solves, each within the file's bound of the exact.
    margin = np.array([[solver_margin(run, i, j, runs=2) for j in range(6)] for i in range(6)])
    expect(abs(zeta[1, 1] - zeta[0, 0]) <= margin[0, 1], "square plate: friction along x = along y")
    expect(np.all(np.abs(zeta[:3, 3:]) <= margin[:3, 3:]), "translation-rotation coupling about the centre")
    edge, broad = zeta[0, 0], zeta[2, 2]
    average = (2 * edge + broad) / 3
    capacitance = 6 * PI * 0.3667874 * side
    print(f"side {side}: edgewise {edge:.6g}, broadside {broad:.6g}, ratio {edge / broad:.5f}, average / "
          f"(6 pi C) {average / capacitance:.5f}")
    expect(0.6 < edge / broad < 0.8, f"edgewise / broadside friction {edge / broad:.4f}, thin-disk 2/3")
    expect(0.98 < average / capacitance < 1.10, f"average friction / 6 pi C = {average / capacitance:.4f}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("check", choices=["health", "flagged", "nonfinite", "slender", "gaps", "gap_chain", "far",
                                          "pair_contact", "cube", "plate"])
    parser.add_argument("files", nargs="+")
    args = parser.parse_args()
    f = args.files
    {"health": lambda: [health(p) for p in f],
     "flagged": lambda: [check_flagged(p) for p in f],
     "nonfinite": lambda: [check_nonfinite(p) for p in f],
     "slender": lambda: check_slender(f),
     "gaps": lambda: check_gaps(f),
     "gap_chain": lambda: check_gap_chain(*f),
     "far": lambda: check_far(f[0], f[1:]),
     "pair_contact": lambda: [check_pair_contact(p) for p in f],
     "cube": lambda: check_cube(*f),
     "plate": lambda: [check_plate(p) for p in f]}[args.check]()
    print(f"{args.check}: {'PASS' if not failures else f'{len(failures)} failures'}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
