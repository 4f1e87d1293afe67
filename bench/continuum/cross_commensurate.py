#!/usr/bin/env python3
"""cross_commensurate.py --exe BEADMOB --turned JOB.h5 [--aligned JOB.h5] [--k 2 3 ...] [--workdir DIR] [--reuse] --out FILE.md

A reference for the 3-D cross of nonconvex.py by another route than the continuum job's, to judge
its error bars (the cross has no exact mobility). The cross is a union of 104 voxels of side 0.3;
on a lattice of bead diameter d = 0.3 / k whose nodes sit at the centres of the voxels' k^3
sub-cubes (lattice_offset = frac(shift / d + 1/2) on each axis), the beads' cubes tile the body
exactly, every bead model of the sequence is the same voxel body refined (104 k^3 beads), and the
body keeps its three mirror planes and its cubic symmetry at every k. There is no offset scatter to
average and no lattice resonance: the error of the bead model (discretisation and order-L
truncation) is a function of h = 1 / k alone, extrapolated here to h = 0 from ordinary runs
(krylov_rtol 1e-5) by least squares in powers of h, with the spread over the fits (polynomial
degree 2 and 3, coarsest levels left out) as its uncertainty. Cubic symmetry makes the mobility
about the centre isotropic, so the translation and rotation mobilities are each one number (a
third of the trace), compared with every diagonal entry of the continuum jobs given (principal
frame, their bars). Mobilities in the mesh's length unit, viscosity 1.
"""
import argparse
import datetime
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from continuum_jobs import ROOT, run  # noqa: E402
from nonconvex import CROSS, CROSS_SHIFT, cross, write_obj  # noqa: E402

sys.path.insert(0, str(ROOT / "scripts"))
from beadmob_post.continuum_bar import principal_diagonal, read_samples  # noqa: E402


def job_text(k):
    d = CROSS["voxel"] / k
    offset = np.mod(CROSS_SHIFT / d + 0.5, 1.0)
    return (f"&shape name = 'mesh', file = 'cross.obj', bead_diameter = {d:.17g},\n"
            f"  lattice_offset = {offset[0]:.17g}, {offset[1]:.17g}, {offset[2]:.17g} /\n"
            "&hydrodynamics krylov_rtol = 1e-5 /\n"), d


def solve(exe, workdir, k, reuse):
    """Level k's ordinary run (or, with reuse, its result kept in workdir by an earlier call)."""
    text, d = job_text(k)
    result, walls = workdir / f"k{k}.h5", workdir / f"k{k}.wall"
    if reuse and result.exists() and walls.exists() and (workdir / f"k{k}.nml").read_text().endswith(text):
        wall = float(walls.read_text())
    else:
        result, wall = run(exe, text, workdir, name=f"k{k}")
        walls.write_text(f"{wall}\n")
    with h5py.File(result, "r") as f:
        h = f["hydrodynamics"]
        mobility = h["mobility"][()]
        beads = int(f["geometry"].attrs["n_beads"])
    # model coordinates are in d, viscosity 1: translation scales as 1 / length, rotation 1 / length^3
    t = np.trace(mobility[:3, :3]) / 3 / d
    r = np.trace(mobility[3:, 3:]) / 3 / d**3
    anisotropy = max(np.ptp(np.diag(mobility[:3, :3])) / np.trace(mobility[:3, :3]) * 3,
                     np.ptp(np.diag(mobility[3:, 3:])) / np.trace(mobility[3:, 3:]) * 3)
    return dict(k=k, d=d, beads=beads, wall=wall, t=t, r=r, anisotropy=anisotropy)


def fit(h, y, degree):
    """Least-squares polynomial in h of `degree` through (h, y), equal weights: its intercept."""
    return np.polynomial.polynomial.polyfit(h, y, degree)[0]


def extrapolations(rows, quantity):
    h = np.array([1.0 / row["k"] for row in rows])
    y = np.array([row[quantity] for row in rows])
    fits = {}
    for degree in (2, 3):
        for dropped in range(0, 3):
            if len(h) - dropped >= degree + 2:
                fits[f"degree {degree}, {dropped} coarsest left out"] = fit(h[dropped:], y[dropped:], degree)
    return fits


def continuum_entries(path):
    """The job's six principal-frame diagonal entries and their bars (beadmob's estimator, replayed
    on its samples: continuum_bar.principal_diagonal), its bead diameters and time budget."""
    with h5py.File(path, "r") as f:
        c = f["continuum"]
        axes, diameters, budget = c["equivalent_axes"][()].T, c["bead_diameters"][()], float(c.attrs["time_budget"])
    entries = principal_diagonal(read_samples(path), axes)
    return np.array([e[0] for e in entries]), np.array([e[1] for e in entries]), diameters, budget


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--exe", type=Path, default=ROOT / "build" / "beadmob")
    parser.add_argument("--k", type=int, nargs="+", default=[2, 3, 4, 5, 6, 7, 8, 10, 12])
    parser.add_argument("--turned", type=Path, help="a continuum job's result of the cross (turned lattices)")
    parser.add_argument("--aligned", type=Path, help="a continuum job's result of the cross (aligned lattices)")
    parser.add_argument("--workdir", type=Path, default=Path("cross_commensurate_runs"))
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--reuse", action="store_true", help="read the levels whose results the workdir keeps")
    args = parser.parse_args()
    args.workdir.mkdir(parents=True, exist_ok=True)
    vertices, faces = cross()
    write_obj(args.workdir / "cross.obj", vertices, faces)
    version = subprocess.run([str(args.exe), "--version"], capture_output=True, text=True).stdout.strip()
    rows = []
    for k in args.k:
        rows.append(solve(args.exe, args.workdir, k, args.reuse))
        print(f"k = {k}: {rows[-1]['beads']} beads, {rows[-1]['wall']:.1f} s, t = {rows[-1]['t']:.7f}, "
              f"r = {rows[-1]['r']:.7f}", flush=True)

    lines = ["# The 3-D cross on commensurate lattices: a reference for its continuum bars", "",
             f"Written by `bench/continuum/cross_commensurate.py` on {datetime.date.today()} with {version} "
             f"(2 ranks). Method: the script's docstring.", "",
             "| k | bead diameter | beads | wall s | translation mobility | rotation mobility | anisotropy |",
             "|---|---|---|---|---|---|---|"]
    for row in rows:
        lines.append(f"| {row['k']} | {row['d']:.5g} | {row['beads']} | {row['wall']:.1f} | {row['t']:.7f} | "
                     f"{row['r']:.7f} | {row['anisotropy']:.1e} |")
    references = {}
    lines += ["", "Extrapolations to h = 1 / k = 0 (least squares, equal weights):", "",
              "| fit | translation | rotation |", "|---|---|---|"]
    fits_t, fits_r = extrapolations(rows, "t"), extrapolations(rows, "r")
    for name in fits_t:
        lines.append(f"| {name} | {fits_t[name]:.7f} | {fits_r[name]:.7f} |")
    for quantity, fits in (("t", fits_t), ("r", fits_r)):
        values = np.array(list(fits.values()))
        centre = 0.5 * (values.max() + values.min())
        references[quantity] = (centre, 0.5 * (values.max() - values.min()))
    lines += ["", f"Reference (the middle of the fits, +- half their range): translation "
              f"{references['t'][0]:.7f} +- {references['t'][1]:.7f} "
              f"({100 * references['t'][1] / references['t'][0]:.3f} %), rotation {references['r'][0]:.7f} +- "
              f"{references['r'][1]:.7f} ({100 * references['r'][1] / references['r'][0]:.3f} %).", ""]
    for label, path in (("turned lattices", args.turned), ("aligned lattices", args.aligned)):
        if path is None:
            continue
        values, bars, diameters, budget = continuum_entries(path)
        lines += [f"The continuum job `{path}` ({label}; time_budget {budget:g} s, "
                  f"bead diameters {diameters[0]:.4g} - {diameters[-1]:.4g}):", "",
                  "| entry | continuum value | its bar % | reference | off % | off / bar | off / (bar + reference's) |",
                  "|---|---|---|---|---|---|---|"]
        for i, name in enumerate(["t_a", "t_b", "t_c", "r_a", "r_b", "r_c"]):
            ref, ref_bar = references["t" if i < 3 else "r"]
            off = values[i] - ref
            lines.append(f"| {name} | {values[i]:.7f} | {100 * bars[i] / values[i]:.3f} | {ref:.7f} | "
                         f"{100 * off / ref:+.3f} | {abs(off) / bars[i]:.2f} | {abs(off) / (bars[i] + ref_bar):.2f} |")
        lines.append("")
    args.out.write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
