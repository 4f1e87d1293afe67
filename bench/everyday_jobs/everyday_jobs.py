#!/usr/bin/env python3
"""everyday_jobs.py [--exe BUILD/beadmob] [--before OLD/beadmob] [--repeats 3] [--sphere]: the jobs people run
most, timed as their speed targets state them (below), beside a dense RPY code of the kind a user writes in
forty lines of numpy (grand RPY mobility of the beads, Cholesky factorisation, rigid-body
contraction: the RPY level, less accurate than beadmob's L = 2).

Rows: the paper cone's friction job; a random compact 1000-bead lattice body (Eden growth, seed
1) and 2000 jittered off-lattice beads as whole processes (start-up included), at the default
L = 2 and at L = 1 (the RPY level of the dense code); the arrowhead and
the four open rings' friction jobs. The targets: the paper cone's friction job in 2.5 s, the random
1000-bead body in 0.8 s and the 2000 jittered beads in 4 s as whole processes, the 1e6-bead sphere
in 150 s, each ring's job within 2x of the arrowhead's. Every time
is the median of `--repeats` runs on 2 ranks; with --before, the same jobs of another build run
in alternation with this one, and the table gives the ratio of the medians and whether the two
builds' friction agrees within what the solver promises for both (tests/e2e/solver_promise.py:
each run within its stated bound of the exact solve). --sphere adds the filled lattice sphere of
radius 62.1 (about 1e6 beads), one run per build: job time, peak memory per rank and the
coefficients with their error bar.
"""
import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np
import scipy.linalg

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "bench" / "offlattice"))
sys.path.insert(0, str(ROOT / "tests" / "e2e"))
from offlattice import jittered  # noqa: E402
import solver_promise  # noqa: E402
from eden_body import eden_body  # noqa: E402

RANKS = 2
# Launched as scripts/mpi-env.sh launches on one node (Open MPI's shared-memory pml, not UCX's
# start-up probing), both builds alike.
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
           OMPI_MCA_pml=os.environ.get("OMPI_MCA_pml", "ob1"))


def dense_rpy_friction(points):
    """The 6x6 friction of rigid touching beads (radius 1/2) at the RPY level about their mean:
    M (3N x 3N, Rotne-Prager-Yamakawa, Rotne & Prager 1969, eq. for r >= 2a), zeta = K^T M^-1 K
    with K the rigid-body velocities of the beads; viscosity 1 (units of 6 pi eta a = 3 pi)."""
    a = 0.5
    n = len(points)
    r = points[:, None, :] - points[None, :, :]
    dist = np.linalg.norm(r, axis=-1)
    np.fill_diagonal(dist, 1.0)
    rhat = r / dist[..., None]
    eye = np.eye(3)
    outer = rhat[..., :, None] * rhat[..., None, :]
    c1 = 3 * a / (4 * dist) * (1 + 2 * a * a / (3 * dist**2))
    c2 = 3 * a / (4 * dist) * (1 - 2 * a * a / dist**2)
    blocks = c1[..., None, None] * eye + c2[..., None, None] * outer
    blocks[np.arange(n), np.arange(n)] = eye
    mobility = blocks.transpose(0, 2, 1, 3).reshape(3 * n, 3 * n) / (6 * np.pi * a)
    arm = points - points.mean(axis=0)
    k = np.zeros((3 * n, 6))
    for axis in range(3):
        k[axis::3, axis] = 1.0
        unit = np.zeros(3)
        unit[axis] = 1.0
        k[:, 3 + axis] = np.cross(unit, arm).reshape(-1)
    # zeta = (L^-1 K)^T (L^-1 K) with M = L L^T: one Cholesky and a triangular solve (a general
    # solve with the factor would add an LU factorisation twice the Cholesky's cost).
    factor = np.linalg.cholesky(mobility)
    half = scipy.linalg.solve_triangular(factor, k, lower=True)
    return half.T @ half


def write_beads(path, points):
    np.savetxt(path, points, header="x y z (bead diameters)", fmt="%.12g")


def run(exe, input_path, workdir):
    """Whole-process wall time, the friction job's own time (phase 'total') and what the run
    computed (friction, its solver bound, coefficients and error bar, peak memory per rank)."""
    for old in Path(workdir).glob("*.h5"):
        old.unlink()
    start = time.perf_counter()
    subprocess.run(["mpiexec", "-n", str(RANKS), exe, str(input_path), "-quiet"], cwd=workdir, env=ENV, check=True,
                   stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - start
    (result,) = [p for p in Path(workdir).glob("*.h5")]
    with h5py.File(result) as f:
        h = f["hydrodynamics"]
        job = float(h.attrs["phase_seconds"][-1])
        record = {"friction": h["friction"][()], "multipole_friction": h["multipole_friction"][()],
                  "bound": solver_promise.bound(h), "coefficients": h["coefficients"][()],
                  "error": h["coefficient_error"][()] if "coefficient_error" in h else None,
                  "memory": float(h.attrs["peak_memory_bytes"]) / 2**30,
                  "iterations": int(np.sum(h.attrs["solve_iterations"]))
                  + int(np.sum(h.attrs["companion_iterations"]) if "companion_iterations" in h.attrs else 0)}
    return wall, job, record


def agreement(this, before):
    """Largest |friction difference| of two runs as a fraction of what their solver bounds allow."""
    if this["bound"] is None or before["bound"] is None:
        return float("nan")
    allowed = solver_promise.allowed_difference([this["bound"], before["bound"]], this["multipole_friction"])
    return float(np.nanmax(np.abs(this["friction"] - before["friction"]) / allowed))


def median(values):
    return float(np.median(values))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--exe", default=str(ROOT / "build" / "beadmob"))
    parser.add_argument("--before", default="")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--out", default=str(Path(__file__).with_name("everyday_jobs.md")))
    parser.add_argument("--title", default="")
    parser.add_argument("--sphere", action="store_true", help="also the 1e6-bead sphere, one run per build")
    args = parser.parse_args()
    builds = [("this", os.path.abspath(args.exe))] + ([("before", os.path.abspath(args.before))] if args.before else [])
    with tempfile.TemporaryDirectory() as work:
        work = Path(work)
        write_beads(work / "random_1000.txt", eden_body(1000))
        write_beads(work / "jittered_2000.txt", jittered(2000))
        jobs = [("paper cone (`shapes/cone.nml`)", ROOT / "shapes" / "cone.nml", "job", None)]
        for name in ("random_1000", "jittered_2000"):
            nml = work / f"{name}.nml"
            nml.write_text(f"&run output = '{name}.h5' /\n&shape name = 'bead_file', file = '{name}.txt' /\n"
                           "&hydrodynamics /\n")
            jobs.append((f"{name.replace('_', ' ')} beads (whole process)", nml, "wall", name))
        # The same bodies at L = 1, the RPY level of the dense code (docs/theory.md T7).
        for name in ("random_1000", "jittered_2000"):
            nml = work / f"{name}_L1.nml"
            nml.write_text(f"&run output = '{name}_L1.h5' /\n&shape name = 'bead_file', file = '{name}.txt' /\n"
                           "&hydrodynamics multipole_order = 1 /\n")
            jobs.append((f"{name.replace('_', ' ')} beads at L = 1, the RPY level (whole process)", nml, "wall", name))
        for shape in ("arrowhead", "ring_1mm", "ring_2mm", "ring_3mm", "ring_4mm"):
            jobs.append((f"{shape} (`shapes/{shape}.nml`)", ROOT / "shapes" / f"{shape}.nml", "job", None))
        rows = []
        records = {}
        for label, nml, measure, key_name in jobs:
            times = {key: [] for key, _ in builds}
            for _ in range(args.repeats):
                for key, exe in builds:   # alternated: both builds see the same machine
                    wall, job, records[key] = run(exe, nml, work)
                    times[key].append(wall if measure == "wall" else job)
            agree = agreement(records["this"], records["before"]) if args.before else float("nan")
            iterations = "/".join(str(records[key]["iterations"]) for key, _ in builds)
            rows.append((label, measure, {key: median(v) for key, v in times.items()}, key_name, agree, iterations))
            print(label, rows[-1][2], agree, flush=True)
        sphere = {}
        if args.sphere:
            nml = work / "sphere.nml"
            nml.write_text("&run output = 'sphere.h5' /\n&shape name = 'sphere', radius = 62.1 /\n&hydrodynamics /\n")
            for key, exe in builds:
                wall, job, record = run(exe, nml, work)
                sphere[key] = (job, record)
                print("sphere", key, job, record["memory"], flush=True)
        dense = {}
        for name in ("random_1000", "jittered_2000"):
            points = np.loadtxt(work / f"{name}.txt")
            seconds = []
            for _ in range(args.repeats):
                start = time.perf_counter()
                dense_rpy_friction(points)
                seconds.append(time.perf_counter() - start)
            dense[name] = median(seconds)
            print(name, "dense RPY", dense[name], flush=True)
    header = "| job | measured | this build (s) |" + (" before (s) | before / this | friction difference / allowed |"
                                                       if args.before else "") + " iterations |"
    rule = "|---|---|---|" + ("---|---|---|" if args.before else "") + "---|"
    lines = [f"# Everyday jobs{': ' + args.title if args.title else ''}", "",
             f"Written by `bench/everyday_jobs/everyday_jobs.py`: {RANKS} ranks, medians of {args.repeats} runs"
             + (", the two builds alternated" if args.before else "") + "; `job` is the friction job's own time "
             "(phase `total` in the result file), `wall` the whole process from `mpiexec` to exit, launched with "
             f"Open MPI's pml {ENV['OMPI_MCA_pml']} (scripts/mpi-env.sh).", "",
             header, rule]
    for label, measure, t, _, agree, iterations in rows:
        line = f"| {label} | {measure} | {t['this']:.2f} |"
        if args.before:
            line += f" {t['before']:.2f} | {t['before'] / t['this']:.2f} | {agree:.2f} |"
        lines.append(line + f" {iterations} |")
    if args.before:
        lines += ["", "Friction difference / allowed: the largest entry of |friction (this) - friction (before)| "
                  "over the sum of the two runs' solver bounds (tests/e2e/solver_promise.py), last run of each "
                  "row; at most 1 means the builds agree within what the solver promises. Iterations: the Krylov "
                  "iterations of the job's solves and its companion's, summed over the motions (this / before)."]
    if sphere:
        lines += ["", "The filled lattice sphere of radius 62.1 (about 1e6 beads), one run per build:", "",
                  "| build | friction job (s) | peak memory per rank (GiB) | mu11 | its error bar |", "|---|---|---|---|---|"]
        for key, (job, record) in sphere.items():
            error = record["error"][0] if record["error"] is not None else float("nan")
            lines.append(f"| {key} | {job:.1f} | {record['memory']:.2f} | {record['coefficients'][0]:.5f} | "
                         f"{error:.5f} |")
        if "before" in sphere:
            lines.append("")
            lines.append(f"Ratio before / this: {sphere['before'][0] / sphere['this'][0]:.2f}; friction difference / "
                         f"allowed {agreement(sphere['this'][1], sphere['before'][1]):.2f}.")
    lines += ["", "The dense RPY code beside them (numpy, one process, median of the same repeats): "
              + ", ".join(f"{name.replace('_', ' ')} beads {seconds:.2f} s" for name, seconds in dense.items())
              + ". beadmob's whole process against it: "
              + "; ".join(f"{label.replace(' (whole process)', '')} {t['this'] / dense[name]:.2f}x"
                          for label, _, t, name, _, _ in rows if name)
              + " (above 1: beadmob slower). The dense code: a Cholesky factorisation of the 3N x 3N mobility "
              "and one triangular solve (scipy.linalg.solve_triangular), numpy's BLAS on its default threads."]
    Path(args.out).write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
