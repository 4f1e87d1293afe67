#!/usr/bin/env python3
"""The error bar of a run: how well a run's own truncation-error estimate (its order-L
result against the companion solve of order L - 1 on the same beads, docs/theory.md T14) bounds
its true error, and whether the extrapolated value is closer to the truth than the order-L one.

    python3 bench/error_estimate/error_estimate.py collect [--bodies a,b] [--settings s,t] [--exe build/beadmob]
    python3 bench/error_estimate/error_estimate.py calibrate      # the factors of src/hydro/error_estimate.f90
    python3 bench/error_estimate/error_estimate.py report         # bench/error_estimate/error_estimate.md and .csv (calibration
                                                   # section from bench/error_estimate/error_estimate_tuning.csv)
    python3 bench/error_estimate/error_estimate.py recheck [--exe build/beadmob]
                                                   # a later build's default runs against the references kept
                                                   # in error_estimate.csv: bench/error_estimate/error_estimate_recheck.md

Bodies: a tuning set (used to choose the estimate's two factors) and a check set that was not
(the seven paper shapes, a torus, a spheroid, a flat disc and a bent rod). Each body is run at
the default settings (which carry the estimate) and at a reference: L = 4, the full model (no
shell), Krylov tolerance 1e-7 (the exact Stokes mobility of the bead model up to the L = 4
truncation, ~1e-4, bench/accuracy/l_convergence_arrowhead.md). The tuning set is also run at L = 1 with
the default's shell model and tolerance (the companion, computed separately) so that the
factors can be fitted before the estimate exists in a build.

Error measure (docs/theory.md T14): entry (i, j) of the 6x6 body-frame mobility M against the
reference, |dM_ij| / sqrt(M_ii M_jj) -- relative on the diagonal, and for a coupling relative to
the largest value an entry of a positive definite matrix can have there, so a coupling near zero
is measured on the scale of its block, not its own. The paper's five coefficients are entries
of M (times pi L or pi L^2), measured the same way.
Runs go to bench/error_estimate/error_estimate_runs/ (kept: a second call only runs what is missing).
"""
import argparse
import csv
import sys
from pathlib import Path

import h5py
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "accuracy"))   # bench/accuracy/accuracy.py
from accuracy import launch, shape_group, write_csv  # noqa: E402

HERE = Path(__file__).resolve().parent   # this study's folder: bench/<study>/
ROOT = HERE.parents[1]
RUNS = HERE / "error_estimate_runs"
PAPER_SHAPES = ["cone", "crescent_moon", "arrowhead", "ring_1mm", "ring_2mm", "ring_3mm", "ring_4mm"]
# name -> (&shape group, role); bead files are written by make_bead_file
BODIES = {
    "sphere_r6": ("&shape name = 'sphere', radius = 6 /", "tune"),
    "prolate": ("&shape name = 'spheroid', semi_axes = 12, 5, 5 /", "tune"),
    "slab": ("&shape name = 'box', box_beads = 10, 6, 3 /", "tune"),
    "chain_12": ("&shape name = 'chain', n_beads = 12 /", "tune"),
    "cluster_300": ("&shape name = 'bead_file', file = 'cluster_300.txt' /", "tune"),
    "cluster_600": ("&shape name = 'bead_file', file = 'cluster_600.txt' /", "tune"),
    "cluster_1500": ("&shape name = 'bead_file', file = 'cluster_1500.txt' /", "tune"),
    "l_block": ("&shape name = 'bead_file', file = 'l_block.txt' /", "tune"),
    "sphere_r10": ("&shape name = 'sphere', radius = 10 /", "tune"),
    "plate": ("&shape name = 'box', box_beads = 20, 12, 6 /", "tune"),
    **{s: (None, "check") for s in PAPER_SHAPES},
    "torus": ("&shape name = 'torus', major_radius = 14, minor_radius = 4 /", "check"),
    "spheroid": ("&shape name = 'spheroid', semi_axes = 18, 8, 8 /", "check"),
    "disc": ("&shape name = 'bead_file', file = 'disc.txt' /", "check"),
    "bent_rod": ("&shape name = 'bead_file', file = 'bent_rod.txt' /", "check"),
}
# label -> (&hydrodynamics entries, command-line options)
SETTINGS = {
    "default": ("", ""),
    "L1_shell1": ("multipole_order = 1, shell_layers = 1", ""),
    "L4_tight": ("multipole_order = 4, shell_layers = 0", "-ksp_rtol 1e-7"),
}
REFERENCE = "L4_tight"
COEFFICIENTS = ["mu11", "mu22", "mu33", "mu42", "mu51"]
# the paper's coefficients as (row, column) of the body-frame mobility and the power of the
# reference length in their normalisation (pi eta L mu_tt, pi eta L^2 mu_rt)
COEFFICIENT_ENTRIES = [(0, 0), (1, 1), (2, 2), (3, 1), (4, 0)]


def make_bead_file(name):
    """The tuning and check bodies given as bead files (integer lattice nodes), reproducibly."""
    path = RUNS / f"{name}.txt"
    if path.exists():
        return
    if name.startswith("cluster_"):
        # Eden growth on the lattice: a compact random aggregate without any symmetry.
        n = int(name.split("_")[1])
        rng = np.random.default_rng(n)
        beads, members = [(0, 0, 0)], {(0, 0, 0)}
        steps = [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)]
        while len(beads) < n:
            b = beads[rng.integers(len(beads))]
            s = steps[rng.integers(6)]
            c = (b[0] + s[0], b[1] + s[1], b[2] + s[2])
            if c not in members:
                members.add(c)
                beads.append(c)
        points = np.array(beads)
    elif name == "l_block":
        # two slabs at right angles, one thicker: couplings of every kind
        g = np.mgrid[0:10, 0:4, 0:3].reshape(3, -1).T
        h = np.mgrid[0:3, 0:4, 3:12].reshape(3, -1).T
        points = np.vstack([g, h])
    elif name == "disc":
        # a flat cylinder: radius 14, three layers
        g = np.mgrid[-14:15, -14:15, -1:2].reshape(3, -1).T
        points = g[g[:, 0] ** 2 + g[:, 1] ** 2 <= 14 ** 2]
    elif name == "bent_rod":
        # nodes within 2.2 of a circular arc of radius 14 over 150 degrees (in the xz plane)
        g = np.mgrid[-17:18, -3:4, -17:18].reshape(3, -1).T.astype(float)
        angle = np.arctan2(g[:, 2], g[:, 0])
        arc = np.clip(angle, np.radians(15), np.radians(165))
        nearest = 14 * np.stack([np.cos(arc), np.zeros_like(arc), np.sin(arc)], axis=1)
        points = g[np.sum((g - nearest) ** 2, axis=1) <= 2.2 ** 2].astype(int)
    else:
        raise ValueError(name)
    RUNS.mkdir(parents=True, exist_ok=True)
    np.savetxt(path, points, fmt="%d", header=f"{name}: {len(points)} beads (bench/error_estimate/error_estimate.py)")


def body_group(name):
    text, _ = BODIES[name]
    if text is None:
        return shape_group(name)
    if "bead_file" in text:
        make_bead_file(text.split("'")[3].removesuffix(".txt"))
    return text


def run(exe, name, label, force=False):
    tag = f"{name}_{label}"
    h5, times = RUNS / f"{tag}.h5", RUNS / f"{tag}.times"
    if not force and h5.exists() and times.exists():
        return float(times.read_text())
    hydro, options = SETTINGS[label]
    text = f"&run output = '{tag}.h5', progress = .false. /\n{body_group(name)}\n&hydrodynamics {hydro} /\n"
    wall = launch(exe, RUNS, tag, text, options.split())
    times.write_text(f"{wall:.3f}")
    print(f"error_estimate: {tag} {wall:.1f} s", flush=True)
    return wall


def read(name, label):
    with h5py.File(RUNS / f"{name}_{label}.h5") as f:
        g = f["hydrodynamics"]
        positions = np.asarray(f["geometry/positions"][()])
        out = dict(mobility=np.asarray(g["body_mobility"][()]), coefficients=np.asarray(g["coefficients"][()]),
                   positions=positions[np.lexsort(positions.T[::-1])],
                   n=int(f["geometry"].attrs["n_beads"]), length=float(f["shape"].attrs["reference_length"]))
        for key in ("scaled_coefficient_error", "scaled_extrapolated_coefficient_error", "extrapolated_body_mobility",
                    "extrapolated_coefficients", "companion_body_mobility"):
            if key in g:
                out[key] = np.asarray(g[key][()])
        for key in ("estimated_error", "estimated_extrapolated_error"):
            if key in g.attrs:
                out[key] = float(g.attrs[key])
        out["seconds"] = float(g.attrs["phase_seconds"][-1])
        names = g.attrs["phase_names"]
        names = (names.decode() if isinstance(names, bytes) else str(names)).split()
        out["phases"] = dict(zip(names, np.asarray(g.attrs["phase_seconds"], dtype=float)))
        return out


def scaled(delta, mobility):
    """|delta_ij| / sqrt(M_ii M_jj) (the module docstring's measure)."""
    d = np.sqrt(np.abs(np.diag(mobility)))
    return np.abs(delta) / np.outer(d, d)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("stage", choices=["collect", "calibrate", "report", "recheck"])
    parser.add_argument("--bodies", default=",".join(BODIES))
    parser.add_argument("--settings", default=None)
    parser.add_argument("--exe", default=str(ROOT / "build" / "beadmob"))
    parser.add_argument("--force", action="store_true")
    args = parser.parse_args()
    bodies = args.bodies.split(",")
    if args.stage == "collect":
        for name in bodies:
            labels = args.settings.split(",") if args.settings else \
                (["L1_shell1", "default", REFERENCE] if BODIES[name][1] == "tune" else ["default", REFERENCE])
            for label in labels:
                run(Path(args.exe).resolve(), name, label, args.force)
    elif args.stage == "calibrate":
        calibrate(bodies)
    elif args.stage == "recheck":
        recheck(Path(args.exe).resolve())
    else:
        report(bodies)


def factors():
    """The estimate's factors as compiled (src/hydro/error_estimate.f90)."""
    import re
    text = (ROOT / "src" / "hydro" / "error_estimate.f90").read_text()
    names = ["entry_factor", "block_factor", "extrapolation_ratio", "extrapolated_entry_factor",
             "extrapolated_block_factor"]
    return {n: float(re.search(rf"{n} = ([0-9.]+)_dp", text).group(1)) for n in names}


def tuning_rows(bodies):
    rows = []
    for name in bodies:
        if BODIES[name][1] != "tune":
            continue
        low, main_run, ref = read(name, "L1_shell1"), read(name, "default"), read(name, REFERENCE)
        truth = scaled(main_run["mobility"] - ref["mobility"], ref["mobility"])
        step = scaled(main_run["mobility"] - low["mobility"], main_run["mobility"])
        signed_truth = main_run["mobility"] - ref["mobility"]
        signed_step = main_run["mobility"] - low["mobility"]
        for i in range(6):
            for j in range(i, 6):
                rows.append(dict(body=name, i=i, j=j, coefficient=int((i, j) in UPPER_COEFFICIENTS),
                                 truth=truth[i, j], step=step[i, j], block_step=block_max(step, i, j),
                                 ratio=signed_truth[i, j] / signed_step[i, j] if signed_step[i, j] else np.nan))
    return rows


# the coefficients' entries in the upper triangle (the mobility is symmetric)
UPPER_COEFFICIENTS = [(min(i, j), max(i, j)) for i, j in COEFFICIENT_ENTRIES]


def calibrate(bodies):
    """Ratios true error / step (|M_L - M_(L-1)| in the scaled measure) over the tuning bodies,
    per entry of the mobility and for the coefficients' entries, and how the compiled factors do
    there (the factors were chosen from these numbers: docs/theory.md T14)."""
    rows = tuning_rows(bodies)
    write_csv(HERE / "error_estimate_tuning.csv", rows)
    print("\n".join(calibration_lines(rows)))


def calibration_lines(rows):
    f = factors()
    truth = np.array([r["truth"] for r in rows])
    step = np.array([r["step"] for r in rows])
    block = np.array([r["block_step"] for r in rows])
    ratio = np.array([r["ratio"] for r in rows])
    coefficient = np.array([r["coefficient"] for r in rows], dtype=bool)
    lines = ["| entries | count | truth / step: median, 90 %, 95 %, max | bound by the estimate | "
             "estimate / truth: median, 95 % | extrapolated closer | extrapolated bound |",
             "|---|---|---|---|---|---|---|"]
    for label, mask in (("all 21 of the 6x6 (upper triangle)", truth > 1e-6),
                        ("the five coefficients' entries", (truth > 1e-6) & coefficient)):
        t, s, b, r = truth[mask], step[mask], block[mask], ratio[mask]
        est = np.maximum(f["entry_factor"] * s, f["block_factor"] * b)
        ext_err = np.abs(r + f["extrapolation_ratio"]) * s * (t / np.abs(r * s))  # |truth + rho step|
        ext_est = np.maximum(f["extrapolated_entry_factor"] * s, f["extrapolated_block_factor"] * b)
        q = np.quantile(t / s, [0.5, 0.9, 0.95, 1.0])
        lines.append(f"| {label} | {mask.sum()} | {q[0]:.2f}, {q[1]:.2f}, {q[2]:.2f}, {q[3]:.2f} | "
                     f"{np.mean(est >= t):.0%} | {np.median(est / t):.1f}, {np.quantile(est / t, 0.95):.1f} | "
                     f"{np.mean(ext_err < t):.0%} | {np.mean(ext_est >= ext_err):.0%} |")
    lines.append("")
    lines.append("Entries with a true error below 1e-6 (zero by symmetry, or converged) are left out. "
                 f"Factors: {', '.join(f'{k} = {v}' for k, v in f.items())}.")
    return lines


def block_max(step, i, j):
    """The largest scaled difference in the 3x3 block of the mobility that holds entry (i, j)."""
    bi, bj = 3 * (i // 3), 3 * (j // 3)
    return float(np.max(step[bi:bi + 3, bj:bj + 3]))


def report(bodies):
    """bench/error_estimate/error_estimate.md and .csv: each check body's run (default settings, its own
    estimate) against the reference, per coefficient and for the whole mobility."""
    rows, cost = [], []
    for name in bodies:
        if BODIES[name][1] != "check" or not (RUNS / f"{name}_{REFERENCE}.h5").exists():
            continue
        run_, ref = read(name, "default"), read(name, REFERENCE)
        if not np.array_equal(run_["positions"], ref["positions"]):
            raise SystemExit(f"{name}: the reference run has other beads than the default run (rerun collect --force)")
        if "scaled_coefficient_error" not in run_:
            raise SystemExit(f"{name}: the default run has no error estimate (rerun collect with a current build)")
        m, r = run_["mobility"], ref["mobility"]
        truth = scaled(m - r, r)
        ext_truth = scaled(run_["extrapolated_body_mobility"] - r, r)
        for k, (i, j) in enumerate(COEFFICIENT_ENTRIES):
            rows.append(dict(body=name, coefficient=COEFFICIENTS[k], value=run_["coefficients"][k],
                             reference=ref["coefficients"][k], extrapolated=run_["extrapolated_coefficients"][k],
                             true_error=truth[i, j], estimate=run_["scaled_coefficient_error"][k],
                             extrapolated_true_error=ext_truth[i, j],
                             extrapolated_estimate=run_["scaled_extrapolated_coefficient_error"][k]))
        rows.append(dict(body=name, coefficient="6x6 (largest entry)", value=np.nan, reference=np.nan,
                         extrapolated=np.nan, true_error=truth.max(), estimate=run_["estimated_error"],
                         extrapolated_true_error=ext_truth.max(),
                         extrapolated_estimate=run_["estimated_extrapolated_error"]))
        cost.append((name, run_["n"], run_["phases"]))
    write_csv(HERE / "error_estimate.csv", rows)
    write_report(rows, cost)


def read_tuning_rows():
    """The rows `calibrate` wrote (the tuning runs need not be present for the report)."""
    with open(HERE / "error_estimate_tuning.csv", newline="") as source:
        return [{k: (v if k == "body" else float(v)) for k, v in r.items()} for r in csv.DictReader(source)]


def write_report(rows, cost):
    tuning = read_tuning_rows()
    coeff = [r for r in rows if r["coefficient"] in COEFFICIENTS]
    zero = [r for r in coeff if r["true_error"] <= 1e-6]   # exact zeros by symmetry
    judged = [r for r in coeff if r["true_error"] > 1e-6]
    bound = [r for r in judged if r["estimate"] >= r["true_error"]]
    over = np.array([r["estimate"] / r["true_error"] for r in judged])
    closer = [r for r in judged if r["extrapolated_true_error"] < r["true_error"]]
    ext_bound = [r for r in judged if r["extrapolated_estimate"] >= r["extrapolated_true_error"]]
    zero_ok = [r for r in zero if r["estimate"] <= 1e-6]
    out = ["# The error bar of a run against the truth (generated by `python3 bench/error_estimate/error_estimate.py report`)", "",
           "Every run with `&hydrodynamics` at L >= 2 also solves the companion of order L - 1 on the same beads and "
           "reports an estimated error per mobility entry and coefficient, and a value extrapolated in L with its own "
           "error (docs/theory.md T14, src/hydro/error_estimate.f90). Here each check body is run at the default "
           "settings (L = 2, one surface layer, Krylov tolerance 1e-3) and compared with its reference: "
           "L = 4, the full model (no shell), Krylov tolerance 1e-7, i.e. the exact Stokes mobility of the bead model "
           "up to the L = 4 truncation (about 1e-4, bench/accuracy/l_convergence_arrowhead.md). None of the check bodies was "
           "used to choose the estimate's factors (section Calibration).", "",
           "Measure: |dM_ij| / sqrt(M_ii M_jj) for entry (i, j) of the body-frame mobility (relative for mu11, mu22, "
           "mu33; a coupling on the scale of its block, which stays meaningful near zero).", "",
           "## Summary", "",
           f"- Coefficients with a nonzero true error (> 1e-6): {len(judged)}; the estimate bounds the true error in "
           f"**{len(bound)} ({len(bound) / max(len(judged), 1):.0%})**; it overestimates by a median factor "
           f"{np.median(over):.1f}, at most {over.max():.1f} (95 % of them at most {np.quantile(over, 0.95):.1f}; "
           f"by at most 10x in {np.sum(over <= 10)} of {len(judged)}).",
           *[f"- Overestimated more than 10x: {r['body']} {r['coefficient']}, true error {r['true_error']:.1e} against "
             f"a median {np.median([q['true_error'] for q in judged]):.1e} over all: its order-L value lies near the "
             f"reference by chance, much nearer than its step from order L - 1 suggests; the estimate "
             f"{r['estimate']:.1e} is of the usual size." for r in judged if r["estimate"] > 10 * r["true_error"]],
           f"- The extrapolated value is closer to the reference than the order-L value in **{len(closer)} of "
           f"{len(judged)}** coefficients; its own error bar bounds its true error in {len(ext_bound)} of {len(judged)}.",
           f"- Coefficients that are zero by symmetry (true error <= 1e-6): {len(zero)}; the estimate is <= 1e-6 "
           f"in {len(zero_ok)} of them.", "",
           "## Per body and coefficient", "",
           "| body | coefficient | order L | reference | true error | estimate | estimate / truth | extrapolated | "
           "its true error | its estimate |",
           "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        ratio = r["estimate"] / r["true_error"] if r["true_error"] > 1e-6 else np.nan
        fmt = (lambda x: "" if not np.isfinite(x) else f"{x:.5f}")
        out.append(f"| {r['body']} | {r['coefficient']} | {fmt(r['value'])} | {fmt(r['reference'])} | "
                   f"{r['true_error']:.1e} | {r['estimate']:.1e} | "
                   f"{'' if not np.isfinite(ratio) else f'{ratio:.1f}'} | {fmt(r['extrapolated'])} | "
                   f"{r['extrapolated_true_error']:.1e} | {r['extrapolated_estimate']:.1e} |")
    out += ["", "## Cost of the companion", "",
            "Wall time of the friction job's phases in the default run (the companion phase is the estimate's "
            "cost; bench/error_estimate/error_estimate_cost.md compares whole runs with and without it side by side).", "",
            "| body | beads | blocks | solve | companion | total | companion / (total - companion) |",
            "|---|---|---|---|---|---|---|"]
    for name, n, ph in cost:
        out.append(f"| {name} | {n} | {ph.get('blocks', 0):.2f} | {ph.get('solve', 0):.2f} | "
                   f"{ph.get('companion', 0):.2f} | {ph.get('total', 0):.2f} | "
                   f"{ph.get('companion', 0) / max(ph.get('total', 0) - ph.get('companion', 0), 1e-9):.2f} |")
    out += ["", "## Calibration", "",
            "The factors were chosen on the tuning bodies only (" +
            ", ".join(dict.fromkeys(r["body"] for r in tuning)) + "): the same reference, the default run, and "
            "a separate L = 1 run with the default's shell model and tolerance standing in for the companion "
            "(bench/error_estimate/error_estimate_tuning.csv). 'truth / step' is the true error of the order-L value over its "
            "difference from order L - 1; the estimate is max(entry_factor step, block_factor block step).", ""]
    out += calibration_lines(tuning)
    (HERE / "error_estimate.md").write_text("\n".join(out) + "\n")
    print("wrote bench/error_estimate/error_estimate.md")


def recheck(exe):
    """The check bodies' default runs of build `exe` (today's solver) against the references kept
    in error_estimate.csv (the L = 4 runs of `report`): does the error bar still bound the truth?
    The scale of each coefficient's measure (sqrt(M_ii M_jj) of the reference, times the
    coefficient's normalisation) is the kept row's |value - reference| / true_error; a coefficient
    zero by symmetry (kept true error <= 1e-6) is judged by its estimate alone, as in `report`.
    Each new value is also set against the kept default run's, in units of 2 b (b: this run's
    solver_error_bound, the friction's relative bound of tests/e2e/solver_promise.py, taken as the
    kept run's too): the same beads and model give differences of order b, a changed model far more."""
    with open(HERE / "error_estimate.csv", newline="") as source:
        kept = [r for r in csv.DictReader(source) if r["coefficient"] in COEFFICIENTS]
    bodies = list(dict.fromkeys(r["body"] for r in kept))
    lines, judged, bounded, ext_bounded, closer, zero, zero_ok, drift = [], 0, 0, 0, 0, 0, 0, []
    for name in bodies:
        run(exe, name, "default", force=True)
        new = read(name, "default")
        with h5py.File(RUNS / f"{name}_default.h5") as f:
            bound = float(f["hydrodynamics"].attrs["solver_error_bound"])
        for k, r in enumerate(row for row in kept if row["body"] == name):
            value, reference, old = new["coefficients"][k], float(r["reference"]), float(r["value"])
            estimate, ext_estimate = new["scaled_coefficient_error"][k], new["scaled_extrapolated_coefficient_error"][k]
            kept_truth = float(r["true_error"])
            if kept_truth <= 1e-6:
                zero += 1
                zero_ok += estimate <= 1e-6
                lines.append(f"| {name} | {r['coefficient']} | {value:.5f} | {reference:.5f} | (zero by symmetry) | "
                             f"{estimate:.1e} | | |")
                continue
            scale = abs(old - reference) / kept_truth
            truth, ext_truth = abs(value - reference) / scale, abs(new["extrapolated_coefficients"][k] - reference) / scale
            judged += 1
            bounded += estimate >= truth
            ext_bounded += ext_estimate >= ext_truth
            closer += ext_truth < truth
            drift.append(abs(value - old) / scale / (2 * bound))
            lines.append(f"| {name} | {r['coefficient']} | {value:.5f} | {reference:.5f} | {truth:.1e} | {estimate:.1e} | "
                         f"{estimate / truth:.1f} | {drift[-1]:.2f} |")
    out = ["# The error bar of today's runs against the kept references (generated by "
           "`python3 bench/error_estimate/error_estimate.py recheck`)", "",
           "The check bodies of error_estimate.md run again at the default settings with this build; their "
           "references (L = 4, the full model, Krylov tolerance 1e-7) are the ones kept in error_estimate.csv. "
           "Measure as there: |d mu| on the scale sqrt(M_ii M_jj) of the reference.", "",
           f"- Coefficients with a nonzero true error: {judged}; the estimate bounds the true error in "
           f"**{bounded} of {judged}**; the extrapolated value is closer to the reference in {closer} of {judged} and "
           f"its own error bar bounds its error in {ext_bounded} of {judged}.",
           f"- Zero by symmetry: {zero}; the estimate is <= 1e-6 in {zero_ok} of them.",
           f"- Against the kept default runs (the build of error_estimate.md): the largest difference is "
           f"{max(drift):.2f} x 2b, b this run's relative solver bound of the friction (of order 1 or less: the same "
           "model within the solvers' promise; a changed model or bead set would show far more).", "",
           "| body | coefficient | order L (this build) | reference | true error | estimate | estimate / truth | "
           "difference from the kept run / 2b |",
           "|---|---|---|---|---|---|---|---|"] + lines
    (HERE / "error_estimate_recheck.md").write_text("\n".join(out) + "\n")
    print("wrote bench/error_estimate/error_estimate_recheck.md")


if __name__ == "__main__":
    main()
