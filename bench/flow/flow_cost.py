#!/usr/bin/env python3
"""flow_cost.py [--exe BUILD/beadmob] [--before OLD_BUILD/beadmob] [--repeats 5] [--ranks 2] [--out FILE]:
what `&hydrodynamics flow = .true.` costs (docs/theory.md T19, issue: the eleven right-hand sides
within 2x of the six-motion job).

Jobs: the paper's cone (shapes/cone.nml, 5088 beads, two mirror planes: 4 of the 6 motions
solved) and the example particle mesh (shapes/particle.stl) at bead_diameter 0.032 mm (about 20k
beads, no symmetry: all 6 motions solved), both with the defaults (L = 2, shell model, error bar).
Each job runs as: A = flow = .true. (this build), B = the same input without it (this build), and,
with --before, C = without it on the build before the flow was added (a job that does not ask for
the flow must cost what it did). The runs alternate A B C A B C ... (`--repeats` rounds) so every
column sees the same machine; the ratios A/B and B/C are taken round by round and their medians
reported. Wall: the whole process (mpiexec included), timed here; phases and the peak resident set
(largest rank) from the result file; iterations: the Krylov iterations of the order-L solves (the
motions, and the strains for A).
"""
import argparse
import os
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parents[2]
ENV = {k: v for k, v in os.environ.items() if k != "BEADMOB_CACHE"}
ENV.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", OMPI_MCA_pml=ENV.get("OMPI_MCA_pml", "ob1"))

JOBS = {
    "paper cone (`shapes/cone.nml`, 5088 beads)":
        "&shape name = 'cone', base_diameter = 20, height = 47 /\n",
    "particle mesh (`shapes/particle.stl`, bead_diameter 0.032 mm)":
        f"&shape name = 'mesh', file = '{ROOT / 'shapes' / 'particle.stl'}', bead_diameter = 0.032 /\n",
}


def run(exe, shape, flow, workdir, ranks):
    nml = Path(workdir) / "job.nml"
    nml.write_text("&run output = 'job.h5' /\n" + shape + ("&hydrodynamics flow = .true. /\n" if flow
                                                           else "&hydrodynamics /\n"))
    result = Path(workdir) / "job.h5"
    if result.exists():
        result.unlink()
    start = time.perf_counter()
    subprocess.run(["mpiexec", "--oversubscribe", "-n", str(ranks), exe, str(nml), "-quiet"], cwd=workdir, env=ENV,
                   check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - start
    with h5py.File(result) as f:
        h = f["hydrodynamics"]
        seconds = dict(zip(h.attrs["phase_names"].decode().split(), h.attrs["phase_seconds"]))
        iterations = int(np.sum(h.attrs["solve_iterations"]))
        strains_solved = 0
        if flow:
            iterations += int(np.sum(f["flow"].attrs["strain_iterations"]))
            strains_solved = int(np.sum(f["flow"].attrs["strain_derived_from"] == 0))
        return {"wall": wall, "solve": seconds["solve"], "companion": seconds["companion"], "total": seconds["total"],
                "memory": float(h.attrs["peak_memory_bytes"]) / 2**20, "iterations": iterations,
                "beads": int(f["geometry"].attrs["n_beads"]), "solved": int(np.sum(h.attrs["solve_source"] == 0)),
                "strains solved": strains_solved}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--exe", default=str(ROOT / "build" / "beadmob"))
    parser.add_argument("--before", default="", help="the build before the flow, for column C")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--ranks", type=int, default=2)
    parser.add_argument("--out", default=str(ROOT / "bench" / "flow" / "flow_cost.md"))
    args = parser.parse_args()
    columns = {"A": (args.exe, True), "B": (args.exe, False)}
    if args.before:
        columns["C"] = (args.before, False)
    rows = []
    for label, shape in JOBS.items():
        runs = {c: [] for c in columns}
        with tempfile.TemporaryDirectory() as workdir:
            for _ in range(args.repeats):
                for c, (exe, flow) in columns.items():
                    runs[c].append(run(exe, shape, flow, workdir, args.ranks))
        rows.append((label, runs))
        print(label, {c: statistics.median(r["wall"] for r in v) for c, v in runs.items()}, flush=True)

    med = lambda runs, key: statistics.median(r[key] for r in runs)  # noqa: E731
    ratio = lambda a, b, key: statistics.median(x[key] / y[key] for x, y in zip(a, b))  # noqa: E731
    lines = [
        "# What the flow costs: `&hydrodynamics flow = .true.` beside the six-motion job",
        "",
        f"Written by `bench/flow/flow_cost.py` on {time.strftime('%Y-%m-%d')} ({args.ranks} ranks, "
        f"medians of {args.repeats} rounds; A = flow = .true., B = the same job without it, same build"
        + (", C = without it on the build before the flow was added" if args.before else "") + "). "
        "Wall: the whole process; solve, companion: the result file's phases; memory: peak resident set of "
        "the largest rank; iterations: the order-L Krylov iterations (motions, plus the strains in A); "
        "solved: motions solved, strains solved in A (the rest derived by symmetry). Ratios: medians of the round-by-round ratios.",
        "",
        "| job | beads | solved | strains solved | wall A (s) | wall B (s) | A / B | solve A | solve B | companion A | companion B | "
        "memory A (MiB) | memory B (MiB) | iterations A | iterations B |"
        + (" wall C (s) | B / C | memory C (MiB) |" if args.before else ""),
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|" + ("---|---|---|" if args.before else ""),
    ]
    for label, runs in rows:
        a, b = runs["A"], runs["B"]
        line = (f"| {label} | {a[0]['beads']} | {a[0]['solved']} | {a[0]['strains solved']} | {med(a, 'wall'):.2f} | {med(b, 'wall'):.2f} | "
                f"{ratio(a, b, 'wall'):.2f} | {med(a, 'solve'):.2f} | {med(b, 'solve'):.2f} | "
                f"{med(a, 'companion'):.2f} | {med(b, 'companion'):.2f} | {med(a, 'memory'):.0f} | "
                f"{med(b, 'memory'):.0f} | {a[0]['iterations']} | {b[0]['iterations']} |")
        if args.before:
            c = runs["C"]
            line += f" {med(c, 'wall'):.2f} | {ratio(b, c, 'wall'):.2f} | {med(c, 'memory'):.0f} |"
        lines.append(line)
    Path(args.out).write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
