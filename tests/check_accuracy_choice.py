#!/usr/bin/env python3
"""check_accuracy_choice.py RESULT.h5 TARGET: a run with an accuracy target used exactly the
settings of the candidate it records (L, the sigma = 2 degree max(L - 2, 0), shell layers and the
Krylov tolerance, as listed in bench/accuracy_rule.py), recorded the target, and its expected
error meets the target whenever it says so. Whether the promise holds on real shapes is measured
by bench/accuracy_check.py, not here (this body is not in the tuning data)."""
import sys
from pathlib import Path

import h5py

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "bench"))
from accuracy_rule import CANDIDATES  # noqa: E402

path, target = sys.argv[1], float(sys.argv[2])
with h5py.File(path) as f:
    g = f["hydrodynamics"]
    a = {k: g.attrs[k] for k in g.attrs}
    setting = a["accuracy_setting"].decode() if isinstance(a["accuracy_setting"], bytes) else a["accuracy_setting"]
    order, rtol, shell = CANDIDATES[setting]
    effective = f["input/effective_namelist"][()]
    effective = effective.decode() if isinstance(effective, bytes) else str(effective)
    failures = []
    if abs(a["accuracy_target"] - target) > 1e-15 * target:
        failures.append(f"target recorded as {a['accuracy_target']}, asked {target}")
    used = (int(g.attrs["multipole_order"]), int(g.attrs["potential_order"]), int(a["shell_layers"]),
            float(a["ksp_relative_tolerance"]))
    if used != (order, max(order - 2, 0), shell, rtol):
        failures.append(f"{setting} is (L, L2, shell, rtol) = {(order, max(order - 2, 0), shell, rtol)}, used {used}")
    if int(a["accuracy_target_met"]) == 1 and not a["accuracy_expected_error"] <= target:
        failures.append(f"target met, but expected error {a['accuracy_expected_error']} > {target}")
    if f"chosen for accuracy = " not in effective or f"multipole_order = {order}" not in effective:
        failures.append("the effective namelist does not show the chosen settings and the target")
    if int(a["all_converged"]) != 1:
        failures.append("a Krylov solve did not converge")
print(f"{path}: target {target:g} -> {setting} (expected error {a['accuracy_expected_error']:.2e})")
for failure in failures:
    print("FAILED:", failure)
sys.exit(1 if failures else 0)
