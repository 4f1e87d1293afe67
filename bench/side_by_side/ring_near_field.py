#!/usr/bin/env python3
"""What a far-field approximation would cost a paper ring: the exact near field it needs, measured
beside the exact FFT product; writes bench/side_by_side/ring_near_field.md (docs/theory.md T4,
"What bounds a hollow body's product").

An approximate far field on a grid of spacing h (the precorrected FFT, docs/theory.md T16) keeps
its interpolation error, (s h / r)^s for pairs at distance r, by computing the pairs within
r_near exactly; the same error at h = 2 d as today's defaults at h = 1 d (s = 4, r_near = 3 d)
needs r_near = 6 d. The pfft operator on the unit grid runs ring_1mm with both radii: on the
lattice its interpolation is exact (weights 1 and 0, docs/theory.md T16), so the friction is the
FFT operator's and the difference between the two radii is what the pairs from 3 d to 6 d cost:
set-up, each product, memory. Beside them the FFT operator's ring_1mm job and the arrowhead's,
the yardstick of bench/everyday_jobs (a ring within 2x of the arrowhead). The jobs alternate, --repeats times,
2 ranks; medians.

usage: python3 bench/side_by_side/ring_near_field.py [--exe build/beadmob] [--repeats 5]
"""
import argparse
import os
import platform
import statistics
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "e2e"))
sys.path.insert(0, str(ROOT / "bench" / "operator_check"))
import solver_promise  # noqa: E402
from lattice_crossover import RANKS, timed_job  # noqa: E402  (the same launch)

PHASES = ["blocks", "near_field", "solve", "companion", "lubrication", "total"]
JOBS = [  # (label, shape, operator, further options)
    ("arrowhead, fft", "arrowhead", "fft", ()),
    ("ring_1mm, fft", "ring_1mm", "fft", ()),
    ("ring_1mm, pfft, r_near = 3 d", "ring_1mm", "pfft", ()),
    ("ring_1mm, pfft, r_near = 6 d", "ring_1mm", "pfft", ("-pfft_near_radius", "6")),
]


def read(h):
    seconds = h.attrs["phase_seconds"]
    return {"job": float(seconds[PHASES.index("total")]), "blocks": float(seconds[PHASES.index("blocks")]),
            "solve": float(seconds[PHASES.index("solve")]), "companion": float(seconds[PHASES.index("companion")]),
            "products": int(np.sum(h.attrs["solve_iterations"])), "memory": float(h.attrs["peak_memory_bytes"]) / 2**30,
            "friction": h["multipole_friction"][()], "bound": solver_promise.bound(h)}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--exe", default=str(ROOT / "build" / "beadmob"))
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    exe = os.path.abspath(args.exe)
    runs = {label: [] for label, *_ in JOBS}
    with tempfile.TemporaryDirectory() as work:
        work = Path(work)
        for _, shape, _, _ in JOBS:
            text = (ROOT / "shapes" / f"{shape}.nml").read_text()
            (work / f"{shape}.nml").write_text(text.replace(f"output = '{shape}.h5'", "output = 'result.h5'"))
        for _ in range(args.repeats):
            for label, shape, operator, options in JOBS:
                _, values = timed_job(exe, work / f"{shape}.nml", operator, work, work / "result.h5", read, options)
                runs[label].append(values)
    median = {label: {key: statistics.median(v[key] for v in values) for key in ("job", "blocks", "solve", "companion",
                                                                                  "memory")}
              for label, values in runs.items()}
    reference = runs["ring_1mm, fft"][-1]

    out = ["# A ring's exact near field, the price of an approximate far field", "",
           f"Written by `bench/side_by_side/ring_near_field.py` on {platform.machine()}, {os.cpu_count()} cores: "
           f"{RANKS} ranks, the jobs alternated, medians of {args.repeats} runs. `job` is the friction job's own time "
           "(phase `total`), `per product` the solve phase over its Krylov iterations (the solves' products and "
           "the work around them), memory the peak resident set of the largest rank. Friction difference: the "
           "largest entry of |friction - the FFT operator's| over the two runs' solver bounds "
           "(tests/e2e/solver_promise.py), last runs; at most 1 is the same friction within the solver's promise.", "",
           "| job | job (s) | blocks (s) | solve (s) | companion (s) | products | per product (ms) | memory/rank (GiB) "
           "| friction difference / allowed |", "|---|---|---|---|---|---|---|---|---|"]
    for label, *_ in JOBS:
        m, last = median[label], runs[label][-1]
        if label.startswith("ring_1mm"):
            allowed = solver_promise.allowed_difference([last["bound"], reference["bound"]], reference["friction"])
            difference = f"{np.max(np.abs(last['friction'] - reference['friction']) / allowed):.2f}"
        else:
            difference = "(another body)"
        out.append(f"| {label} | {m['job']:.2f} | {m['blocks']:.2f} | {m['solve']:.2f} | {m['companion']:.2f} | "
                   f"{last['products']} | {1e3 * m['solve'] / last['products']:.1f} | {m['memory']:.2f} | {difference} |")
    near3, near6 = median["ring_1mm, pfft, r_near = 3 d"], median["ring_1mm, pfft, r_near = 6 d"]
    products = runs["ring_1mm, pfft, r_near = 6 d"][-1]["products"]
    budget = 2 * median["arrowhead, fft"]["job"]
    out += ["", "The pairs from 3 d to 6 d alone (r_near = 6 d less r_near = 3 d): "
            f"set-up {near6['blocks'] - near3['blocks']:.2f} s, "
            f"{1e3 * (near6['solve'] - near3['solve']) / products:.1f} ms per product in the solve, "
            f"{near6['memory'] - near3['memory']:.2f} GiB per rank. "
            f"The budget for a ring's job, twice the arrowhead's: {budget:.2f} s; "
            f"the ring's exact job with the FFT operator: {median['ring_1mm, fft']['job']:.2f} s, "
            f"{1e3 * median['ring_1mm, fft']['solve'] / reference['products']:.1f} ms per product."]
    (Path(__file__).resolve().parent / "ring_near_field.md").write_text("\n".join(out) + "\n")
    print("\n".join(out))


if __name__ == "__main__":
    main()
