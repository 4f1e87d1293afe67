#!/usr/bin/env python3
"""The error bar of a run (issue 15): how well a run's own truncation-error estimate (its order-L
result against the companion solve of order L - 1 on the same beads, docs/theory.md T14) bounds
its true error, and whether the extrapolated value is closer to the truth than the order-L one.

    python3 bench/error_estimate.py collect [--bodies a,b] [--settings s,t] [--exe build/beadmob]
    python3 bench/error_estimate.py calibrate      # the factors of src/hydro/error_estimate.f90
    python3 bench/error_estimate.py report         # bench/error_estimate.md and .csv

Bodies: a tuning set (used to choose the estimate's two factors) and a check set that was not
(the seven paper shapes, a torus, a spheroid, a flat disc and a bent rod). Each body is run at
the default settings (which carry the estimate) and at a reference: L = 4, the full model (no
shell), Krylov tolerance 1e-7 (the exact Stokes mobility of the bead model up to the L = 4
truncation, ~1e-4, bench/l_convergence_arrowhead.md). The tuning set is also run at L = 1 with
the default's shell model and tolerance (the companion, computed separately) so that the
factors can be fitted before the estimate exists in a build.

Error measure (docs/theory.md T14): entry (i, j) of the 6x6 body-frame mobility M against the
reference, |dM_ij| / sqrt(M_ii M_jj) -- relative on the diagonal, and for a coupling relative to
the largest value an entry of a positive definite matrix can have there, so a coupling near zero
is measured on the scale of its block, not its own. The paper's five coefficients are entries
of M (times pi L or pi L^2), measured the same way.
Runs go to bench/error_estimate_runs/ (kept: a second call only runs what is missing).
"""
import argparse
import csv
import sys
from pathlib import Path

import h5py
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from accuracy import launch, shape_group, write_csv  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
RUNS = ROOT / "bench" / "error_estimate_runs"
PAPER_SHAPES = ["cone", "crescent_moon", "arrowhead", "ring_1mm", "ring_2mm", "ring_3mm", "ring_4mm"]
# name -> (&shape group, role); bead files are written by make_bead_file
BODIES = {
    "sphere_r6": ("&shape name = 'sphere', radius = 6 /", "tune"),
    "prolate": ("&shape name = 'spheroid', semi_axes = 12, 5, 5 /", "tune"),
    "slab": ("&shape name = 'box', box_beads = 10, 6, 3 /", "tune"),
    "chain_12": ("&shape name = 'chain', n_beads = 12 /", "tune"),
    "cluster_300": ("&shape name = 'bead_file', file = 'cluster_300.txt' /", "tune"),
    "cluster_600": ("&shape name = 'bead_file', file = 'cluster_600.txt' /", "tune"),
    "cluster_1500": ("&shape name = 'bead_file', file = 'cluster_1500.txt' /", "tune"),
    "l_block": ("&shape name = 'bead_file', file = 'l_block.txt' /", "tune"),
    "sphere_r10": ("&shape name = 'sphere', radius = 10 /", "tune"),
    "plate": ("&shape name = 'box', box_beads = 20, 12, 6 /", "tune"),
    **{s: (None, "check") for s in PAPER_SHAPES},
    "torus": ("&shape name = 'torus', major_radius = 14, minor_radius = 4 /", "check"),
    "spheroid": ("&shape name = 'spheroid', semi_axes = 18, 8, 8 /", "check"),
    "disc": ("&shape name = 'bead_file', file = 'disc.txt' /", "check"),
    "bent_rod": ("&shape name = 'bead_file', file = 'bent_rod.txt' /", "check"),
}
# label -> (&hydrodynamics entries, command-line options)
SETTINGS = {
    "default": ("", ""),
    "L1_shell1": ("multipole_order = 1, shell_layers = 1", ""),
    "L4_tight": ("multipole_order = 4, shell_layers = 0", "-ksp_rtol 1e-7"),
}
REFERENCE = "L4_tight"
COEFFICIENTS = ["mu11", "mu22", "mu33", "mu42", "mu51"]
# the paper's coefficients as (row, column) of the body-frame mobility and the power of the
# reference length in their normalisation (pi eta L mu_tt, pi eta L^2 mu_rt)
COEFFICIENT_ENTRIES = [(0, 0), (1, 1), (2, 2), (3, 1), (4, 0)]


def make_bead_file(name):
    """The tuning and check bodies given as bead files (integer lattice nodes), reproducibly."""
    path = RUNS / f"{name}.txt"
    if path.exists():
        return
    if name.startswith("cluster_"):
        # Eden growth on the lattice: a compact random aggregate without any symmetry.
        n = int(name.split("_")[1])
        rng = np.random.default_rng(n)
        beads, members = [(0, 0, 0)], {(0, 0, 0)}
        steps = [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)]
        while len(beads) < n:
            b = beads[rng.integers(len(beads))]
            s = steps[rng.integers(6)]
            c = (b[0] + s[0], b[1] + s[1], b[2] + s[2])
            if c not in members:
                members.add(c)
                beads.append(c)
        points = np.array(beads)
    elif name == "l_block":
        # two slabs at right angles, one thicker: couplings of every kind
        g = np.mgrid[0:10, 0:4, 0:3].reshape(3, -1).T
        h = np.mgrid[0:3, 0:4, 3:12].reshape(3, -1).T
        points = np.vstack([g, h])
    elif name == "disc":
        # a flat cylinder: radius 14, three layers
        g = np.mgrid[-14:15, -14:15, -1:2].reshape(3, -1).T
        points = g[g[:, 0] ** 2 + g[:, 1] ** 2 <= 14 ** 2]
    elif name == "bent_rod":
        # nodes within 2.2 of a circular arc of radius 14 over 150 degrees (in the xz plane)
        g = np.mgrid[-17:18, -3:4, -17:18].reshape(3, -1).T.astype(float)
        angle = np.arctan2(g[:, 2], g[:, 0])
        arc = np.clip(angle, np.radians(15), np.radians(165))
        nearest = 14 * np.stack([np.cos(arc), np.zeros_like(arc), np.sin(arc)], axis=1)
        points = g[np.sum((g - nearest) ** 2, axis=1) <= 2.2 ** 2].astype(int)
    else:
        raise ValueError(name)
    RUNS.mkdir(parents=True, exist_ok=True)
    np.savetxt(path, points, fmt="%d", header=f"{name}: {len(points)} beads (bench/error_estimate.py)")


def body_group(name):
    text, _ = BODIES[name]
    if text is None:
        return shape_group(name)
    if "bead_file" in text:
        make_bead_file(text.split("'")[3].removesuffix(".txt"))
    return text


def run(exe, name, label, force=False):
    tag = f"{name}_{label}"
    h5, times = RUNS / f"{tag}.h5", RUNS / f"{tag}.times"
    if not force and h5.exists() and times.exists():
        return float(times.read_text())
    hydro, options = SETTINGS[label]
    text = f"&run output = '{tag}.h5', progress = .false. /\n{body_group(name)}\n&hydrodynamics {hydro} /\n"
    wall = launch(exe, RUNS, tag, text, options.split())
    times.write_text(f"{wall:.3f}")
    print(f"error_estimate: {tag} {wall:.1f} s", flush=True)
    return wall


def read(name, label):
    with h5py.File(RUNS / f"{name}_{label}.h5") as f:
        g = f["hydrodynamics"]
        out = dict(mobility=np.asarray(g["body_mobility"][()]), coefficients=np.asarray(g["coefficients"][()]),
                   n=int(f["geometry"].attrs["n_beads"]), length=float(f["shape"].attrs["reference_length"]))
        for key in ("estimate_mobility_error", "estimate_coefficient_error", "extrapolated_mobility",
                    "extrapolated_coefficients", "companion_mobility"):
            if key in g:
                out[key] = np.asarray(g[key][()])
        out["seconds"] = float(g.attrs["phase_seconds"][-1])
        names = [n.decode() if isinstance(n, bytes) else str(n) for n in g.attrs["phase_names"]]
        out["phases"] = dict(zip(names, np.asarray(g.attrs["phase_seconds"], dtype=float)))
        return out


def scaled(delta, mobility):
    """|delta_ij| / sqrt(M_ii M_jj) (the module docstring's measure)."""
    d = np.sqrt(np.abs(np.diag(mobility)))
    return np.abs(delta) / np.outer(d, d)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("stage", choices=["collect", "calibrate", "report"])
    parser.add_argument("--bodies", default=",".join(BODIES))
    parser.add_argument("--settings", default=None)
    parser.add_argument("--exe", default=str(ROOT / "build" / "beadmob"))
    parser.add_argument("--force", action="store_true")
    args = parser.parse_args()
    bodies = args.bodies.split(",")
    if args.stage == "collect":
        for name in bodies:
            labels = args.settings.split(",") if args.settings else \
                (["L1_shell1", "default", REFERENCE] if BODIES[name][1] == "tune" else ["default", REFERENCE])
            for label in labels:
                run(Path(args.exe).resolve(), name, label, args.force)
    elif args.stage == "calibrate":
        calibrate(bodies)
    else:
        report(bodies)


def calibrate(bodies):
    """Ratios true error / |M_L - M_(L-1)| in the scaled measure over the tuning bodies: per entry of
    the mobility, and the block-wise floor that keeps a near-zero difference from promising too
    little (docs/theory.md T14)."""
    rows = []
    for name in bodies:
        if BODIES[name][1] != "tune":
            continue
        low, main_run, ref = read(name, "L1_shell1"), read(name, "default"), read(name, REFERENCE)
        truth = scaled(main_run["mobility"] - ref["mobility"], ref["mobility"])
        step = scaled(main_run["mobility"] - low["mobility"], main_run["mobility"])
        signed_truth = (main_run["mobility"] - ref["mobility"])
        signed_step = (main_run["mobility"] - low["mobility"])
        for i in range(6):
            for j in range(i, 6):
                rows.append(dict(body=name, i=i, j=j, truth=truth[i, j], step=step[i, j],
                                 block_step=block_max(step, i, j),
                                 ratio=signed_truth[i, j] / signed_step[i, j] if signed_step[i, j] else np.nan))
    write_csv(ROOT / "bench" / "error_estimate_tuning.csv", rows)
    truth = np.array([r["truth"] for r in rows])
    step = np.array([r["step"] for r in rows])
    block = np.array([r["block_step"] for r in rows])
    significant = truth > 1e-6
    print(f"{len(rows)} entries, {significant.sum()} with a true error above 1e-6")
    for q in (0.5, 0.9, 0.95, 1.0):
        print(f"  quantile {q}: truth/step {np.quantile(truth[significant] / step[significant], q):.3g}, "
              f"truth/block {np.quantile(truth[significant] / block[significant], q):.3g}")
    ratio = np.array([r["ratio"] for r in rows])
    good = np.isfinite(ratio) & significant
    print(f"  signed ratio (M_L - M_ref) / (M_L - M_L-1): median {np.median(ratio[good]):.3g}, "
          f"quartiles {np.quantile(ratio[good], 0.25):.3g} {np.quantile(ratio[good], 0.75):.3g}")


def block_max(step, i, j):
    """The largest scaled difference in the 3x3 block of the mobility that holds entry (i, j)."""
    bi, bj = 3 * (i // 3), 3 * (j // 3)
    return float(np.max(step[bi:bi + 3, bj:bj + 3]))


def report(bodies):
    raise SystemExit("report: written with the estimate (see the issue 15 commits)")


if __name__ == "__main__":
    main()
