#!/usr/bin/env python3
"""control_extension.py --job DIR [--exe BUILD/beadmob] [--finer K] [--offsets N] [--keep DIR] [--reuse]
[--out control_extension.md]: would control samples on levels finer than the full samples' shrink a
non-convex body's bar enough (issue 44, item 4; docs/theory.md T18, "What limits a real particle's
bar")? An experiment on one kept continuum job with control samples (e.g. nonconvex.py's 3-D cross
on turned lattices), not a beadmob feature.

The idea measured: a continuum value is the limit of x, the order L - 1 control mobility, plus the
limit of d = y - x, the order-L sample's difference from its own control (docs/theory.md T18,
"Control samples"). d is small and smooth in h; x carries the discretisation trend and is about a
sixth of a full sample's cost. So x could be extrapolated from levels K finer than the full ladder's,
d from the full ladder alone, and the bar made of the two fits' bars.

What it does: solves an order-1 continuum job on the kept job's body (its &shape group, the kept
job's turned_lattices, `multipole_order = 1` at the control samples' Krylov tolerance 5e-3, a fixed
ladder of K + 4 levels whose finest is K levels finer than the kept job's, N offsets each), then per
diagonal entry in the principal frame (the kept job's equivalent axes, as nonconvex.py):
  - beadmob's own value and bar (scripts/beadmob_post/continuum_bar.py, replayed on the kept job);
  - the split estimate: X, beadmob's fit (the quadratic, its 2 sigma, its model spread) over the x level
    means of both jobs' samples merged by bead diameter (within 1e-4 relative: the two ladders' grids
    are the same up to the digits the finest diameter was given with), plus D, the same fit over the
    kept job's paired differences d; its bar the quadrature sum of the two fit errors (no volume term,
    as small here as in the job's own bar);
  - X's fit on the kept job's x samples alone (no finer level), to separate what the finer levels buy.
Times: the kept job's wall and the order-1 job's (the sum of its sample seconds: what its levels cost).

--reuse: the order-1 job is already in --keep (job.h5); nothing is solved.
"""
import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parents[1] / "scripts"))
from beadmob_post.continuum_bar import combination_bar, entry_power, extrapolate, level_means, read_samples  # noqa: E402
from continuum_jobs import ENV, RANKS  # noqa: E402
from nonconvex import build_version, principal_axes  # noqa: E402

CONTROL_RTOL = 5e-3     # beadmob's control samples' Krylov tolerance (continuum_job.f90's control_rtol)
SAME_LEVEL = 1e-4       # bead diameters this close (relative) are one level


def shape_group(job_nml):
    return next(line for line in job_nml.read_text().splitlines() if line.strip().startswith("&shape"))


def solve_order_one(exe, job, keep, finer, offsets):
    """The order-1 job of the experiment in `keep` (the kept job's body and shape group)."""
    keep.mkdir(parents=True, exist_ok=True)
    samples = read_samples(job / "job.h5")
    finest = float(np.min(samples.bead_diameters)) / 2.0 ** (finer / 3.0)
    with h5py.File(job / "job.h5") as f:
        turned = bool(int(f["continuum"].attrs.get("turned_lattices", 0)))
    shape = shape_group(job / "job.nml")
    if "file" in shape:
        (keep / "body.obj").write_bytes((job / "body.obj").read_bytes())
    (keep / "job.nml").write_text(
        "&run output = 'job.h5' /\n" + shape + "\n"
        f"&hydrodynamics multipole_order = 1, krylov_rtol = {CONTROL_RTOL!r} /\n"
        f"&continuum finest_bead_diameter = {finest!r}, levels = {finer + 4}, offsets = {offsets}, "
        f"turned_lattices = {'.true.' if turned else '.false.'} /\n")
    start = time.perf_counter()
    with open(keep / "job.log", "w") as log:
        subprocess.run(["mpiexec", "-n", str(RANKS), str(exe), "job.nml"], cwd=keep, env=ENV, stdout=log,
                       stderr=subprocess.STDOUT, check=True)
    (keep / "meta.json").write_text(json.dumps({"wall": time.perf_counter() - start, "exe": build_version(exe)}))


def merged_levels(parts):
    """Bead diameters (coarsest first) and per value its 1-based level, for [(diameters, sample_level, values)]."""
    grid = []
    for diameters, _, _ in parts:
        for d in diameters:
            if not any(abs(d - g) <= SAME_LEVEL * g for g in grid):
                grid.append(float(d))
    grid = sorted(grid, reverse=True)
    values, levels = [], []
    for diameters, sample_level, x in parts:
        index = [next(i for i, g in enumerate(grid) if abs(d - g) <= SAME_LEVEL * g) for d in diameters]
        values.append(x)
        levels.append(np.array([index[k - 1] + 1 for k in sample_level]))
    return np.array(grid), np.concatenate(values), np.concatenate(levels)


def analyse(job, keep):
    a, b = read_samples(job / "job.h5"), read_samples(keep / "job.h5")
    if a.sample_full is None:
        sys.exit(f"{job / 'job.h5'}: no control samples (control_offsets = 0): nothing to split")
    rotation, _ = principal_axes(job / "job.h5")
    q = np.zeros((6, 6))
    q[:3, :3] = q[3:, 3:] = rotation
    paired = a.sample_full == 1
    rows = []
    for i, name in enumerate(["t_a", "t_b", "t_c", "r_a", "r_b", "r_c"]):
        w = np.outer(q[:, i], q[:, i])
        value, bar, _ = combination_bar(a, w, entry_power(i, i))
        y = np.einsum("sjk,jk->s", np.where(paired[:, None, None], a.sample_mobility, 0.0), w)
        x = np.einsum("sjk,jk->s", a.sample_control_mobility, w)
        xb = np.einsum("sjk,jk->s", b.sample_mobility, w)
        d_fit = extrapolate(a.bead_diameters, *level_means((y - x)[paired], a.sample_level[paired],
                                                           len(a.bead_diameters)))
        x_alone = extrapolate(a.bead_diameters, *level_means(x, a.sample_level, len(a.bead_diameters)))
        grid, xs, levels = merged_levels([(a.bead_diameters, a.sample_level, x), (b.bead_diameters, b.sample_level, xb)])
        x_fit = extrapolate(grid, *level_means(xs, levels, len(grid)))
        split = x_fit.value + d_fit.value
        rows.append(dict(entry=name, value=value, bar=bar / abs(value), split=split,
                         split_bar=np.hypot(x_fit.fit_error, d_fit.fit_error) / abs(split),
                         x_sigma=2 * x_fit.standard_error / abs(split), x_spread=x_fit.model_spread / abs(split),
                         d_bar=d_fit.fit_error / abs(split), x_alone_bar=np.hypot(x_alone.fit_error, d_fit.fit_error) / abs(split),
                         apart=abs(split - value) / np.hypot(bar, np.hypot(x_fit.fit_error, d_fit.fit_error))))
    return rows, a, b, grid


def report(job, keep, rows, a, b, grid, out):
    meta_job = json.loads((job / "meta.json").read_text()) if (job / "meta.json").exists() else {}
    meta_keep = json.loads((keep / "meta.json").read_text()) if (keep / "meta.json").exists() else {}
    pct = lambda v: f"{100 * v:.3f}"  # noqa: E731
    lines = [
        "# Control samples on finer levels than the full samples (an experiment)", "",
        f"Written by `bench/continuum/control_extension.py --job {job} --keep {keep}` on {time.strftime('%Y-%m-%d')}. "
        f"The kept job: {meta_job.get('source', '?')}, wall {meta_job.get('wall', float('nan')):.0f} s, "
        f"{len(a.sample_level)} samples, bead diameters {a.bead_diameters.max():.4g} - {a.bead_diameters.min():.4g}. "
        f"The order-1 job: {meta_keep.get('exe', '?')}, {len(b.sample_level)} samples on bead diameters "
        f"{b.bead_diameters.max():.4g} - {b.bead_diameters.min():.4g}, their seconds "
        f"{float(np.sum(read_seconds(keep / 'job.h5'))):.0f} s in all. The x ladder merged: "
        f"{len(grid)} levels, {grid.max():.4g} - {grid.min():.4g}. Method: the script's docstring.", "",
        "| entry | beadmob's value | its bar % | split value | split bar % | X: 2 sigma % | X: model spread % | "
        "D: bar % | split without the finer levels: bar % | values apart / bars in quadrature |",
        "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['entry']} | {r['value']:.6g} | {pct(r['bar'])} | {r['split']:.6g} | {pct(r['split_bar'])} | "
                     f"{pct(r['x_sigma'])} | {pct(r['x_spread'])} | {pct(r['d_bar'])} | {pct(r['x_alone_bar'])} | "
                     f"{r['apart']:.2f} |")
    Path(out).write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


def read_seconds(path):
    with h5py.File(path) as f:
        return np.asarray(f["continuum"]["sample_seconds"][()])


def main():
    parser = argparse.ArgumentParser(usage=__doc__.splitlines()[0])
    parser.add_argument("--job", type=Path, required=True, help="a kept continuum job (job.nml, job.h5, body.obj)")
    parser.add_argument("--exe", type=Path, default=HERE.parents[1] / "build" / "beadmob")
    parser.add_argument("--finer", type=int, default=2)
    parser.add_argument("--offsets", type=int, default=8)
    parser.add_argument("--keep", type=Path, default=HERE / "control_extension_runs")
    parser.add_argument("--reuse", action="store_true")
    parser.add_argument("--out", default=str(HERE / "control_extension.md"))
    args = parser.parse_args()
    if not args.reuse:
        solve_order_one(args.exe.resolve(), args.job, args.keep, args.finer, args.offsets)
    report(args.job, args.keep, *analyse(args.job, args.keep), args.out)


if __name__ == "__main__":
    main()
