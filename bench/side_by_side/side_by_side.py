#!/usr/bin/env python3
"""side_by_side.py --a "OPTIONS" --b "OPTIONS" --out FILE [--title T] [--exe BUILD/beadmob] [--repeats 3]
[--ranks 2] [--random 1000] [--jittered 2000] [--random-only]:
two sets of command-line options of one build, side by side on the everyday jobs of bench/everyday_jobs (lattice
bodies; with --jittered, off-lattice ones too).

Each job runs with options A and options B in alternation (both see the same machine), on `--ranks`
ranks (oversubscribed beyond the cores),
`--repeats` times, no table cache (BEADMOB_CACHE unset). From each result file: the blocks phase
(the operator's set-up, FFT plans included), the solve and companion phases, the job (`total`)
and the time per operator product of the order-L solve (its phase over its products: every CG
iteration, one true-residual product per computed motion and one per coarse vector of a
deflation). The table gives medians, the ratio B / A of the job times, the Krylov iterations, and
whether the two runs' friction agrees within what the solver promises for both
(tests/e2e/solver_promise.py).
"""
import argparse
import os
import shlex
import subprocess
import sys
import tempfile
from pathlib import Path

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "bench" / "everyday_jobs"))
sys.path.insert(0, str(ROOT / "bench" / "offlattice"))
sys.path.insert(0, str(ROOT / "tests" / "e2e"))
from everyday_jobs import write_beads  # noqa: E402
from eden_body import eden_body  # noqa: E402
from offlattice import jittered  # noqa: E402
import solver_promise  # noqa: E402

ENV = {k: v for k, v in os.environ.items() if k != "BEADMOB_CACHE"}
ENV.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", OMPI_MCA_pml=ENV.get("OMPI_MCA_pml", "ob1"))


def run(exe, nml, options, workdir, ranks):
    for old in Path(workdir).glob("*.h5"):
        old.unlink()
    subprocess.run(["mpiexec", "--oversubscribe", "-n", str(ranks), exe, str(nml), "-quiet", *options], cwd=workdir, env=ENV, check=True,
                   stdout=subprocess.DEVNULL)
    (result,) = list(Path(workdir).glob("*.h5"))
    with h5py.File(result) as f:
        h = f["hydrodynamics"]
        seconds = dict(zip(h.attrs["phase_names"].decode().split(), h.attrs["phase_seconds"]))
        products = (int(np.sum(h.attrs["solve_iterations"])) + int(np.sum(h.attrs["solve_source"] >= 0))
                    + (int(h.attrs["deflation_vectors"]) if "deflation_vectors" in h.attrs else 0))
        return {"blocks": seconds["blocks"], "solve": seconds["solve"], "companion": seconds["companion"],
                "total": seconds["total"], "product": seconds["solve"] / products,
                "iterations": int(np.sum(h.attrs["solve_iterations"])) + int(np.sum(h.attrs["companion_iterations"])),
                "memory": float(h.attrs["peak_memory_bytes"]) / 2**20,
                "friction": h["friction"][()], "multipole_friction": h["multipole_friction"][()],
                "bound": solver_promise.bound(h)}


def agreement(a, b):
    if a["bound"] is None or b["bound"] is None:
        return float("nan")
    allowed = solver_promise.allowed_difference([a["bound"], b["bound"]], a["multipole_friction"])
    return float(np.nanmax(np.abs(a["friction"] - b["friction"]) / allowed))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--exe", default=str(ROOT / "build" / "beadmob"))
    parser.add_argument("--a", required=True, help="options of run A, e.g. '-fft_planner estimate'")
    parser.add_argument("--b", required=True)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--out", required=True)
    parser.add_argument("--title", default="")
    parser.add_argument("--note", default="", help="a paragraph written below the table")
    parser.add_argument("--ranks", type=int, default=2)
    parser.add_argument("--random", default="1000", help="bead counts of the random (Eden) bodies, comma-separated")
    parser.add_argument("--jittered", default="", help="bead counts of jittered off-lattice clusters (bench/offlattice), "
                        "comma-separated")
    parser.add_argument("--random-only", action="store_true", help="only the random (and jittered) bodies")
    args = parser.parse_args()
    exe = os.path.abspath(args.exe)
    sets = {"A": shlex.split(args.a), "B": shlex.split(args.b)}
    with tempfile.TemporaryDirectory() as work:
        work = Path(work)
        jobs = []
        for count in [int(n) for n in args.random.split(",")]:
            write_beads(work / f"random_{count}.txt", eden_body(count))
            (work / f"random_{count}.nml").write_text(f"&run output = 'random_{count}.h5' /\n&shape name = 'bead_file', "
                                                      f"file = 'random_{count}.txt' /\n&hydrodynamics /\n")
            jobs.append((f"random {count} beads", work / f"random_{count}.nml"))
        for count in [int(n) for n in args.jittered.split(",") if n]:
            write_beads(work / f"jittered_{count}.txt", jittered(count))
            (work / f"jittered_{count}.nml").write_text(f"&run output = 'jittered_{count}.h5' /\n&shape name = "
                                                        f"'bead_file', file = 'jittered_{count}.txt' /\n&hydrodynamics /\n")
            jobs.append((f"jittered {count} beads (off the lattice)", work / f"jittered_{count}.nml"))
        (work / "sphere_20.nml").write_text("&run output = 'sphere.h5' /\n&shape name = 'sphere', radius = 20 /\n"
                                            "&hydrodynamics /\n")
        if not args.random_only:
            jobs += [("paper cone (`shapes/cone.nml`)", ROOT / "shapes" / "cone.nml"),
                     ("ring_1mm (`shapes/ring_1mm.nml`)", ROOT / "shapes" / "ring_1mm.nml"),
                     ("sphere of radius 20 (33371 beads)", work / "sphere_20.nml")]
        rows = []
        for label, nml in jobs:
            runs = {"A": [], "B": []}
            for _ in range(args.repeats):
                for key in runs:
                    runs[key].append(run(exe, nml, sets[key], work, args.ranks))
            med = {key: {name: float(np.median([r[name] for r in rs])) for name in
                         ("blocks", "solve", "companion", "total", "product", "memory", "iterations")} for key, rs in runs.items()}
            rows.append((label, med, agreement(runs["A"][-1], runs["B"][-1])))
            print(label, med, flush=True)
    lines = [f"# {args.title or 'Side by side'}", "",
             f"Written by `bench/side_by_side/side_by_side.py`: {args.ranks} ranks, medians of {args.repeats} runs of "
             f"each option set in alternation, no table cache. A: `{args.a}`; B: `{args.b}`. Phases in seconds "
             "(`blocks`: the operator's set-up, FFT plans included); `product`: the order-L solve phase over its "
             "operator products; `iterations`: the Krylov iterations of the solves and the companion's, summed over the motions; `agree`: the largest friction difference of the last pair over what the solver "
             "promises for both (at most 1: equal within the promise).", "",
             "| job | blocks A | blocks B | solve A | solve B | companion A | companion B | product A (ms) | "
             "product B (ms) | job A | job B | B / A | memory A (MiB) | memory B (MiB) | iterations A | iterations B | agree |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for label, med, agree in rows:
        a, b = med["A"], med["B"]
        lines.append(f"| {label} | {a['blocks']:.2f} | {b['blocks']:.2f} | {a['solve']:.2f} | {b['solve']:.2f} | "
                     f"{a['companion']:.2f} | {b['companion']:.2f} | {1e3 * a['product']:.1f} | "
                     f"{1e3 * b['product']:.1f} | {a['total']:.2f} | {b['total']:.2f} | {b['total'] / a['total']:.2f} | "
                     f"{a['memory']:.0f} | {b['memory']:.0f} | {a['iterations']:.0f} | {b['iterations']:.0f} | {agree:.2f} |")
    if args.note:
        lines += ["", args.note]
    Path(args.out).write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
