#!/usr/bin/env python3
"""compare_result_files.py A.h5 B.h5: exit 0 when two beadmob result files of the same job (other
rank counts, resumed, cached, other FFT plans) hold the same data, to what the program promises.

Every dataset and attribute must be equal (floating point: bit for bit), except the run-specific
metadata (creation time, ranks, timings, memory, the estimate per rank), the solver's diagnostics (iterations,
residuals, condition estimates: they describe each run's own solve), and the results of the
Krylov solves. Those differ between runs by the solver error, which each file bounds itself:
the variational friction is within `solver_error_bound` sqrt(zeta_mm zeta_nn) of the exact
solve's (docs/theory.md T5, "Solver error bound", rounding included), so two runs may differ
by the sum of their bounds. Every tolerance below is derived from that, stated beside it;
none is taken from one machine's rounding.
"""
import sys

import h5py
import numpy as np

from solver_promise import bound, entry_scale

#: Of this run: its date, ranks, timings and memory, the plan's estimate, which is per rank, and
#: whether the ranks shared the products or each had the whole operator (the same products).
RUN_SPECIFIC = {"created", "mpi_ranks", "phase_seconds", "peak_memory_bytes", "phase_peak_memory_bytes",
                "estimated_peak_memory_bytes", "estimated_seconds", "replicated_products",
                "operator_choice", "operator_error_seconds"}
#: Each run's record of its own solve: compared only through the bounds they give.
SOLVER_DIAGNOSTICS = {"solve_true_relative_residual", "solve_iterations", "symmetry_error", "off_pattern",
                      "plain_symmetry_error", "variational_correction", "companion_iterations",
                      "companion_true_relative_residual", "solve_natural_relative_residual",
                      "companion_natural_relative_residual", "condition_estimate", "companion_condition_estimate",
                      "solver_error_bound", "companion_solver_error_bound", "preconditioned_smallest_eigenvalue"}
#: The rotational diffusion's axes: eigenvectors, defined up to sign (and for equal eigenvalues up
#: to a turn), compared through the eigenvalues (DIFFUSION_NUMBERS) and the mobility they come from.
SOLVER_DIAGNOSTICS |= {"rotational_axes"}
#: Eigenvalues, condition number and asymmetry of the frictions: functions of the frictions
#: compared below (their 0/1 flags are compared exactly).
SOLVER_DIAGNOSTICS |= {f"{prefix}_{name}" for prefix in ("friction", "multipole_friction")
                       for name in ("asymmetry", "condition_number", "eigenvalues", "min_eigenvalue")}
#: Order-L frictions: within the sum of the two runs' bounds on the scale sqrt(zeta_mm zeta_nn)
#: of the order-L friction (the lubrication correction is added exactly, no solver error).
ORDER_L_FRICTIONS = {"friction", "multipole_friction"}
#: Derived from the inverse of a friction: M = zeta^-1, dM = -M dzeta M to first order, so
#: |dM|_2 <= |M|_2^2 |dzeta|_2. With |dzeta|_2 <= 6 max|dzeta_mn| <= 6 b max_m zeta_mm <= 6 b |zeta|_2
#: and |M|_2 <= 6 max|M_ij|: max|dM_ij| <= 36 b cond(zeta) max|M_ij| (b: the summed bounds; x1.1
#: for the second order). The coefficients are entries of the body mobility times powers of the
#: reference length: the same relative bound on the scale of their largest. The centre of
#: mobility is a ratio of mobility entries, on the scale of the body's reference length.
ORDER_L_INVERSES = {"mobility", "body_mobility", "coefficients", "multipole_coefficients",
                    "mobility_at_centre_of_mobility", "centre_of_mobility"}
COMPANION_INVERSES = {"companion_body_mobility", "companion_coefficients"}
#: M(L) + 0.15 (M(L) - M(L - 1)) (theory.md T14): 1.15 the order-L error plus 0.15 the companion's.
EXTRAPOLATED = {"extrapolated_body_mobility", "extrapolated_coefficients"}
#: The error bar: max(0.6 s_ij, 0.03 b_ij) and max(0.4 s_ij, 0.03 b_ij) of the steps
#: s = |M(L) - M(L - 1)| (theory.md T14): changed by at most the two mobilities' changes, on
#: the scale of the mobility (or coefficients) for the plain errors, and divided by the
#: smallest sqrt(M_ii M_jj) for the scaled ones.
ERROR_BARS = {"body_mobility_error", "coefficient_error", "extrapolated_coefficient_error"}
SCALED_ERROR_BARS = {"scaled_body_mobility_error", "scaled_coefficient_error",
                     "scaled_extrapolated_coefficient_error", "estimated_error", "estimated_extrapolated_error",
                     "accuracy_estimated_error", "truncation_estimated_error"}
#: Per-bead forces and torques: the plain solutions, first order in the solver error. The
#: energy-norm error of a solution is sqrt(bound) of its right-hand side's (theory.md T5);
#: one bead's share of it is compared on the largest bead's scale with 10 for the passage from
#: the energy norm to single entries (the preconditioner's condition at L <= 3, theory.md T11).
BEAD_RESULTS = {"bead_forces"}
#: The pfft far field's measured error (docs/theory.md T16): quadratic forms of the solutions in
#: E = A - A~ and their spread over the sampled rows, first order in the solutions' error: as the
#: bead forces, 10 x 2 sqrt(bound / 2) on the scale of each item's largest entry.
OPERATOR_ERRORS = {"operator_error", "operator_error_friction", "operator_error_scaled", "operator_friction_change",
                   "operator_friction_standard_error", "operator_friction_second_order",
                   "operator_body_mobility_change", "operator_body_mobility_error",
                   "scaled_operator_body_mobility_error", "operator_coefficient_error", "operator_error_row_terms",
                   "operator_error_row_sizes"}


def collect(path):
    items = {}
    with h5py.File(path, "r") as f:
        for name, value in f.attrs.items():
            items["@/" + name] = value
        def visit(name, obj):
            for attr, value in obj.attrs.items():
                items[f"@{name}/{attr}"] = value
            if isinstance(obj, h5py.Dataset):
                items[name] = obj[()]
        f.visititems(visit)
    return items


def solver_bounds(a, b):
    """The promised differences: (order L, companion) bounds summed over both runs (None: a run
    states none)."""
    def summed(name):
        with h5py.File(a, "r") as f, h5py.File(b, "r") as g:
            pair = [bound(f["hydrodynamics"], name), bound(g["hydrodynamics"], name)] \
                if "hydrodynamics" in f and "hydrodynamics" in g else [None]
        return None if None in pair else sum(pair)
    return summed("solver_error_bound"), summed("companion_solver_error_bound")


def inverse_tolerance(bound, friction):
    """max|dM| / max|M| for M = friction^-1 (see ORDER_L_INVERSES)."""
    if bound is None or not np.all(np.isfinite(friction)):
        return None
    return 1.1 * 36 * bound * np.linalg.cond(friction)


#: /diffusion (src/hydro/brownian_numbers.f90): functions of the order-L mobility about the centre
#: of mobility M, whose entries move by at most e = rel_l max|M| (ORDER_L_INVERSES). D_t = tr(M_tt)/3
#: moves by e, the eigenvalues of M_rr by |dM_rr|_2 <= 3 e (Weyl), a relaxation rate (6 D -+ 2 Delta,
#: 3 (D + D_i): Lipschitz constant <= 8 in the eigenvalues) by 24 e, and 1/x by dx / x^2.
DIFFUSION_NUMBERS = {"translational_diffusion", "stokes_radius", "rotational_diffusion", "relaxation_times",
                     "harmonic_mean_relaxation_time", "centre_of_diffusion"}


def diffusion_tolerance(name, x, first, rel_l):
    """(allowed max |x - y|, derivation) for a /diffusion number (DIFFUSION_NUMBERS)."""
    e = 1.1 * rel_l * np.nanmax(np.abs(first["hydrodynamics/mobility_at_centre_of_mobility"]))
    d_t = float(first["@diffusion/translational_diffusion"])
    if name == "translational_diffusion":
        allowed = e
    elif name == "stokes_radius":
        allowed = float(np.max(x)) * e / (d_t - e)
    elif name == "rotational_diffusion":
        allowed = 3 * e
    elif name == "centre_of_diffusion":
        allowed = rel_l * max(float(np.nanmax(np.abs(first["hydrodynamics/centre_of_mobility"]))),
                              float(first.get("@shape/reference_length", 1.0)))
    else:   # times: 1 / rate, the rate moving by 24 e (the harmonic mean's by 6 e)
        rates = 1.0 / np.asarray(x, float)
        change = 24 * e if name == "relaxation_times" else 6 * e
        allowed = float(np.max(change / (rates * (rates - change))))
    return allowed, f"{allowed:.1e} (from the mobility's {rel_l:.1e} relative)"


def tolerance(key, x, first, bounds):
    """(allowed max |x - y|, how it was derived) for a solver result, None for exact items."""
    name = key.rsplit("/", 1)[-1]
    order_l, companion = bounds
    if key.lstrip("@").startswith("diffusion") and name in DIFFUSION_NUMBERS:
        rel = inverse_tolerance(order_l, first.get("hydrodynamics/multipole_friction"))
        return None if rel is None else diffusion_tolerance(name, x, first, rel)
    if not key.lstrip("@").startswith("hydrodynamics"):
        return None
    hydro = lambda item: first.get(f"hydrodynamics/{item}")
    if name in ORDER_L_FRICTIONS and order_l is not None:
        return order_l * entry_scale(hydro("multipole_friction")), f"{order_l:.1e} sqrt(zeta_mm zeta_nn)"
    if name == "companion_friction" and companion is not None:
        return companion * entry_scale(x), f"{companion:.1e} sqrt(zeta_mm zeta_nn)"
    if name in OPERATOR_ERRORS and order_l is not None:
        rel = 10 * 2 * np.sqrt(order_l / 2)
        return rel * np.nanmax(np.abs(x)), f"{rel:.1e} relative"
    rel_l = inverse_tolerance(order_l, hydro("multipole_friction"))
    rel_c = inverse_tolerance(companion, hydro("companion_friction")) if companion is not None else None
    if name in ORDER_L_INVERSES and rel_l is not None:
        scale = np.nanmax(np.abs(x))
        if name == "centre_of_mobility":
            scale = max(scale, float(first.get("@shape/reference_length", 1.0)))
        return rel_l * scale, f"{rel_l:.1e} relative"
    if name in COMPANION_INVERSES and rel_c is not None:
        return rel_c * np.nanmax(np.abs(x)), f"{rel_c:.1e} relative"
    if rel_l is None or rel_c is None:
        return None
    if name in EXTRAPOLATED:
        rel = 1.15 * rel_l + 0.15 * rel_c
        return rel * np.nanmax(np.abs(x)), f"{rel:.1e} relative"
    if name in ERROR_BARS:
        values = hydro("coefficients" if "coefficient" in name else "body_mobility")
        allowed = (rel_l + rel_c) * np.nanmax(np.abs(values))
        return allowed, f"{allowed:.1e} (on the scale of the {'coefficients' if 'coefficient' in name else 'mobility'})"
    if name in SCALED_ERROR_BARS:
        mobility = hydro("body_mobility")
        allowed = (rel_l + rel_c) * np.nanmax(np.abs(mobility)) / np.nanmin(np.abs(np.diag(mobility)))
        return allowed, f"{allowed:.1e} (scaled by the smallest diagonal mobility)"
    if name in BEAD_RESULTS:
        rel = 10 * 2 * np.sqrt(order_l / 2)
        return rel * np.nanmax(np.abs(x)), f"{rel:.1e} relative"
    return None


def main(a, b):
    skipped = RUN_SPECIFIC | SOLVER_DIAGNOSTICS
    first = {k: v for k, v in collect(a).items() if k.rsplit("/", 1)[-1] not in skipped}
    second = {k: v for k, v in collect(b).items() if k.rsplit("/", 1)[-1] not in skipped}
    bounds = solver_bounds(a, b)
    problems = [f"only in {a}: {k}" for k in sorted(first.keys() - second.keys())]
    problems += [f"only in {b}: {k}" for k in sorted(second.keys() - first.keys())]
    compared = 0
    for key in sorted(first.keys() & second.keys()):
        compared += 1
        x, y = np.asarray(first[key]), np.asarray(second[key])
        if x.shape != y.shape:
            problems.append(f"differs in shape: {key}")
            continue
        allowed = tolerance(key, x, first, bounds) if x.dtype.kind == "f" else None
        if allowed is None:
            if not np.array_equal(x, y, equal_nan=x.dtype.kind == "f"):
                problems.append(f"differs: {key}")
            continue
        limit, derivation = allowed
        if not np.array_equal(np.isnan(x), np.isnan(y)):
            problems.append(f"not computed in one file only: {key}")
            continue
        difference = np.nan_to_num(np.abs(x - y))
        excess = difference - np.nan_to_num(np.broadcast_to(limit, x.shape), nan=0.0)
        if np.any(excess > 0):
            problems.append(f"differs beyond the promised {derivation}: {key} (by {np.max(difference):.2e})")
    for p in problems:
        print(p)
    print(f"solver error bounds of the two runs, summed: order L {bounds[0]}, companion {bounds[1]}")
    print(f"compared {compared} items: {'identical to the promise' if not problems else f'{len(problems)} differences'}")
    return 1 if problems else 0


if __name__ == "__main__":
    import argparse
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("first")
    parser.add_argument("second")
    args = parser.parse_args()
    sys.exit(main(args.first, args.second))
