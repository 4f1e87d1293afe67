#!/usr/bin/env python3
"""cross_jobs.py --job LABEL=JOB.h5 [--job ...] [--reference cross_commensurate.md] --out FILE.md: continuum
jobs of the 3-D cross (nonconvex.py) side by side, against the reference by another route.

The cross has no exact mobility, but bench/continuum/cross_commensurate.md has a reference from
ordinary runs on lattices commensurate with its voxels (its line "Reference ..."; translation and
rotation each one number by the cross's cubic symmetry). For every job given: the build that solved
it (the file's git_hash), its ladder (samples per level, coarsest first; the finest level's beads),
the bars of its six principal diagonal entries (beadmob's estimator replayed on its samples,
scripts/beadmob_post/continuum_bar.py: the file's own bars when the estimator is the file's), the
median share of 2 sigma and of the model spread in them, the largest distance of an entry from the
reference and the largest distance in units of the entry's bar. Nothing is solved here."""
import argparse
import re
import sys
from pathlib import Path

import h5py
import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from continuum_jobs import ROOT  # noqa: E402

sys.path.insert(0, str(ROOT / "scripts"))
from beadmob_post import continuum_bar  # noqa: E402


def reference(path):
    """(translation, rotation) from cross_commensurate.md's "Reference" line."""
    text = Path(path).read_text()
    match = re.search(r"Reference .*?translation ([0-9.]+) .*?rotation ([0-9.]+)", text)
    if match is None:
        raise SystemExit(f"cross_jobs.py: no 'Reference ... translation ... rotation ...' line in {path}")
    return float(match.group(1)), float(match.group(2))


def job_row(label, path, exact):
    samples = continuum_bar.read_samples(path)
    with h5py.File(path, "r") as f:
        build = f.attrs["git_hash"].decode()
        axes = np.asarray(f["continuum/equivalent_axes"][()]).T   # h5py rows are the Fortran columns
        beads = np.asarray(f["continuum"].attrs["sample_beads"]).reshape(-1)
        turned = bool(f["continuum"].attrs["turned_lattices"])
    counts = np.bincount(samples.sample_level)[1:]
    finest = int(np.mean(beads[samples.sample_level == len(counts)]))
    entries = continuum_bar.principal_diagonal(samples, axes)
    bars = np.array([100 * bar / abs(value) for value, bar, _ in entries])
    sigma_share = np.median([2 * fit.standard_error / bar for _, bar, fit in entries])
    spread_share = np.median([fit.model_spread / bar for _, bar, fit in entries])
    off = np.array([100 * abs(value - e) / e for (value, _, _), e in zip(entries, exact)])
    in_bar = max(abs(value - e) / bar for (value, bar, _), e in zip(entries, exact))
    return (f"| {label} | {build} | {'turned' if turned else 'aligned'} | {' '.join(map(str, counts))} | {finest} | "
            f"{bars[:3].min():.2f}-{bars[:3].max():.2f} | {bars[3:].min():.2f}-{bars[3:].max():.2f} | "
            f"{sigma_share:.2f} / {spread_share:.2f} | {off[:3].max():.3f} / {off[3:].max():.3f} | {in_bar:.2f} |")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--job", action="append", required=True, metavar="LABEL=JOB.h5")
    parser.add_argument("--reference", default=str(HERE / "cross_commensurate.md"))
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    t, r = reference(args.reference)
    exact = [t] * 3 + [r] * 3
    lines = [f"Reference (cross_commensurate.md): translation {t}, rotation {r}. Bars, distances: % of the value.", "",
             "| job | build | lattice | samples per level | finest beads | translation bars % | rotation bars % | "
             "2 sigma / spread, median share of the bar | largest distance from the reference % (t / r) | "
             "largest distance / bar |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for item in args.job:
        label, _, path = item.partition("=")
        if not Path(path).exists():
            raise SystemExit(f"cross_jobs.py: no result file {path} for job '{label}'")
        lines.append(job_row(label, path, exact))
    Path(args.out).write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
