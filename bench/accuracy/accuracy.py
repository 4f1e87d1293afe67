#!/usr/bin/env python3
"""Run time against error: every accuracy knob of beadmob on the paper shapes and a
filled sphere, each setting's error taken against a reference run with the tightest settings that
fit (stated in the output).

    python3 bench/accuracy/accuracy.py [--shapes a,b,...] [--settings s,t,...] [--reference L3_tight]
                              [--name accuracy] [--repeats 3] [--exe build/beadmob] [--force]

Runs go to bench/accuracy/accuracy_runs/ (kept: a second call only runs what is missing); writes
bench/accuracy/NAME.csv (one row per shape and setting), bench/accuracy/NAME.md (tables, the Pareto front,
convergence in L with and without the lubrication correction) and bench/accuracy/NAME_pareto.png.
The Krylov tolerance study: --name solver_tolerance --reference L2_tight
--settings L2_rtol1e-2,L2_default,L2_rtol1e-4,L2_rtol1e-5,L2_rtol1e-6.

Error measure: the paper's five coefficients mu11, mu22, mu33, mu42, mu51 (body frame,
normalised as in the paper); err = max_k |mu_k - mu_k(ref)| / scale_k, with scale_k = |mu_k(ref)|
for the translational ones and max(|mu_k(ref)|, 0.1 mu33(ref)) for the couplings (a body without
coupling, the sphere, would otherwise divide by ~0). Each run yields two friction matrices (the
order-L one and the one with the lubrication correction), compared with the same in the reference.
"""
import argparse
import csv
import os
import subprocess
import time
from pathlib import Path

import h5py
import numpy as np

HERE = Path(__file__).resolve().parent   # this study's folder: bench/<study>/
ROOT = HERE.parents[1]
RUNS = HERE / "accuracy_runs"
PAPER_SHAPES = ["cone", "crescent_moon", "arrowhead", "ring_1mm", "ring_2mm", "ring_3mm", "ring_4mm"]
EXTRA_SHAPES = {"sphere": "&shape name = 'sphere', radius = 10 /",
                # not in the tuning data: the check of --accuracy on unseen shapes
                "torus": "&shape name = 'torus', major_radius = 14, minor_radius = 4 /",
                "spheroid": "&shape name = 'spheroid', semi_axes = 18, 8, 8 /"}
# label -> (&hydrodynamics entries, extra command-line options)
SETTINGS = {
    "L6_tight": ("multipole_order = 6, shell_layers = 0", "-ksp_rtol 1e-7"),
    "L5_tight": ("multipole_order = 5, shell_layers = 0", "-ksp_rtol 1e-7"),
    "L4_tight": ("multipole_order = 4, shell_layers = 0", "-ksp_rtol 1e-7"),
    "L3_tight": ("multipole_order = 3, shell_layers = 0", "-ksp_rtol 1e-7"),
    "L2_tight": ("multipole_order = 2, shell_layers = 0", "-ksp_rtol 1e-7"),
    "L1_tight": ("multipole_order = 1, shell_layers = 0", "-ksp_rtol 1e-7"),
    "L3_default": ("multipole_order = 3, shell_layers = 0", ""),
    "L2_default": ("multipole_order = 2, shell_layers = 0", ""),
    "L1_default": ("multipole_order = 1, shell_layers = 0", ""),
    "L2_rtol1e-2": ("multipole_order = 2, shell_layers = 0", "-ksp_rtol 1e-2"),
    "L2_rtol1e-4": ("multipole_order = 2, shell_layers = 0", "-ksp_rtol 1e-4"),
    "L2_rtol1e-5": ("multipole_order = 2, shell_layers = 0", "-ksp_rtol 1e-5"),
    "L2_rtol1e-6": ("multipole_order = 2, shell_layers = 0", "-ksp_rtol 1e-6"),
    "L1_rtol1e-2": ("multipole_order = 1, shell_layers = 0", "-ksp_rtol 1e-2"),
    "L2_shell1": ("multipole_order = 2, shell_layers = 1", ""),
    "L2_shell2": ("multipole_order = 2, shell_layers = 2", ""),
    "L2_direct": ("multipole_order = 2, shell_layers = 0", "-operator direct"),
}
# The default grid. Left out, each for a reason: L4_tight (about 30 min per paper shape; used on
# small bodies only), L2_rtol1e-5/1e-6 (in bench/accuracy/solver_tolerance.md: never on the front, the
# L = 2 truncation error dominates), L2_direct (the direct product equals the FFT one to 3e-14,
# bench/operator_check/operator_check.md, at about 300 x the cost per product: a full run takes ~50 min).
DEFAULT_SETTINGS = ["L1_rtol1e-2", "L1_default", "L1_tight", "L2_rtol1e-2", "L2_shell1", "L2_shell2",
                    "L2_default", "L2_rtol1e-4", "L2_tight", "L3_default"]
# The settings of a run that sets nothing: L = 2, Krylov tolerance 1e-3 ("_default" in a label),
# one surface layer (src/io/input_config.f90, default_shell_layers).
DEFAULT_LABEL = "L2_shell1"
NAMES = ["mu11", "mu22", "mu33", "mu42", "mu51"]


def launch(exe, runs, tag, text, options=()):
    """Writes runs/TAG.nml (text) and runs beadmob on it on 2 ranks in runs/ (output to TAG.log);
    returns the wall time (s). A failed run raises."""
    runs.mkdir(parents=True, exist_ok=True)
    (runs / f"{tag}.nml").write_text(text)
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    start = time.perf_counter()
    with open(runs / f"{tag}.log", "w") as log:
        subprocess.run(["mpirun", "-n", "2", str(exe), f"{tag}.nml", *options], cwd=runs, stdout=log,
                       stderr=subprocess.STDOUT, env=env, check=True)
    return time.perf_counter() - start


def write_csv(path, rows):
    """rows (dicts with the same keys) as a CSV file with a header line."""
    with open(path, "w", newline="") as out:
        writer = csv.DictWriter(out, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


def shape_group(shape):
    if shape in EXTRA_SHAPES:
        return EXTRA_SHAPES[shape]
    # The &shape group of the shape file, comments dropped (they may contain a '/').
    text = "\n".join(line.split("!")[0] for line in (ROOT / "shapes" / f"{shape}.nml").read_text().splitlines())
    start = text.index("&shape")
    return text[start:text.index("/", start) + 1]


def run(exe, shape, label, repeats, force, reference):
    """Runs beadmob for (shape, setting) `repeats` times; returns the wall times (s)."""
    tag = f"{shape}_{label}"
    h5, times_file = RUNS / f"{tag}.h5", RUNS / f"{tag}.times"
    if not force and h5.exists() and times_file.exists():
        return [float(t) for t in times_file.read_text().split()]
    hydro, options = SETTINGS[label]
    text = f"&run output = '{tag}.h5' /\n{shape_group(shape)}\n&hydrodynamics {hydro}, lubrication = .true. /\n"
    # Tight and L = 3 settings: one run each (minutes per run; the runs column says so).
    walls = [launch(exe, RUNS, tag, text, options.split())
             for _ in range(1 if label == reference or label.endswith("_tight") or label.startswith("L3") else repeats)]
    times_file.write_text(" ".join(f"{w:.3f}" for w in walls))
    print(f"accuracy: {tag} {np.median(walls):.1f} s", flush=True)
    return walls


def read(shape, label, path=None):
    with h5py.File(path or RUNS / f"{shape}_{label}.h5") as f:
        g = f["hydrodynamics"]
        # Without the correction the file has only `coefficients` (the order-L ones).
        plain = g["multipole_coefficients"] if "multipole_coefficients" in g else g["coefficients"]
        return dict(plain=np.asarray(plain[()]), lubricated=np.asarray(g["coefficients"][()]),
                    iterations=int(np.sum(g.attrs["solve_iterations"])), n=int(f["geometry"].attrs["n_beads"]),
                    hydro_beads=int(g.attrs.get("hydrodynamic_beads", f["geometry"].attrs["n_beads"])),
                    converged=bool(g.attrs["all_converged"]), build=f.attrs["git_hash"].decode()
                    if isinstance(f.attrs["git_hash"], bytes) else str(f.attrs["git_hash"]))


def error(values, reference):
    scale = np.abs(reference).astype(float)
    scale[3:] = np.maximum(scale[3:], 0.1 * abs(reference[2]))
    return float(np.max(np.abs(values - reference) / scale))


def reference_error_estimate(rows, shape, friction, reference):
    """The truncation error of the reference (order L = 3) itself, estimated from the differences
    d1 = mu(L=1) - mu(3), d2 = mu(2) - mu(3) per coefficient under geometric convergence in L,
    mu(L) = mu(inf) + C q^L: then d2/d1 = q/(1+q) and mu(3) - mu(inf) = d2 q/(1-q). A coefficient
    whose differences change sign or do not shrink counts |d2| (q = 1/2), one with q >= 1 counts 1
    (no convergence seen). Same scaling as error(). rows: accuracy.csv rows (str or float values);
    L1/L2 from the *_tight runs when present, else the *_default ones."""
    def values(label):
        match = [r for r in rows if r["shape"] == shape and r["setting"] == label and r["friction"] == friction]
        return np.array([float(match[0][k]) for k in NAMES]) if match else None
    ref = values(reference)
    mu1 = values("L1_tight") if values("L1_tight") is not None else values("L1_default")
    mu2 = values("L2_tight") if values("L2_tight") is not None else values("L2_default")
    if ref is None or mu1 is None or mu2 is None:
        return float("nan")
    scale = np.abs(ref)
    scale[3:] = np.maximum(scale[3:], 0.1 * abs(ref[2]))
    estimate = 0.0
    for d1, d2, s in zip(mu1 - ref, mu2 - ref, scale):
        if d1 * d2 <= 0 or abs(d2) >= abs(d1):
            e = abs(d2)
        else:
            r = d2 / d1
            q = r / (1 - r)
            e = abs(d2) * q / (1 - q) if q < 1 else s
        estimate = max(estimate, min(e / s, 1.0))
    return estimate


def pareto_front(points):
    """Indices of the (time, error) points no other point beats in both."""
    front = []
    for i, (t, e) in enumerate(points):
        if not any((t2 <= t and e2 <= e) and (t2 < t or e2 < e) for t2, e2 in points):
            front.append(i)
    return front


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--shapes", default=",".join(PAPER_SHAPES + ["sphere"]))
    parser.add_argument("--settings", default=",".join(DEFAULT_SETTINGS))
    parser.add_argument("--reference", default="L3_tight", choices=list(SETTINGS))
    parser.add_argument("--name", default="accuracy")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--exe", default=str(Path(os.environ.get("BUILD_DIR", ROOT / "build")) / "beadmob"))
    parser.add_argument("--force", action="store_true")
    args = parser.parse_args()
    shapes, labels = args.shapes.split(","), args.settings.split(",")
    if args.reference not in labels:
        labels.insert(0, args.reference)
    rows = []
    for shape in shapes:
        walls = {label: run(args.exe, shape, label, args.repeats, args.force, args.reference) for label in labels}
        reference = read(shape, args.reference)
        for label in labels:
            r = read(shape, label)
            for friction in ("plain", "lubricated"):
                rows.append(dict(shape=shape, setting=label, friction=friction, n_beads=r["n"],
                                 hydrodynamic_beads=r["hydro_beads"], wall_s=float(np.median(walls[label])),
                                 wall_min_s=min(walls[label]), wall_max_s=max(walls[label]), runs=len(walls[label]),
                                 iterations=r["iterations"], converged=r["converged"], build=r["build"],
                                 error=error(r[friction], reference[friction]),
                                 **{name: v for name, v in zip(NAMES, r[friction])}))
    write_csv(HERE / f"{args.name}.csv", rows)
    write_summary(rows, shapes, labels, args.reference, args.name)


def write_summary(rows, shapes, labels, reference, name):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plain = [r for r in rows if r["friction"] == "plain" and r["setting"] != reference]
    command = f"python3 bench/accuracy/accuracy.py --name {name} --reference {reference} --shapes {','.join(shapes)} " \
              f"--settings {','.join(label for label in labels if label != reference)}"
    lines = [f"# Run time against error (generated by `{command}`)", "",
             f"Reference per shape: `{reference}` = {SETTINGS[reference][0]}, {SETTINGS[reference][1]}.",
             "Error: largest relative change of the paper's five",
             "coefficients against the reference (couplings relative to max(|mu|, 0.1 mu33)); wall time of the",
             "whole run on 2 ranks, median of the repeated runs (the reference: one run). Labels: L, then",
             "`default` = Krylov tolerance 1e-3, `rtolX` = X, `tight` = 1e-7, `shellK` = K surface layers (else the",
             f"full model). beadmob's default settings: {DEFAULT_LABEL} (the star in the plot).",
             f"Runs made by beadmob {', '.join(sorted({r['build'] for r in rows}))} (git hash at build time).", "",
             "## Error and time per setting (order-L friction, without the lubrication correction)", "",
             "Cells: error / wall time.", "",
             "| setting | " + " | ".join(shapes) + " | median time ratio to L2_default (full model) |",
             "|---|" + "---|" * (len(shapes) + 1)]
    for label in labels:
        if label == reference:
            continue
        cells, ratios = [], []
        for shape in shapes:
            r = next(x for x in plain if x["shape"] == shape and x["setting"] == label)
            base = next(x for x in plain if x["shape"] == shape and x["setting"] == "L2_default")
            cells.append(f"{r['error']:.1e} / {r['wall_s']:.1f} s")
            ratios.append(r["wall_s"] / base["wall_s"])
        lines.append(f"| {label} | " + " | ".join(cells) + f" | {np.median(ratios):.2f} |")

    lines += ["", "## Pareto front (per shape: the settings no other setting beats in both time and error)", ""]
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    for shape in shapes:
        pts = [x for x in plain if x["shape"] == shape]
        front = pareto_front([(x["wall_s"], x["error"]) for x in pts])
        on_front = sorted((pts[i] for i in front), key=lambda x: x["wall_s"])
        default_on = any(x["setting"] == DEFAULT_LABEL for x in on_front)
        lines.append(f"- {shape}: " + ", ".join(f"{x['setting']} ({x['error']:.1e}, {x['wall_s']:.1f} s)"
                                               for x in on_front)
                     + ("" if default_on else "  **(default not on the front)**"))
        line, = ax.loglog([x["wall_s"] for x in on_front], [max(x["error"], 1e-12) for x in on_front], "-", alpha=0.6)
        ax.loglog([x["wall_s"] for x in pts], [max(x["error"], 1e-12) for x in pts], "o", color=line.get_color(),
                  ms=3, label=shape)
        default = next(x for x in pts if x["setting"] == DEFAULT_LABEL)
        ax.loglog([default["wall_s"]], [max(default["error"], 1e-12)], "*", color=line.get_color(), ms=10)
    from matplotlib.ticker import NullFormatter
    ax.xaxis.set_minor_formatter(NullFormatter())
    if reference.startswith("L3"):
        reference_error = max(reference_error_estimate(rows, shape, "plain", reference) for shape in shapes)
        ax.axhline(reference_error, color="k", ls="--", lw=0.8)
        ax.text(ax.get_xlim()[0] * 1.05, reference_error * 1.15, f"estimated error of {reference} itself (largest)",
                fontsize=7)
    ax.set_xlabel("wall time, 2 ranks (s)")
    ax.set_ylabel("max relative coefficient error")
    ax.set_title(f"Settings against {reference} (star: default)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(HERE / f"{name}_pareto.png", dpi=120)

    lines += ["", f"![Pareto plot]({name}_pareto.png)", "",
              "## Convergence in L, with and without the lubrication correction (tight tolerance)", "",
              ]
    orders = [order for order in range(1, 9) if f"L{order}_tight" in labels]
    lines += ["| shape | friction | " + " | ".join(f"L = {order}" for order in orders) + " |",
              "|---|---|" + "---|" * len(orders)]
    for shape in shapes:
        for friction in ("plain", "lubricated"):
            errs = []
            for order in orders:
                match = [x for x in rows if x["shape"] == shape and x["setting"] == f"L{order}_tight"
                         and x["friction"] == friction]
                errs.append(f"{match[0]['error']:.1e}" if match else "")
            lines.append(f"| {shape} | {friction} | " + " | ".join(errs) + " |")
    if not reference.startswith("L3"):   # the estimate extrapolates from L = 1, 2 to the next order, 3
        (HERE / f"{name}.md").write_text("\n".join(lines) + "\n")
        print(f"wrote bench/accuracy/{name}.md, bench/accuracy/{name}.csv, bench/accuracy/{name}_pareto.png")
        return
    lines += ["", f"## Estimated error of the reference ({reference}) itself", "",
              "From the convergence in L above (reference_error_estimate in bench/accuracy/accuracy.py: geometric",
              "convergence per coefficient fitted to the L = 1 and L = 2 differences; 1 = no convergence seen).",
              "bench/accuracy/accuracy_rule.py adds it to every measured error before it makes a promise.", "",
              "| shape | plain | lubricated |", "|---|---|---|"]
    for shape in shapes:
        lines.append(f"| {shape} | " + " | ".join(f"{reference_error_estimate(rows, shape, f, reference):.1e}"
                                                 for f in ("plain", "lubricated")) + " |")
    (HERE / f"{name}.md").write_text("\n".join(lines) + "\n")
    print(f"wrote bench/accuracy/{name}.md, bench/accuracy/{name}.csv, bench/accuracy/{name}_pareto.png")


if __name__ == "__main__":
    main()
