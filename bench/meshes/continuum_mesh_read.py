#!/usr/bin/env python3
"""continuum_mesh_read.py --before OLD_EXE [--after NEW_EXE] [--repeats 5]: a continuum job on a
1e6-triangle mesh, a build that reads and checks the mesh at every fill beside one that reads it
once per job (d340c23: shape_catalog.f90 read_mesh_once, continuum_job.f90).

The sphere of bench/meshes/mesh_fill.py (radius 1, 998000 triangles, binary STL, made by the same
helpers) in a continuum job kept small so the solves do not dominate: `&continuum levels = 3,
offsets = 2, finest_bead_diameter = 0.128` (about 2000 beads at the finest level), the default
moment_fills (32), default &hydrodynamics, 2 ranks. Whole processes (mpiexec to exit), the two
builds alternated pair by pair (the first of a pair alternating too) after one warm-up pair that
is not counted; median, min and max per build, the ratio of the medians and the pairs' ratios.
Phase split, from the counted runs: the six ladder samples (each its fill and its solve: the sum
of /continuum/sample_seconds) and the rest of the process (start-up, the mesh read(s), the
survey's and the moment fills, the fit, the result file); beside it one `-geometry_only` process
of the mesh at the finest bead diameter (read, check, one fill) and of the analytic sphere of the
same radius (start-up and geometry checks alone), medians of 3 (mesh_fill.timed_run). The times
each build opens the mesh file: the warm-up pair run under strace. The same job in both builds:
the ladder's bead counts, and /continuum/mobility against mobility_error. Runs and the mesh are
kept in bench/meshes/continuum_mesh_read_runs/."""
import argparse
import datetime
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path.insert(0, str(HERE))
import mesh_fill  # noqa: E402  (the mesh helpers, ENV, RANKS and timed_run of the existing mesh bench)

WORK = HERE / "continuum_mesh_read_runs"
FINEST = 0.128          # (4/3 pi / 2000)^(1/3) = 0.1279: ~2000 beads at the finest level of the unit sphere
CONTINUUM = f"levels = 3, offsets = 2, finest_bead_diameter = {FINEST}"
MESH = "sphere.stl"


def write_input(tag):
    """The job's input file for one build (its own result file)."""
    nml = WORK / f"{tag}.nml"
    nml.write_text(f"&run output = '{tag}.h5', checkpoint = .false. /\n"
                   f"&shape name = 'mesh', file = '{MESH}', bead_diameter = {FINEST} /\n"
                   f"&hydrodynamics /\n&continuum {CONTINUUM} /\n")
    return nml


def continuum_job(exe, tag, prefix=()):
    """One whole continuum job: (wall seconds, the result's /continuum numbers). The result file is
    removed first, so a stale one is never read; the job's printout is kept in <tag>.log. `prefix`:
    a command the job runs under (strace for the warm-up pair)."""
    nml, result = WORK / f"{tag}.nml", WORK / f"{tag}.h5"
    result.unlink(missing_ok=True)
    with open(WORK / f"{tag}.log", "w") as log:
        start = time.perf_counter()
        subprocess.run([*prefix, "mpiexec", "-n", str(mesh_fill.RANKS), exe, str(nml)], cwd=WORK,
                       env=mesh_fill.ENV, check=True, stdout=log, stderr=subprocess.STDOUT)
        wall = time.perf_counter() - start
    with h5py.File(result) as f:
        c = f["continuum"]
        return wall, dict(mobility=c["mobility"][()], mobility_error=c["mobility_error"][()],
                          diameters=c["bead_diameters"][()], beads=c.attrs["sample_beads"][()],
                          samples=float(np.sum(c["sample_seconds"][()])), coefficients=c["coefficients"][()],
                          coefficient_error=c["coefficient_error"][()])


def spread(values):
    return float(np.median(values)), float(np.min(values)), float(np.max(values))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", required=True, help="the build before the change (4cd6227)")
    parser.add_argument("--after", default=str(ROOT / "build" / "beadmob"))
    parser.add_argument("--repeats", type=int, default=5, help="counted pairs")
    parser.add_argument("--out", default=str(HERE / "continuum_mesh_read.md"))
    parser.add_argument("--before-label", default="4cd6227", help="the commit --before was built from")
    parser.add_argument("--after-label", default="main", help="the commit --after was built from")
    args = parser.parse_args()
    exes = {"before": os.path.abspath(args.before), "after": os.path.abspath(args.after)}
    labels = {"before": args.before_label, "after": args.after_label}
    WORK.mkdir(exist_ok=True)
    started = datetime.datetime.now(datetime.timezone.utc)
    triangles = mesh_fill.ellipsoid_mesh(1.0, 1.0, 1.0, n=500)   # 4 n^2 - 2 n = 998e3 triangles
    mesh_fill.write_stl_binary(WORK / MESH, triangles)
    megabytes = (WORK / MESH).stat().st_size / 1e6
    for tag in exes:
        write_input(tag)

    walls = {tag: [] for tag in exes}
    results = {tag: [] for tag in exes}
    opens = {}
    for pair in range(args.repeats + 1):            # pair 0: the warm-up, not counted
        order = ("before", "after") if pair % 2 == 0 else ("after", "before")
        for tag in order:
            # The warm-up pair under strace: how many times each build opens (reads) the mesh file.
            trace = WORK / f"{tag}.strace"
            prefix = ("strace", "-f", "-qq", "-e", "trace=open,openat", "-o", str(trace)) if pair == 0 else ()
            wall, numbers = continuum_job(exes[tag], tag, prefix)
            if pair == 0:
                opens[tag] = sum(1 for line in trace.read_text().splitlines()
                                 if f'{MESH}"' in line and "= -1" not in line)
            print(f"pair {pair} {tag}: {wall:.2f} s (samples {numbers['samples']:.2f} s)", flush=True)
            if pair > 0:
                walls[tag].append(wall)
                results[tag].append(numbers)
    ratios = [b / a for b, a in zip(walls["before"], walls["after"])]

    geometry = {}
    for tag, exe in exes.items():
        mesh_times, sphere_times = [], []
        for _ in range(3):
            seconds, _ = mesh_fill.timed_run(exe, f"name = 'mesh', file = '{MESH}', bead_diameter = {FINEST}", WORK)
            mesh_times.append(seconds)
            seconds, _ = mesh_fill.timed_run(exe, f"name = 'sphere', radius = {1 / FINEST:.17g}", WORK)
            sphere_times.append(seconds)
        geometry[tag] = (float(np.median(mesh_times)), float(np.median(sphere_times)))
        print(tag, "geometry only (mesh, sphere):", geometry[tag], flush=True)

    # The same job: the same ladder, and the mobility within the error bars.
    first = {tag: results[tag][0] for tag in exes}
    same_ladder = (np.array_equal(first["before"]["beads"], first["after"]["beads"]) and
                   np.allclose(first["before"]["diameters"], first["after"]["diameters"], rtol=1e-12, atol=0))
    difference = np.abs(first["after"]["mobility"] - first["before"]["mobility"])
    bar = np.minimum(first["after"]["mobility_error"], first["before"]["mobility_error"])
    within = bool(np.all(difference <= bar))
    scale = np.max(np.abs(first["before"]["mobility"]))
    repeat_spread = max(float(np.max(np.abs(r["mobility"] - first[tag]["mobility"])))
                        for tag in exes for r in results[tag])

    def median_rest(tag):
        return float(np.median([w - r["samples"] for w, r in zip(walls[tag], results[tag])]))

    def median_samples(tag):
        return float(np.median([r["samples"] for r in results[tag]]))

    rows = []
    for tag in exes:
        median, low, high = spread(walls[tag])
        rows.append(f"| {tag} ({labels[tag]}) | {median:.1f} | {low:.1f} | {high:.1f} | {median_samples(tag):.1f} | "
                    f"{median_rest(tag):.1f} | {opens[tag]} | {geometry[tag][0]:.2f} | {geometry[tag][1]:.2f} |")
    before, after = float(np.median(walls["before"])), float(np.median(walls["after"]))
    ratio_medians = before / after
    pair_median, pair_low, pair_high = spread(ratios)
    extra_reads = opens["before"] - opens["after"]
    read_cost = (before - after) / extra_reads if extra_reads > 0 else float("nan")
    m_before, m_after = first["before"], first["after"]
    coefficients = ", ".join(f"{a:.5f} / {b:.5f} +- {e:.5f}" for a, b, e in
                             zip(m_before["coefficients"], m_after["coefficients"], m_after["coefficient_error"]))
    cpu = next((line.split(":", 1)[1].strip() for line in Path("/proc/cpuinfo").read_text().splitlines()
                if line.startswith("model name")), platform.machine())
    memory = next((int(line.split()[1]) / 2**20 for line in Path("/proc/meminfo").read_text().splitlines()
                   if line.startswith("MemTotal")), float("nan"))
    machine = (f"{os.cpu_count()} cores ({cpu}), {memory:.0f} GiB, shared with other work (wall times vary with "
               f"the load; the pairs' ratios less), Linux {platform.release()}")
    text = [
        "# A continuum job on a 1e6-triangle mesh: the mesh read at every fill, and once", "",
        f"Written by `python3 bench/meshes/continuum_mesh_read.py {' '.join(sys.argv[1:])}` on "
        f"{started:%Y-%m-%d} (UTC); Release builds (`scripts/build.sh`) of {labels['before']} (before: the mesh "
        f"read and checked at every fill) and {labels['after']} (after d340c23: read and checked once per job). "
        f"Machine: {machine}.", "",
        f"The job: the sphere of [mesh_fill.md](mesh_fill.md) (radius 1, {len(triangles)} triangles, binary STL, "
        f"{megabytes:.0f} MB), `&shape name = 'mesh', bead_diameter = {FINEST}`, default `&hydrodynamics`, "
        f"`&continuum {CONTINUUM} /` (default moment_fills = 32; beads per sample "
        f"{', '.join(str(b) for b in m_after['beads'])}), {mesh_fill.RANKS} ranks. Wall: the whole process "
        f"(mpiexec to exit), {args.repeats} pairs of the two builds alternated (the first of each pair alternating) "
        "after one warm-up pair that is not counted. Samples: the sum of the ladder's six samples' "
        "`/continuum/sample_seconds` (each its fill and its solve), median over the runs; rest: wall minus samples "
        "(start-up, the mesh read(s), the survey's and the 32 moment fills, the fit, the result file), median. "
        "Mesh reads: the times the job opened the STL file (the warm-up pair run under `strace -f -e "
        "trace=open,openat`). Geometry only: one `-geometry_only` process of the mesh at d = "
        f"{FINEST} (start-up, read, check, one fill) and of the analytic `sphere` of the same radius (start-up and "
        "geometry checks alone), medians of 3.", "",
        "| build | wall median (s) | min | max | samples (s) | rest (s) | mesh reads | geometry only, mesh (s) | "
        "geometry only, sphere (s) |",
        "|---|---|---|---|---|---|---|---|---|",
        *rows, "",
        f"Ratio before / after: {ratio_medians:.2f}x (medians); pair by pair {pair_median:.2f}x "
        f"(min {pair_low:.2f}, max {pair_high:.2f}).", "",
        f"Same job: the same ladder in both builds ({'yes' if same_ladder else 'NO'}: bead diameters and beads per "
        f"sample); /continuum/mobility differs by at most {float(np.max(difference)):.2e} (largest entry "
        f"{scale:.4f}), {'within' if within else 'NOT within'} mobility_error entry by entry (smallest bar "
        f"{float(np.min(bar)):.2e}); between the repeats of one build by at most {repeat_spread:.2e}. Coefficients "
        f"mu11 ... mu51, before / after +- the error bar: {coefficients}.", "",
        f"Reading: the mesh read once instead of {opens['before']} times takes the job from {before:.0f} s to "
        f"{after:.0f} s ({ratio_medians:.1f}x, pairs {pair_low:.1f}-{pair_high:.1f}x) with the same mobility: "
        f"{read_cost:.1f} s per read saved (beside it a geometry-only process of the mesh takes "
        f"{geometry['before'][0] - geometry['before'][1]:.1f} s more than the sphere's: read, check, one fill).",
        f"After it the job's {after:.0f} s are the samples ({median_samples('after'):.0f} s) and a rest of "
        f"{median_rest('after'):.0f} s (the survey's and the moment fills of the 1e6-triangle mesh, no longer "
        f"reading it: {median_rest('before'):.0f} s before).",
    ]
    Path(args.out).write_text("\n".join(text) + "\n")
    print("\n".join(text))


if __name__ == "__main__":
    main()
