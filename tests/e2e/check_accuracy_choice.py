#!/usr/bin/env python3
"""check_accuracy_choice.py RESULT.h5 TARGET: a run with an accuracy target used the settings of
the candidate it records (L, the sigma = 2 degree max(L - 2, 0), shell layers and the Krylov
tolerance, as listed in bench/accuracy/accuracy_rule.py) or, where its own error estimate missed the
target (docs/theory.md T14), the same tolerance one or more orders higher on the full model, at
most L = 4 (src/solvers/accuracy_choice.f90); it recorded the target, and says the target is met
exactly when its own estimate (or, without one, the rule's promise) is within it. Whether the
promise holds on real shapes is measured by bench/accuracy/accuracy_check.py and bench/error_estimate/error_estimate.py,
not here (this body is not in the tuning data)."""
import sys
from pathlib import Path

import h5py

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "bench" / "accuracy"))
from accuracy_rule import CANDIDATES  # noqa: E402

MAX_ACCURACY_ORDER = 4   # src/solvers/accuracy_choice.f90


def text(value):
    return value.decode() if isinstance(value, bytes) else str(value)


path, target = sys.argv[1], float(sys.argv[2])
with h5py.File(path) as f:
    g = f["hydrodynamics"]
    a = {k: g.attrs[k] for k in g.attrs}
    setting = text(a["accuracy_setting"])
    order, rtol, shell = CANDIDATES[setting]
    effective = text(f["input/effective_namelist"][()])
failures = []
if abs(a["accuracy_target"] - target) > 1e-15 * target:
    failures.append(f"target recorded as {a['accuracy_target']}, asked {target}")
raised = int(a["accuracy_raised_order"])
estimated = float(a["accuracy_estimated_error"])
if raised:
    if not order < raised <= MAX_ACCURACY_ORDER:
        failures.append(f"raised to L = {raised} from the candidate's L = {order} (allowed: up to {MAX_ACCURACY_ORDER})")
    expected = (raised, raised - 2, 0, rtol)
else:
    expected = (order, max(order - 2, 0), shell, rtol)
used = (int(a["multipole_order"]), int(a["potential_order"]), int(a["shell_layers"]),
        float(a["ksp_relative_tolerance"]))
if used != expected:
    failures.append(f"{setting} (raised to L = {raised}) is (L, L2, shell, rtol) = {expected}, used {used}")
met = int(a["accuracy_target_met"]) == 1
if estimated >= 0:   # the run's own estimate decides
    if met != (estimated <= target):
        failures.append(f"target_met = {met}, but the run's own estimate is {estimated:.3e} against {target}")
    if estimated > target and used[0] < MAX_ACCURACY_ORDER:
        failures.append(f"estimate {estimated:.3e} misses the target at L = {used[0]}, but L was not raised")
elif met and not a["accuracy_expected_error"] <= target:
    failures.append(f"target met, but expected error {a['accuracy_expected_error']} > {target}")
if "chosen for accuracy = " not in effective or f"multipole_order = {used[0]}" not in effective:
    failures.append("the effective namelist does not show the chosen settings and the target")
if int(a["all_converged"]) != 1:
    failures.append("a Krylov solve did not converge")
print(f"{path}: target {target:g} -> {setting}, L = {used[0]} (rule's expected error "
      f"{a['accuracy_expected_error']:.2e}, own estimate {estimated:.2e}, raised to L = {raised})")
for failure in failures:
    print("FAILED:", failure)
sys.exit(1 if failures else 0)
