#!/usr/bin/env python3
"""lattice_turns.py [--exe BUILD/beadmob] [--turns 4] [--out FILE] [--keep DIR]: do samples on turned
lattices make the 3-D cross's continuum bar as small as a smooth body's?

The 3-D cross of bench/continuum/nonconvex.py (three square bars 0.6 x 0.6 x 3, faces along the
axes) has the widest continuum bars of the non-convex bodies, mostly the model spread: its level
means do not follow one smooth law in the bead size d (docs/theory.md T18). Its faces lie along the
lattice's axes, so a bar is always a whole number of bead rows wide, and at the levels where
0.6 / d is an integer every offset gives the same beads (no scatter at all). A lattice turned
against the body has no such alignment.

Two ways to the same number of samples per level on the same ladder (`finest_bead_diameter` =
0.04725, 6 levels, bead counts 830 ... 26.5k; 2 ranks):
* aligned: one continuum job of the cross as made, `offsets` = 2 x turns;
* turned: `turns` continuum jobs, each of the cross turned by a random rotation R_j (numpy
  default_rng(TURN_SEED)) about the origin, `offsets` = 2; each job's samples (its mobility about the
  centroid in its own input frame) are turned back, R_j^T M R_j on both blocks, and the samples of
  all the jobs pooled per level.
Both are then read by beadmob's own estimator (scripts/beadmob_post/continuum_bar.py: the level
means, the weighted quadratic in d, the model spread, 2 sigma; the volume term from the aligned
job) for the six diagonal entries in the cross's axes (x, y, z: its bars), with each level's
relative scatter and the quadratic's reduced chi^2.
"""
import argparse
import json
import sys
import time
from dataclasses import replace
from pathlib import Path

import h5py
import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from continuum_jobs import ROOT, run  # noqa: E402
from nonconvex import cross, write_obj  # noqa: E402

sys.path.insert(0, str(ROOT / "scripts"))
from beadmob_post import continuum_bar  # noqa: E402

TURN_SEED = 46
LADDER = "levels = 6, finest_bead_diameter = 0.04725"
NAMES = ("t_x", "t_y", "t_z", "r_x", "r_y", "r_z")


def random_rotation(rng):
    """A uniformly random rotation from a unit quaternion of four standard normals."""
    w, x, y, z = (lambda q: q / np.linalg.norm(q))(rng.standard_normal(4))
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def continuum_job(exe, folder, vertices, faces, offsets):
    folder.mkdir(parents=True, exist_ok=True)
    write_obj(folder / "body.obj", vertices, faces)
    text = ("&shape name = 'mesh', file = 'body.obj', bead_diameter = 0.075 /\n&hydrodynamics /\n"
            f"&continuum {LADDER}, offsets = {offsets} /\n")
    return run(exe, text, folder)


def turned_back(samples, rotation):
    q = np.zeros((6, 6))
    q[:3, :3] = q[3:, 3:] = rotation
    return replace(samples, sample_mobility=np.einsum("ji,sjk,kl->sil", q, samples.sample_mobility, q))


def pooled(parts):
    first = parts[0]
    return replace(first, sample_level=np.concatenate([p.sample_level for p in parts]),
                   sample_mobility=np.concatenate([p.sample_mobility for p in parts]))


def analysis(samples):
    """Per diagonal entry: value, bar %, 2 sigma %, spread %, chi2/dof, the levels' relative scatter %."""
    rows = []
    for i, name in enumerate(NAMES):
        weights = np.zeros((6, 6))
        weights[i, i] = 1.0
        value, bar, fit = continuum_bar.combination_bar(samples, weights, continuum_bar.entry_power(i, i))
        values = samples.sample_mobility[:, i, i]
        scatter = [100 * np.std(values[samples.sample_level == k], ddof=1) / abs(np.mean(values[samples.sample_level == k]))
                   for k in range(1, len(samples.bead_diameters) + 1)]
        rows.append(dict(name=name, value=value, bar=100 * bar / abs(value), sigma2=200 * fit.standard_error / abs(value),
                         spread=100 * fit.model_spread / abs(value), chi2=fit.reduced_chi2, scatter=scatter))
    return rows


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--exe", default=str(ROOT / "build" / "beadmob"))
    parser.add_argument("--turns", type=int, default=4)
    parser.add_argument("--keep", default=str(HERE / "lattice_turns_runs"))
    parser.add_argument("--reuse", action="store_true", help="read the kept jobs, solve nothing")
    parser.add_argument("--out", default=str(HERE / "lattice_turns.md"))
    args = parser.parse_args()
    keep = Path(args.keep)
    vertices, faces = cross()
    rng = np.random.default_rng(TURN_SEED)
    rotations = [random_rotation(rng) for _ in range(args.turns)]
    walls = {}
    if not args.reuse:
        _, walls["aligned"] = continuum_job(args.exe, keep / "aligned", vertices, faces, 2 * args.turns)
        for j, rotation in enumerate(rotations):
            _, walls[f"turn{j}"] = continuum_job(args.exe, keep / f"turn{j}", vertices @ rotation.T, faces, 2)
        (keep / "walls.json").write_text(json.dumps(walls))
    walls = json.loads((keep / "walls.json").read_text())
    aligned = continuum_bar.read_samples(keep / "aligned" / "job.h5")
    turned = pooled([turned_back(continuum_bar.read_samples(keep / f"turn{j}" / "job.h5"), rotation)
                     for j, rotation in enumerate(rotations)])
    turned = replace(turned, volume=aligned.volume, volume_error=aligned.volume_error)
    if not np.allclose(turned.bead_diameters, aligned.bead_diameters):
        sys.exit("the turned jobs ran another ladder than the aligned one")
    beads = {}
    for key in ["aligned"] + [f"turn{j}" for j in range(args.turns)]:
        with h5py.File(keep / key / "job.h5") as f:
            beads[key] = int(np.max(f["continuum"].attrs["sample_beads"]))
    lines = ["# The 3-D cross on aligned and on turned lattices", "",
             f"Written by `bench/continuum/lattice_turns.py` on {time.strftime('%Y-%m-%d')} (2 ranks; `&continuum "
             f"{LADDER}`; aligned: offsets = {2 * args.turns}; turned: {args.turns} random rotations x offsets = 2). "
             "Wall: " + ", ".join(f"{k} {v:.0f} s ({beads[k]} beads finest)" for k, v in walls.items()) + ".", "",
             "Bars relative to the value (%), in the cross's axes; scatter: each level's relative standard deviation "
             "over its samples (%), coarsest level first.", "",
             "| lattice | entry | value | bar % | 2 sigma % | spread % | chi2/dof | scatter per level % |",
             "|---|---|---|---|---|---|---|---|"]
    for label, samples in (("aligned", aligned), ("turned", turned)):
        for row in analysis(samples):
            lines.append(f"| {label} | {row['name']} | {row['value']:.6g} | {row['bar']:.3f} | {row['sigma2']:.3f} | "
                         f"{row['spread']:.3f} | {row['chi2']:.2f} | "
                         + ", ".join(f"{s:.3f}" for s in row["scatter"]) + " |")
    Path(args.out).write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
