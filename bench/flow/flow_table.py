#!/usr/bin/env python3
"""flow_table.py [--exe BUILD/beadmob] [--budget 120] [--out FILE] [--workdir DIR]: the body in a
linear flow (docs/theory.md T19) on the six ellipsoids of bench/continuum and the paper's seven
particles, every new number beside its exact value where one exists.

Ellipsoids (semi-axes in their own unit along x, y, z; exact values: scripts/beadmob_post/ellipsoid.py,
Jeffery 1922 and Eshelby's tensor, and the exact friction for the Brownian part): a continuum job
(`&hydrodynamics flow = .true. /`, `&continuum time_budget = BUDGET /`, bead_diameter 0.125) and an
ordinary run at bead_diameter 0.125 (L = 2, its bar from the companion). Per body: the stresslet per
unit strain T (its five diagonal entries, in the ellipsoid's axes), the rotation per unit strain
(its three Jeffery entries; a sphere has none), the intrinsic viscosity [eta]_inf = tr T / (10 V) and
[eta]_0 (with the rotary Brownian stress; beadmob_post/brownian.py) with the exact volume 4/3 pi abc:
the largest error against the exact value relative to it, the largest bar relative to it, and
whether every exact value lies inside its bar (`held`).

Paper particles (shapes/<name>.nml, L = 2, ordinary runs with flow; no exact values): translational
diffusion D_t (eta = kT = 1, d = 1), Stokes radius, the three rotational diffusion constants, the
harmonic mean relaxation time, [eta]_inf and [eta]_0 with the volume N d^3, the largest rotation per
unit strain and each with its bar where the run gives one; the job's wall time with and without the
flow is in bench/flow/flow_cost.md.
"""
import argparse
import sys
import time
from pathlib import Path

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "scripts"))
sys.path.insert(0, str(ROOT / "bench" / "continuum"))
from beadmob_post.ellipsoid import ellipsoid_flow, ellipsoid_friction  # noqa: E402
from beadmob_post.brownian import intrinsic_viscosity  # noqa: E402
from beadmob_post.results import load_result  # noqa: E402
from beadmob_post.brownian import diffusion_analysis  # noqa: E402
from continuum_jobs import run  # noqa: E402

BODIES = [("sphere", (1, 1, 1)), ("prolate 2:1", (2, 1, 1)), ("prolate 4:1", (4, 1, 1)),
          ("oblate 1:2", (1, 2, 2)), ("oblate 1:4", (1, 4, 4)), ("triaxial 3:2:1", (3, 2, 1))]
PAPER = ["cone", "arrowhead", "crescent_moon", "ring_1mm", "ring_2mm", "ring_3mm", "ring_4mm"]
# The Jeffery entries of V (row = Omega component, column = mode) for axes along x, y, z.
JEFFERY = [(5, 0), (4, 1), (3, 2)]


def flow_numbers(velocity, stresslet, mobility_rr, volume):
    """T's diagonal, the Jeffery entries of V, [eta]_inf and [eta]_0."""
    eta = intrinsic_viscosity(velocity[3:], stresslet, mobility_rr, volume)
    return np.concatenate([np.diag(stresslet), [velocity[r, c] for r, c in JEFFERY], [eta.high_frequency, eta.zero_shear]])


def ellipsoid_row(exe, name, semi_axes, budget, workdir):
    d = 0.125
    volume = 4 * np.pi * np.prod(semi_axes) / 3
    velocity, stresslet = ellipsoid_flow(semi_axes)
    mobility = np.linalg.inv(ellipsoid_friction(semi_axes))
    exact = flow_numbers(velocity, stresslet, mobility[3:, 3:], volume)
    shape = "&shape name = 'spheroid', semi_axes = " + ", ".join(f"{a:g}" for a in semi_axes) + f", bead_diameter = {d} /\n"
    result, wall = run(exe, shape + "&hydrodynamics flow = .true. /\n" + f"&continuum time_budget = {budget:g} /\n",
                       workdir)
    with h5py.File(result) as f:
        c = f["continuum"]
        v, ve = c["velocity_per_strain"][()], c["velocity_per_strain_error"][()]
        t, te = c["stresslet_per_strain"][()], c["stresslet_per_strain_error"][()]
        m = c["mobility"][()]
        beads = int(max(c.attrs["sample_beads"]))
    values = flow_numbers(v, t, m[3:, 3:], volume)
    # Bars of [eta]: first order from T's diagonal bars (the Brownian part's own bar is small beside it).
    bars = np.concatenate([np.diag(te), [ve[r, c] for r, c in JEFFERY], [np.sum(np.diag(te)) / (10 * volume)] * 2])
    ordinary, _ = run(exe, shape + "&hydrodynamics flow = .true. /\n", workdir)
    with h5py.File(ordinary) as f:
        g = f["flow"]
        # d units to the body's: T ~ length^3, rotation per strain dimensionless; M_rr ~ length^-3
        ov, ot = g["velocity_per_strain"][()], g["stresslet_per_strain"][()] * d**3
        om = f["hydrodynamics"]["mobility"][()][3:, 3:] / d**3
        ovb, otb = g["velocity_per_strain_error"][()], g["stresslet_per_strain_error"][()] * d**3
    ord_values = flow_numbers(ov, ot, om, volume)
    ord_bars = np.concatenate([np.diag(otb), [ovb[r, c] for r, c in JEFFERY], [np.sum(np.diag(otb)) / (10 * volume)] * 2])

    def part(sl, vals, errs):
        keep = [i for i in range(*sl.indices(len(exact))) if abs(exact[i]) > 1e-12]
        if not keep:
            return "-", "-", "-"
        err = max(abs(vals[i] - exact[i]) / abs(exact[i]) for i in keep)
        bar = max(errs[i] / abs(exact[i]) for i in keep)
        held = all(abs(vals[i] - exact[i]) <= errs[i] for i in keep)
        return f"{100 * err:.2f} %", f"{100 * bar:.2f} %", "yes" if held else "NO"

    cells = []
    for sl in (slice(0, 5), slice(5, 8), slice(8, 10)):
        cells += list(part(sl, values, bars))
    ordinary_cells = []
    for sl in (slice(0, 5), slice(5, 8)):
        ordinary_cells += list(part(sl, ord_values, ord_bars))[:2]
    return (f"| {name} | {beads} | {values[8]:.4f} / {exact[8]:.4f} | {values[9]:.4f} / {exact[9]:.4f} | "
            + " | ".join(cells) + f" | {wall:.0f} | " + " | ".join(ordinary_cells) + " |")


def paper_row(exe, name, workdir):
    text = (ROOT / "shapes" / f"{name}.nml").read_text().replace(f"output = '{name}.h5'", "output = 'job.h5'")
    text = text.replace("&hydrodynamics", "&hydrodynamics flow = .true.,", 1).replace(",,", ",").replace(", /", " /")
    start = time.perf_counter()
    result, _ = run(exe, text, workdir)
    wall = time.perf_counter() - start
    d = diffusion_analysis(load_result(result))
    with h5py.File(result) as f:
        n = int(f["geometry"].attrs["n_beads"])
        g = f["flow"]
        rotation, rotation_bar = np.abs(g["velocity_per_strain"][()][3:]), g["velocity_per_strain_error"][()][3:]
        t_bar = np.diag(g["stresslet_per_strain_error"][()])
    k = np.unravel_index(np.argmax(rotation), rotation.shape)
    eta = d.flow.intrinsic_viscosity
    eta_bar = np.sum(t_bar) / (10 * n)
    return (f"| {name} | {n} | {d.translational:.5f} | {d.stokes_radius:.3f} | "
            + ", ".join(f"{x:.3e}" for x in d.rotational) + f" | {d.harmonic_mean_time:.4g} | "
            f"{eta.high_frequency:.3f} +- {eta_bar:.3f} | {eta.zero_shear:.3f} | {rotation[k]:.4f} +- {rotation_bar[k]:.4f} | "
            f"{wall:.1f} |")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--exe", default=str(ROOT / "build" / "beadmob"))
    parser.add_argument("--budget", type=float, default=120.0)
    parser.add_argument("--out", default=str(ROOT / "bench" / "flow" / "flow_table.md"))
    parser.add_argument("--workdir", default="/tmp/beadmob_flow_table")
    parser.add_argument("--paper-only", action="store_true")
    args = parser.parse_args()
    Path(args.workdir).mkdir(parents=True, exist_ok=True)
    ellipsoids = []
    if not args.paper_only:
        for name, semi_axes in BODIES:
            ellipsoids.append(ellipsoid_row(args.exe, name, semi_axes, args.budget, args.workdir))
            print(ellipsoids[-1], flush=True)
    paper = []
    for name in PAPER:
        paper.append(paper_row(args.exe, name, args.workdir))
        print(paper[-1], flush=True)
    text = [
        "# The body in a linear flow: six ellipsoids against their exact values, the paper's seven particles",
        "",
        f"Written by `bench/flow/flow_table.py --budget {args.budget:g}` on {time.strftime('%Y-%m-%d')} "
        "(2 ranks; the script's docstring says what each column is).",
        "",
        "## Ellipsoids: continuum jobs (and ordinary runs at bead_diameter 0.125)",
        "",
        "T: the five diagonal stresslet entries per unit strain; rotation: the three Jeffery entries of the "
        "rotation per unit strain; [eta]: [eta]_inf and [eta]_0 with the exact volume. `error`: the largest "
        "|value - exact| / |exact|; `bar`: the largest bar / |exact|; `held`: every exact value inside its bar.",
        "",
        "| body | finest beads | [eta]_inf beadmob / exact | [eta]_0 beadmob / exact | T error | T bar | T held | "
        "rotation error | rotation bar | rotation held | [eta] error | [eta] bar | [eta] held | wall (s) | "
        "ordinary T error | ordinary T bar | ordinary rotation error | ordinary rotation bar |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
        *ellipsoids,
        "",
        "## The paper's particles (ordinary runs, L = 2, flow = .true.)",
        "",
        "eta = kT = 1, lengths in d; D_t at the centre of diffusion; D_r: the eigenvalues of the rotational "
        "diffusion tensor; tau_h = 1 / (6 mean D_r); [eta] with the volume N d^3; its bar from the stresslet's; "
        "the largest |Omega - Omega0| per unit strain amplitude with its bar.",
        "",
        "| particle | beads | D_t | Stokes radius (d) | D_r | tau_h | [eta]_inf | [eta]_0 | largest rotation per "
        "strain | wall (s) |",
        "|---|---|---|---|---|---|---|---|---|---|",
        *paper,
        "",
    ]
    Path(args.out).write_text("\n".join(text))
    print("\n".join(text))


if __name__ == "__main__":
    main()
