#!/usr/bin/env python3
"""check_error_estimate.py RUN.h5 REFERENCE.h5: the error bar of a default run (docs/theory.md T14)
is in the result file and bounds the true error against a high-order reference.

RUN.h5: the default settings (L = 2, one surface layer, tolerance 1e-3) on a small body;
REFERENCE.h5: the same beads at L = 5 on the full model with a tight tolerance, whose own
truncation error on small bodies is ~1e-4 (bench/accuracy/l_convergence.md: L = 5 column), ten times below
the errors checked here. The estimate is statistical (it bounds 95 % of the coefficients of
bench/error_estimate/error_estimate.md), so the checks are: the estimated error of the whole mobility (largest
entry) bounds its true error and overestimates it less than tenfold; at least four of the five
coefficients are bounded and none misses by more than twice its estimate; the extrapolated
mobility is closer to the reference than the order-L one; the postprocessor's error bar equals
beadmob's.
"""
import sys
from pathlib import Path

import h5py
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "scripts"))
from beadmob_post.mobility import compute_coefficients  # noqa: E402
from beadmob_post.results import load_result  # noqa: E402

ENTRIES = [(0, 0), (1, 1), (2, 2), (3, 1), (4, 0)]   # mu11 mu22 mu33 mu42 mu51 in the body mobility
REQUIRED = ["companion_friction", "companion_body_mobility", "companion_coefficients", "body_mobility_error",
            "scaled_body_mobility_error", "coefficient_error", "scaled_coefficient_error",
            "extrapolated_body_mobility", "extrapolated_coefficients", "extrapolated_coefficient_error"]


def main(run_path, reference_path):
    failures = []
    with h5py.File(run_path) as run, h5py.File(reference_path) as ref:
        g, r = run["hydrodynamics"], ref["hydrodynamics"]
        missing = [name for name in REQUIRED if name not in g]
        if g.attrs.get("error_estimate") != 1 or missing:
            print(f"FAILED: no error estimate in {run_path} (missing {missing})")
            return 1
        if int(g.attrs["companion_order"]) != int(g.attrs["multipole_order"]) - 1:
            failures.append("the companion is not of order L - 1")
        if not np.all(np.asarray(g.attrs["companion_converged_reason"])[np.asarray(g.attrs["solve_source"]) == 0] > 0):
            failures.append("a companion solve did not converge")
        m, truth_m = g["body_mobility"][()], r["body_mobility"][()]
        scale = np.sqrt(np.outer(np.diag(truth_m), np.diag(truth_m)))
        truth = np.abs(m - truth_m) / scale
        estimate = g["scaled_body_mobility_error"][()]
        largest = float(g.attrs["estimated_error"])
        print(f"whole mobility: true error {truth.max():.2e}, estimate {largest:.2e}")
        if not truth.max() <= largest < 10 * truth.max():
            failures.append("the largest-entry estimate does not bound the true error within 10x")
        bounded, worst = 0, 0.0
        for k, (i, j) in enumerate(ENTRIES):
            print(f"coefficient {k + 1}: true error {truth[i, j]:.2e}, estimate {estimate[i, j]:.2e}")
            bounded += truth[i, j] <= estimate[i, j]
            worst = max(worst, truth[i, j] / estimate[i, j])
        if bounded < 4 or worst > 2:
            failures.append(f"coefficients: {bounded} of 5 bounded, worst true/estimate {worst:.2f}")
        extrapolated = np.abs(g["extrapolated_body_mobility"][()] - truth_m) / scale
        print(f"extrapolated: largest true error {extrapolated.max():.2e} (order L: {truth.max():.2e})")
        if not extrapolated.max() < truth.max():
            failures.append("the extrapolated mobility is not closer to the reference")
        errors = g["coefficient_error"][()]
    bar = compute_coefficients(load_result(run_path)).error_bar
    if bar is None or not np.allclose(bar.errors, errors, rtol=1e-10, atol=1e-15):
        failures.append(f"the postprocessor's error bar {None if bar is None else bar.errors} differs from {errors}")
    for failure in failures:
        print("FAILED:", failure)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:3]))
