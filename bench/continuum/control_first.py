#!/usr/bin/env python3
"""control_first.py --exe NEW --vs OLD [--repeats 3] [--out control_first.md]: two builds side by side on
continuum jobs with fixed ladders, to measure how a full sample's solves are ordered (docs/theory.md
T18, "Control samples"): OLD solves the order-L problem from zero and then its control problem
(order L - 1, at five times the Krylov tolerance) as a second friction job; NEW solves the control
problem first, as the order-L job's companion (its operator read from the order-L one), and starts
the order-L solves from its solutions.

Jobs (2 ranks, the default &continuum settings but a fixed ladder of 3 levels, so that both builds
solve the same samples): a sphere (aligned lattice, mirror planes at the first offset), the
1.6 : 1.0 : 0.7 ellipsoid of nonconvex.md, and the 3-D cross of nonconvex.py on turned lattices
(no mirror plane). Each job runs with NEW and OLD in alternation, `--repeats` pairs. Per job: the
medians of the whole job's wall time, of the full samples' seconds and Krylov iterations (order L
and its control, the file's sample_seconds and sample_iterations), the ratio NEW / OLD of each pair
(median), and the largest |difference| of the two builds' continuum mobility (36 entries) over the
smaller of their two bars: the solves differ by their Krylov tolerance only, so this is small.
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

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from nonconvex import cross, write_obj  # noqa: E402

ENV = {k: v for k, v in os.environ.items() if k != "BEADMOB_CACHE"}
ENV.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", OMPI_MCA_pml=ENV.get("OMPI_MCA_pml", "ob1"))

JOBS = {
    "sphere": ("&shape name = 'sphere', radius = 1.0, bead_diameter = 0.1 /",
               "levels = 3, finest_bead_diameter = 0.08"),
    "ellipsoid 1.6:1:0.7": ("&shape name = 'spheroid', semi_axes = 1.6, 1.0, 0.7, bead_diameter = 0.1 /",
                            "levels = 3, finest_bead_diameter = 0.1"),
    "3-D cross, turned lattices": ("&shape name = 'mesh', file = 'body.obj', bead_diameter = 0.075 /",
                                   "levels = 3, finest_bead_diameter = 0.075, turned_lattices = .true."),
}


def run(exe, folder, shape, ladder):
    (folder / "job.nml").write_text(f"&run output = 'job.h5' /\n{shape}\n&hydrodynamics /\n&continuum {ladder} /\n")
    for stale in folder.glob("job.h5*"):
        stale.unlink()
    start = time.perf_counter()
    subprocess.run(["mpiexec", "-n", "2", str(exe), "job.nml", "-quiet"], cwd=folder, env=ENV, check=True,
                   stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - start
    with h5py.File(folder / "job.h5") as f:
        c = f["continuum"]
        full = np.asarray(c.attrs["sample_full"]).reshape(-1) == 1
        return {"wall": wall,
                "full_seconds": float(np.sum(c["sample_seconds"][()][full])),
                "full_iterations": int(np.sum(np.asarray(c.attrs["sample_iterations"]).reshape(-1)[full])),
                "beads": int(np.max(c.attrs["sample_beads"])),
                "mobility": c["mobility"][()], "bar": c["mobility_error"][()]}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--exe", required=True)
    parser.add_argument("--vs", required=True)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--out", default=str(HERE / "control_first.md"))
    args = parser.parse_args()
    exes = {"new": Path(args.exe).resolve(), "old": Path(args.vs).resolve()}
    version = {k: subprocess.run([str(e), "--version"], capture_output=True, text=True).stdout.strip()
               for k, e in exes.items()}
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        write_obj(folder / "body.obj", *cross())
        for name, (shape, ladder) in JOBS.items():
            runs = {"new": [], "old": []}
            for repeat in range(args.repeats):
                for key in ("new", "old") if repeat % 2 == 0 else ("old", "new"):
                    runs[key].append(run(exes[key], folder, shape, ladder))
                    print(f"{name} {key} {repeat}: {runs[key][-1]['wall']:.1f} s", flush=True)
            new, old = runs["new"], runs["old"]

            def median(key, which):
                return float(np.median([r[key] for r in which]))

            def ratio(key):
                return float(np.median([a[key] / b[key] for a, b in zip(new, old)]))

            bars = np.minimum(new[0]["bar"], old[0]["bar"])
            shift = np.max(np.abs(new[0]["mobility"] - old[0]["mobility"])[bars > 0] / bars[bars > 0])
            rows.append(f"| {name} | {new[0]['beads']} | {median('wall', new):.1f} / {median('wall', old):.1f} | "
                        f"{ratio('wall'):.2f} | {median('full_seconds', new):.1f} / {median('full_seconds', old):.1f} | "
                        f"{ratio('full_seconds'):.2f} | {median('full_iterations', new):.0f} / "
                        f"{median('full_iterations', old):.0f} | {ratio('full_iterations'):.2f} | {shift:.3f} |")
    text = [
        "# A full sample's control problem first, the order-L solves started from it",
        "",
        f"Written by `bench/continuum/control_first.py --repeats {args.repeats}` on {time.strftime('%Y-%m-%d')} "
        f"(2 ranks, this machine): NEW = {version['new']}, OLD = {version['old']}, run in alternation.",
        "",
        (__doc__.split("\n\n", 1)[1]).strip(),
        "",
        "| job | finest level's beads | job wall s (NEW / OLD) | NEW / OLD | full samples s | NEW / OLD | "
        "full samples' iterations | NEW / OLD | largest mobility shift / bar |",
        "|---|---|---|---|---|---|---|---|---|",
        *rows,
        "",
    ]
    Path(args.out).write_text("\n".join(text))
    print("\n".join(text))


if __name__ == "__main__":
    main()
