#!/usr/bin/env python3
"""What follows a continuum sample's offset scatter (docs/theory.md T18, "Control samples").

One level of the 3-D cross of nonconvex.py (bead_diameter 0.0595, ~13.3k beads), as the continuum
job's turned lattices make it: SAMPLES ordinary runs of the mesh turned by its own random rotation
of at most 15 degrees about its centroid (the rotation vector uniform in that ball, numpy
default_rng(SEED)) on the lattice shifted by the Halton offset j + 2 (bases 2, 3, 5). Each sample is
solved at L = 2 with the error bar's companion (L = 1 started from the L = 2 solution, Krylov
tolerance 1e-3) and three more times at L = 1 from zero, at Krylov tolerances 1e-3, 1e-2 and 3e-2.
Its friction is turned back into the mesh's frame, so all samples are the same body.

Reported, for the six diagonal friction entries (translation x, y, z, rotation x, y, z about each
sample's centre of mass):
- the scatter over the samples of the L = 2 friction y (standard deviation / mean);
- for each candidate control x, the scatter of y - k x (k = mean y / mean x) and the correlation of
  x and y: the part of y's scatter x does not follow, which is what a control sample leaves;
- the L = 1 solves' solver error against the companion (mean and scatter over the samples: a
  control needs it only alike in every sample) and the median wall time of each kind of solve;
- a control without a solve: the traction-weighted bead count, sum over a sample's beads of
  |f(x_b)|^2 for each motion's force density f, read at the nearest bead of a reference sample
  (sample 0's L = 1 bead forces, full model): the first-order change of the friction with the
  body's surface (the shape derivative of the resistance), with its least-squares slope fitted
  leave-one-out.

Run: python3 bench/continuum/control_correlation.py [--exe build/beadmob] [--out control_correlation.md]
(about 8 minutes on 2 ranks)."""

import argparse
import datetime
import json
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
from scipy.spatial import cKDTree

from continuum_jobs import ENV, RANKS, ROOT
from nonconvex import cross, write_obj

sys.path.insert(0, str(ROOT / "scripts"))
from beadmob_post.orbit import exp_rotation  # noqa: E402   (the rotation by |u| about u)

SEED = 7
SAMPLES = 8
BEAD_DIAMETER = 0.0595
MAX_TURN_DEGREES = 15.0
LOOSE = ("1e-3", "1e-2", "3e-2")


def halton(index, base):
    fraction, value = 1.0, 0.0
    while index > 0:
        fraction /= base
        value += fraction * (index % base)
        index //= base
    return value


def run(exe, folder, hydrodynamics):
    (folder / "job.nml").write_text(folder.joinpath("shape.nml").read_text() + f"&hydrodynamics {hydrodynamics} /\n")
    start = time.perf_counter()
    done = subprocess.run(["mpiexec", "-n", str(RANKS), str(exe), "job.nml"], cwd=folder, env=ENV,
                          capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"{folder}: beadmob failed\n{done.stdout}\n{done.stderr}")
    return time.perf_counter() - start


def diagonal(matrix, turn):
    big = np.kron(np.eye(2), turn)
    return np.diag(big @ matrix @ big.T)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--exe", default=str(ROOT / "build" / "beadmob"))
    parser.add_argument("--work", default="/tmp/beadmob_control_correlation")
    parser.add_argument("--out", default=str(Path(__file__).with_name("control_correlation.md")))
    arguments = parser.parse_args()
    vertices, faces = cross()
    pivot = vertices.mean(0)
    rng = np.random.default_rng(SEED)
    work = Path(arguments.work)
    y, companion, loose, seconds, counts = [], [], {t: [] for t in LOOSE}, {"L2+companion": [], **{t: [] for t in LOOSE}}, []
    turns = []
    for j in range(SAMPLES):
        while True:
            v = rng.uniform(-1, 1, 3)
            if np.linalg.norm(v) <= 1:
                break
        turn = exp_rotation(v * np.radians(MAX_TURN_DEGREES))
        turns.append(turn)
        folder = work / f"s{j}"
        folder.mkdir(parents=True, exist_ok=True)
        write_obj(folder / "body.obj", (vertices - pivot) @ turn + pivot, faces)   # the mesh turned by turn^T
        offset = ", ".join(str(halton(j + 2, b)) for b in (2, 3, 5))
        folder.joinpath("shape.nml").write_text(
            "&run output = 'job.h5', progress = .false. /\n"
            f"&shape name = 'mesh', file = 'body.obj', bead_diameter = {BEAD_DIAMETER}, lattice_offset = {offset} /\n")
        seconds["L2+companion"].append(run(arguments.exe, folder, "error_estimate = .true."))
        with h5py.File(folder / "job.h5") as f:
            y.append(diagonal(f["/hydrodynamics/multipole_friction"][()], turn))
            companion.append(diagonal(f["/hydrodynamics/companion_friction"][()], turn))
            counts.append(int(f["/geometry"].attrs["n_beads"]))
        for tolerance in LOOSE:
            seconds[tolerance].append(run(arguments.exe, folder, f"multipole_order = 1, error_estimate = .false., "
                                                                 f"krylov_rtol = {tolerance}"))
            with h5py.File(folder / "job.h5") as f:
                loose[tolerance].append(diagonal(f["/hydrodynamics/multipole_friction"][()], turn))
        # the traction proxy: every sample's beads in the mesh's frame (units of d)
        with h5py.File(folder / "job.h5") as f:
            positions = f["/geometry/positions"][()]
        np.save(folder / "positions.npy", pivot / BEAD_DIAMETER + (positions - pivot / BEAD_DIAMETER) @ turn.T)
        print(f"sample {j}: {counts[-1]} beads", flush=True)
    # the reference sample's L = 1 bead forces (full model: bead_forces needs every bead)
    reference = work / "s0"
    seconds_reference = run(arguments.exe, reference, "multipole_order = 1, error_estimate = .false., bead_forces = .true., "
                                                      "shell_layers = 0")
    with h5py.File(reference / "job.h5") as f:
        forces = f["/hydrodynamics/bead_forces"][()].reshape(-1, 6, 6)[:, :, :3]   # [bead, motion, force]
        reference_positions = f["/geometry/positions"][()]
    reference_positions = pivot / BEAD_DIAMETER + (reference_positions - pivot / BEAD_DIAMETER) @ turns[0].T
    weight = np.zeros((len(forces), 6))
    for motion in range(6):
        block, axis = divmod(motion, 3)
        along = turns[0].T[:, axis]   # the mesh frame's axis in the turned frame of sample 0
        f_motion = np.einsum("k,bkc->bc", along, forces[:, 3 * block:3 * block + 3, :])
        weight[:, motion] = np.sum(f_motion**2, 1)
    tree = cKDTree(reference_positions)
    proxy = np.array([weight[tree.query(np.load(work / f"s{j}" / "positions.npy"))[1]].sum(0) for j in range(SAMPLES)])

    y, companion = np.array(y), np.array(companion)
    names = ["t_x", "t_y", "t_z", "r_x", "r_y", "r_z"]

    def percent(values):
        return " | ".join(f"{v:.4f}" for v in values)

    def leftover(x):
        k = y.mean(0) / x.mean(0)
        return (y - k * x).std(0, ddof=1) / y.mean(0) * 100

    def correlation(x):
        return [np.corrcoef(x[:, i], y[:, i])[0, 1] for i in range(6)]

    lines = [
        "# What follows a continuum sample's offset scatter",
        "",
        f"Written by `bench/continuum/control_correlation.py` on {datetime.date.today()} "
        f"({RANKS} ranks, this machine; {subprocess.run([arguments.exe, '--version'], capture_output=True, text=True).stdout.strip()}).",
        "",
        __doc__.split("\n\n", 1)[1].split("\n\nRun:")[0],
        "",
        f"Samples: {SAMPLES}, beads {min(counts)} ... {max(counts)}.",
        "",
        "## Scatter over the samples (% of the mean) and what each control leaves",
        "",
        "| | " + " | ".join(names) + " |",
        "|---|" + "---|" * 6,
        "| y: L = 2 friction, sd % | " + percent(y.std(0, ddof=1) / y.mean(0) * 100) + " |",
        "| y - k x, x = companion (L = 1 from the L = 2 solution, 1e-3), sd % | " + percent(leftover(companion)) + " |",
    ]
    for tolerance in LOOSE:
        lines.append(f"| y - k x, x = L = 1 from zero at {tolerance}, sd % | " + percent(leftover(np.array(loose[tolerance]))) + " |")
    loo = []
    for i in range(6):
        residuals = []
        for k in range(SAMPLES):
            keep = np.arange(SAMPLES) != k
            slope = np.polyfit(proxy[keep, i], y[keep, i], 1)
            residuals.append(y[k, i] - np.polyval(slope, proxy[k, i]))
        loo.append(np.std(residuals, ddof=1) / y[:, i].mean() * 100)
    lines.append("| y - fit(traction-weighted bead count), leave-one-out, sd % | " + percent(loo) + " |")
    lines += ["", "Correlation of each control with y:", "", "| x | " + " | ".join(names) + " |", "|---|" + "---|" * 6,
              "| companion | " + " | ".join(f"{c:.4f}" for c in correlation(companion)) + " |"]
    for tolerance in LOOSE:
        lines.append(f"| L = 1 at {tolerance} | " + " | ".join(f"{c:.4f}" for c in correlation(np.array(loose[tolerance]))) + " |")
    lines.append("| traction-weighted bead count | " + " | ".join(f"{c:.3f}" for c in correlation(proxy)) + " |")
    lines += ["", "Solver error of the L = 1 solves from zero against the companion (%, mean and sd over the samples):", "",
              "| tolerance | " + " | ".join(names) + " |", "|---|" + "---|" * 6]
    for tolerance in LOOSE:
        error = (np.array(loose[tolerance]) / companion - 1) * 100
        lines.append(f"| {tolerance} | " + " | ".join(f"{m:+.3f} +- {s:.4f}" for m, s in zip(error.mean(0), error.std(0, ddof=1))) + " |")
    lines += ["", "Median wall time per run (s; each run includes reading the mesh and filling the lattice):", "",
              "| L = 2 + companion | " + " | ".join(f"L = 1 at {t}" for t in LOOSE) + " | L = 1 with bead forces (full model, once) |",
              "|---|" + "---|" * (len(LOOSE) + 1),
              f"| {np.median(seconds['L2+companion']):.1f} | " + " | ".join(f"{np.median(seconds[t]):.1f}" for t in LOOSE)
              + f" | {seconds_reference:.1f} |", ""]
    Path(arguments.out).write_text("\n".join(lines) + "\n")
    (work / "raw.json").write_text(json.dumps({"y": y.tolist(), "companion": companion.tolist(),
                                               "loose": {t: np.array(v).tolist() for t, v in loose.items()},
                                               "proxy": proxy.tolist(), "seconds": seconds}))
    print(f"written {arguments.out}")


if __name__ == "__main__":
    main()
