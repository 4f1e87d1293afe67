#!/usr/bin/env python3
"""Off-lattice bead models for bench/offlattice.md (issue 14): bead files and beadmob inputs.

Three kinds of model (bead diameter d = 1, bead radius 0.5; coordinates in d), each at about
200 (quick checks), 2000, 5000 and 20000 beads:

  jittered  a compact ball of cubic lattice points (the n points nearest the origin, ties in
            lexicographic order), scaled by 1.1, each coordinate shifted by a uniform random
            amount in [-0.04, 0.04] d (numpy default_rng(1)). Exactly n beads. Nearest centres
            are >= 1.1 - 2 * 0.04 = 1.02 d apart by construction (axis neighbours).
  shell     n beads on a sphere's surface: the Fibonacci (golden-angle) lattice, polar angle
            arccos(1 - 2 (k + 1/2) / n), azimuth pi (1 + sqrt 5) (k + 1/2). The radius is set
            so that the *smallest* nearest-neighbour distance is NEAREST_TARGET = 1.005 d (the
            median nearest-neighbour distance is then ~1.10 d). Exactly n beads.
  cone      the paper's cone (shapes/cone.nml: base_diameter 20, height 47, 5088 beads), its
            bead centres taken from beadmob itself (`beadmob cone.nml -geometry_only`, dataset
            /geometry/positions of the result file), centred on their centroid and turned by
            30 degrees about (1, 2, 3)/sqrt(14) -- not a symmetry of the cubic lattice. The cone
            preset takes base_diameter and height, so the other sizes are the cone scaled by
            (n / 5088)^(1/3) at the paper's aspect ratio (rounded to whole d): the bead count
            is whatever the lattice cone of that size has (printed, and written in the files).

All models are centred on their centroid (the mean of the bead centres), the reference point of
the 6x6 mobility in bench/offlattice_pygrpy.py.

For each model the script writes into --out (default bench/offlattice_runs/models, ignored by git):
  <kind>_<n>.txt          the bead file (text format of src/io/text_bead_file.f90: "x y z" in d,
                          '#' comments)
  <kind>_<n>_L1.nml       beadmob input: &hydrodynamics multipole_order = 1 (the RPY level)
  <kind>_<n>_default.nml  beadmob input: &hydrodynamics / (all defaults: L = 2, error bar)
and a summary models.csv (kind, target, beads, nearest distance, median nearest, extent).

usage: python3 bench/offlattice_models.py [--sizes 200,2000,5000,20000] [--kinds jittered,shell,cone]
       [--out DIR] [--beadmob build/beadmob]
The cone needs a built beadmob (bash scripts/build.sh); the other two need numpy and scipy only.
"""
import argparse
import csv
import os
import subprocess
import sys

import numpy as np
from scipy.spatial import cKDTree

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PAPER_CONE = (20, 47, 5088)        # base_diameter, height (d), beads: shapes/cone.nml
JITTER_SCALE, JITTER_AMPLITUDE, JITTER_SEED = 1.1, 0.04, 1
NEAREST_TARGET = 1.005             # shell: smallest nearest-neighbour centre distance (d)
ROTATION_AXIS, ROTATION_DEGREES = (1.0, 2.0, 3.0), 30.0


def rotation(axis, degrees):
    """Rodrigues' rotation matrix: `degrees` about `axis` (right-handed)."""
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    angle = np.radians(degrees)
    cross = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.cos(angle) * np.eye(3) + np.sin(angle) * cross + (1 - np.cos(angle)) * np.outer(axis, axis)


def nearest_distances(points):
    """Distance from each bead centre to its nearest neighbour."""
    distance, _ = cKDTree(points).query(points, k=2)
    return distance[:, 1]


def jittered(n):
    """The n lattice points nearest the origin (stable order), scaled and jittered."""
    radius = 1.0
    while True:
        g = np.arange(-int(radius) - 1, int(radius) + 2)
        points = np.array(np.meshgrid(g, g, g, indexing="ij")).reshape(3, -1).T
        points = points[(points**2).sum(1) <= radius * radius]
        if len(points) >= n:
            break
        radius += 0.25
    points = points[np.argsort((points**2).sum(1), kind="stable")][:n]
    shift = np.random.default_rng(JITTER_SEED).uniform(-JITTER_AMPLITUDE, JITTER_AMPLITUDE, (n, 3))
    return JITTER_SCALE * points + shift


def shell(n):
    """n Fibonacci points on a sphere whose radius makes the closest pair NEAREST_TARGET apart."""
    k = np.arange(n) + 0.5
    polar = np.arccos(1 - 2 * k / n)
    azimuth = np.pi * (1 + 5**0.5) * k
    unit = np.stack([np.cos(azimuth) * np.sin(polar), np.sin(azimuth) * np.sin(polar), np.cos(polar)], axis=1)
    return unit * (NEAREST_TARGET / nearest_distances(unit).min())


def cone_size(n):
    scale = (n / PAPER_CONE[2])**(1 / 3)
    return round(PAPER_CONE[0] * scale), round(PAPER_CONE[1] * scale)


def lattice_cone(base, height, workdir, beadmob):
    """The lattice cone's bead centres, from `beadmob -geometry_only` (rows: beads)."""
    import h5py
    stem = f"cone_lattice_{base}x{height}"
    nml = os.path.join(workdir, stem + ".nml")
    with open(nml, "w") as f:
        f.write(f"! the paper cone preset at base_diameter {base}, height {height} (bench/offlattice_models.py)\n"
                f"&run output = '{stem}.h5', progress = .false. /\n"
                f"&shape name = 'cone', base_diameter = {base}, height = {height} /\n")
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    subprocess.run([beadmob, os.path.basename(nml), "-geometry_only", "-quiet"], cwd=workdir, env=env,
                   check=True, stdout=subprocess.DEVNULL)
    with h5py.File(os.path.join(workdir, stem + ".h5"), "r") as f:
        points = np.asarray(f["geometry/positions"][()], float)
    return points if points.shape[1] == 3 else points.T


def cone(n, workdir, beadmob):
    base, height = (PAPER_CONE[0], PAPER_CONE[1]) if n == 5000 else cone_size(n)
    points = lattice_cone(base, height, workdir, beadmob)
    points = points - points.mean(axis=0)
    return points @ rotation(ROTATION_AXIS, ROTATION_DEGREES).T, f"base_diameter {base}, height {height}"


def write_model(out, kind, target, points, note):
    name = f"{kind}_{target}"
    nearest = nearest_distances(points)
    header = (f"{kind} model, {len(points)} beads (target {target}), {note}\n"
              f"nearest centre distance {nearest.min():.6f} d, median nearest {np.median(nearest):.6f} d\n"
              "x y z in bead diameters; written by bench/offlattice_models.py")
    np.savetxt(os.path.join(out, name + ".txt"), points, fmt="%.12f", header=header)
    for suffix, hydro in (("L1", "multipole_order = 1"), ("default", "")):
        with open(os.path.join(out, f"{name}_{suffix}.nml"), "w") as f:
            f.write(f"! {kind} model, {len(points)} beads: beadmob at "
                    f"{'L = 1 (RPY level)' if hydro else 'the default settings'} (bench/offlattice_models.py)\n"
                    f"&run output = '{name}_{suffix}.h5' /\n"
                    f"&shape name = 'bead_file', file = '{name}.txt' /\n"
                    f"&hydrodynamics {hydro} /\n")
    extent = points.max(axis=0) - points.min(axis=0)
    return {"kind": kind, "target": target, "beads": len(points), "nearest": f"{nearest.min():.6f}",
            "median_nearest": f"{np.median(nearest):.6f}", "extent": " x ".join(f"{e:.2f}" for e in extent),
            "note": note}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="200,2000,5000,20000")
    parser.add_argument("--kinds", default="jittered,shell,cone")
    parser.add_argument("--out", default=os.path.join(ROOT, "bench", "offlattice_runs", "models"))
    parser.add_argument("--beadmob", default=os.path.join(os.environ.get("BUILD_DIR", os.path.join(ROOT, "build")),
                                                          "beadmob"))
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    rows = []
    for kind in args.kinds.split(","):
        for target in (int(s) for s in args.sizes.split(",")):
            if kind == "jittered":
                points, note = jittered(target), (f"lattice ball x {JITTER_SCALE} + U(-{JITTER_AMPLITUDE}, "
                                                  f"{JITTER_AMPLITUDE}) per coordinate, seed {JITTER_SEED}")
            elif kind == "shell":
                points = shell(target)
                note = f"Fibonacci sphere of radius {np.linalg.norm(points[0]):.6f} d"
            elif kind == "cone":
                points, note = cone(target, args.out, os.path.abspath(args.beadmob))
                note = f"paper cone preset {note}, turned {ROTATION_DEGREES:g} deg about (1, 2, 3)"
            else:
                sys.exit(f"unknown kind {kind}")
            rows.append(write_model(args.out, kind, target, points, note))
            print(", ".join(f"{k} {v}" for k, v in rows[-1].items()), flush=True)
            if float(rows[-1]["nearest"]) < 1.0:
                sys.exit(f"{kind}_{target}: beads overlap (nearest {rows[-1]['nearest']} d)")
    with open(os.path.join(args.out, "models.csv"), "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    print("wrote", args.out)


if __name__ == "__main__":
    sys.exit(main())
