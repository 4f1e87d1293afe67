#!/usr/bin/env python3
"""Regression guard: compare a result file with the committed reference values.

    check_regression.py CASE RESULT.h5      fails if the friction (with and without the lubrication
                                            correction) or the paper coefficients moved by more
                                            than 1e-8 relative (max-norm) from references.json
    check_regression.py --update DIR        rewrites references.json from DIR/regression_<case>.h5
                                            and records the commit that produced them

The references are results of beadmob itself, so they guard against unintended change, not
against error: accuracy is tested elsewhere against exact formulas and the paper. The runs use
-ksp_rtol 1e-6 and -fft_planner estimate. Each run is within its own solver error bound b of the
exact solve (docs/theory.md T5, recorded in the file as solver_error_bound, ~1e-10 here), so a
run and the reference may differ by about 2b in the frictions and by the inverse's amplification
of it in the coefficients (tests/e2e/compare_result_files.py): the check allows the larger of 1e-8
and that promise, so the solver's freedom on another CPU never fails it, and a change of the
code beyond both does."""
import json
import subprocess
import sys
from datetime import date
from pathlib import Path

import h5py
import numpy as np

HERE = Path(__file__).resolve().parent
REFERENCES = HERE / "references.json"
CASES = ("cone", "chain", "doublet")
QUANTITIES = ("friction", "multipole_friction", "coefficients")
TOLERANCE = 1e-8


def promised(values, bound):
    """Relative (to the largest entry) change two runs within bound b of the exact solve may show."""
    zeta = values["multipole_friction"]
    friction = 2 * bound * np.sqrt(np.outer(np.diag(zeta), np.diag(zeta))).max() / np.abs(zeta).max()
    coefficients = 1.1 * 36 * 2 * bound * np.linalg.cond(zeta)
    return {"friction": friction, "multipole_friction": friction, "coefficients": coefficients}


def read(path):
    with h5py.File(path) as f:
        g = f["hydrodynamics"]
        values = {q: np.asarray(g[q][()], dtype=float) for q in QUANTITIES}
        values["solver_error_bound"] = float(g.attrs.get("solver_error_bound", 0.0))
        settings = {"multipole_order": int(g.attrs["multipole_order"]),
                    "lubrication": bool(g.attrs["lubrication"]),
                    "n_beads": int(f["geometry"].attrs["n_beads"])}
    return values, settings


def update(run_dir):
    commit = subprocess.run(["git", "rev-parse", "HEAD"], cwd=HERE, capture_output=True, text=True).stdout.strip()
    # Only the code that makes the numbers counts (src/ and the build).
    dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "--", "src", "CMakeLists.txt"],
                           cwd=HERE.parents[2], capture_output=True, text=True).stdout.strip()
    out = {"made_by_commit": commit + (" (with uncommitted changes)" if dirty else ""),
           "date": date.today().isoformat(), "tolerance": TOLERANCE,
           "options": "-ksp_rtol 1e-6 -fft_planner estimate", "cases": {}}
    for case in CASES:
        values, settings = read(Path(run_dir) / f"regression_{case}.h5")
        out["cases"][case] = {"input": f"tests/e2e/regression/{case}.nml", **settings,
                              **{q: values[q].tolist() for q in QUANTITIES}}
    REFERENCES.write_text(json.dumps(out, indent=1) + "\n")
    print(f"wrote {REFERENCES} ({commit})")


def check(case, path):
    reference = json.loads(REFERENCES.read_text())
    expected = reference["cases"][case]
    values, settings = read(path)
    failures = []
    for key, value in settings.items():
        if expected[key] != value:
            failures.append(f"{key}: {value} (reference {expected[key]})")
    promise = promised(values, values["solver_error_bound"])
    for q in QUANTITIES:
        ref = np.asarray(expected[q])
        change = np.max(np.abs(values[q] - ref)) / np.max(np.abs(ref))
        allowed = max(TOLERANCE, promise[q])
        print(f"{case} {q}: largest change {change:.1e} (relative to max |reference|; allowed {allowed:.1e})")
        if not change <= allowed:   # also catches NaN
            failures.append(f"{q} moved by {change:.1e} > {allowed:.1e}")
    if failures:
        print(f"regression: {case} differs from the references made by {reference['made_by_commit']}: "
              + "; ".join(failures))
        return 1
    return 0


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "--update":
        update(sys.argv[2])
    elif len(sys.argv) == 3 and sys.argv[1] in CASES:
        sys.exit(check(sys.argv[1], sys.argv[2]))
    else:
        sys.exit(__doc__)
