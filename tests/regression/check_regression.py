#!/usr/bin/env python3
"""Regression guard (issue 7): compare a result file with the committed reference values.

    check_regression.py CASE RESULT.h5      fails if the friction (with and without the lubrication
                                            correction) or the paper coefficients moved by more
                                            than 1e-8 relative (max-norm) from references.json
    check_regression.py --update DIR        rewrites references.json from DIR/regression_<case>.h5
                                            and records the commit that produced them

The references are results of beadmob itself, so they guard against unintended change, not
against error: accuracy is tested elsewhere against exact formulas and the paper. The runs use
-ksp_rtol 1e-6 and -fft_planner estimate: the friction is variational, its solver error ~1e-11 at
that tolerance (bench/solver_tolerance.md), and rounding differences from run to run or between
machines stay far below the 1e-8 tolerance."""
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


def read(path):
    with h5py.File(path) as f:
        g = f["hydrodynamics"]
        values = {q: np.asarray(g[q][()], dtype=float) for q in QUANTITIES}
        settings = {"multipole_order": int(g.attrs["multipole_order"]),
                    "lubrication": bool(g.attrs["lubrication"]),
                    "n_beads": int(f["geometry"].attrs["n_beads"])}
    return values, settings


def update(run_dir):
    commit = subprocess.run(["git", "rev-parse", "HEAD"], cwd=HERE, capture_output=True, text=True).stdout.strip()
    # Only the code that makes the numbers counts (src/ and the build).
    dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "--", "src", "CMakeLists.txt"],
                           cwd=HERE.parents[1], capture_output=True, text=True).stdout.strip()
    out = {"made_by_commit": commit + (" (with uncommitted changes)" if dirty else ""),
           "date": date.today().isoformat(), "tolerance": TOLERANCE,
           "options": "-ksp_rtol 1e-6 -fft_planner estimate", "cases": {}}
    for case in CASES:
        values, settings = read(Path(run_dir) / f"regression_{case}.h5")
        out["cases"][case] = {"input": f"tests/regression/{case}.nml", **settings,
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
    for q in QUANTITIES:
        ref = np.asarray(expected[q])
        change = np.max(np.abs(values[q] - ref)) / np.max(np.abs(ref))
        print(f"{case} {q}: largest change {change:.1e} (relative to max |reference|)")
        if not change <= TOLERANCE:   # also catches NaN
            failures.append(f"{q} moved by {change:.1e} > {TOLERANCE:g}")
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
