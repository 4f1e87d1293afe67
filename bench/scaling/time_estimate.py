#!/usr/bin/env python3
"""The dry run's expected wall time against the measured one, phase by phase: writes
bench/scaling/time_estimate.md.

Everyday jobs of the kinds the estimate must serve (docs/input.md, "Know before you run"): the
paper's shapes (products by mirror class, four to six solves), a random compact 1000-bead lattice
body at L = 2 and L = 1 (no symmetry), 2000 jittered off-lattice beads (the pfft operator) and
filled lattice spheres (two solves), each at the default settings on 2 ranks. For each: the dry
run's phases (`--estimate`, the same ranks) and the run's measured phases (`phase_seconds`),
medians of --repeats runs, with the measured Krylov iterations against the estimate's. With
--beside, another build's dry run of the same jobs beside it (its estimate against this build's
measured times: what another cost model, with the same products, would promise).

usage: python3 bench/scaling/time_estimate.py [--exe build/beadmob] [--beside OTHER_EXE] [--repeats 3] [--large]
"""
import argparse
import os
import platform
import re
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "e2e"))
sys.path.insert(0, str(ROOT / "bench" / "offlattice"))
sys.path.insert(0, str(ROOT / "bench" / "operator_check"))
from eden_body import eden_body  # noqa: E402
from offlattice import jittered  # noqa: E402
from lattice_crossover import ENV, RANKS, timed_job  # noqa: E402  (the same launch)

PHASES = ["blocks", "near_field", "solve", "companion", "lubrication", "total"]
UNITS = {"s": 1.0, "min": 60.0, "h": 3600.0}


def jobs(work, large):
    """(label, input file) of each job, written into `work`; large: and the filled sphere of about
    1e6 beads (radius 62.1)."""
    out = []
    for shape in ("cone", "arrowhead", "crescent_moon", "ring_1mm", "ring_4mm"):
        text = (ROOT / "shapes" / f"{shape}.nml").read_text()
        (work / f"{shape}.nml").write_text(re.sub(r"output = '[^']*'", "output = 'result.h5'", text))
        out.append((f"paper {shape}", work / f"{shape}.nml"))
    np.savetxt(work / "random_1000.txt", eden_body(1000), fmt="%.1f")
    np.savetxt(work / "jittered_2000.txt", jittered(2000), fmt="%.6f")
    for name, text in (
            ("random 1000 beads, L = 2", "&shape name = 'bead_file', file = 'random_1000.txt' /\n"),
            ("random 1000 beads, L = 1", "&shape name = 'bead_file', file = 'random_1000.txt' /\n"
                                         "&hydrodynamics multipole_order = 1 /\n"),
            ("jittered 2000 beads (pfft)", "&shape name = 'bead_file', file = 'jittered_2000.txt' /\n"),
            ("sphere, radius 13.4", "&shape name = 'sphere', radius = 13.4 /\n"),
            ("sphere, radius 28.8", "&shape name = 'sphere', radius = 28.8 /\n")):
        nml = work / (re.sub(r"\W+", "_", name).strip("_") + ".nml")
        if "&hydrodynamics" not in text:
            text += "&hydrodynamics /\n"
        nml.write_text("&run output = 'result.h5' /\n" + text)
        out.append((name, nml))
    if large:
        nml = work / "sphere_62.nml"
        nml.write_text("&run output = 'result.h5' /\n&shape name = 'sphere', radius = 62.1 /\n&hydrodynamics /\n")
        out.append(("sphere, radius 62.1 (one run)", nml))
    return out


def seconds(text):
    value, unit = text.split()
    return float(value) * UNITS[unit]


def dry_run(exe, nml, work):
    """The estimate's phases (s) and its CG iterations per solve."""
    out = subprocess.run(["mpiexec", "-n", str(RANKS), exe, str(nml), "--estimate"], cwd=work, env=ENV, check=True,
                         capture_output=True, text=True).stdout
    m = re.search(r"expected wall time:\s+(\S+ \S+) \(blocks (\S+ \S+), solve (\S+ \S+): (\d+) solve\(s\) of "
                  r"~(\d+) CG iterations(?:, error bar's companion (\S+ \S+))?\)", out)
    if not m:
        raise SystemExit(f"no expected wall time in the dry run of {nml}:\n{out}")
    return {"total": seconds(m.group(1)), "blocks": seconds(m.group(2)), "solve": seconds(m.group(3)),
            "companion": seconds(m.group(6)) if m.group(6) else 0.0, "solves": int(m.group(4)),
            "iterations": int(m.group(5))}


def measured(exe, nml, work):
    """The run's phases (s), solves and mean iterations per solved motion, and its operator."""
    def read(h):
        phase = h.attrs["phase_seconds"]
        solved = h.attrs["solve_iterations"][h.attrs["solve_source"] == 0]
        return {"total": float(phase[PHASES.index("total")]), "blocks": float(phase[PHASES.index("blocks")]),
                "solve": float(phase[PHASES.index("solve")]), "companion": float(phase[PHASES.index("companion")]),
                "solves": len(solved), "iterations": float(np.mean(solved)) if len(solved) else 0.0,
                "operator": h.attrs["operator"].decode() + (" by class" if h.attrs["fft_by_mirror_class"] else "")}
    return timed_job(exe, nml, "auto", work, work / "result.h5", read)[1]   # auto: the default


def ratio(estimate, measure):
    return f"{estimate / measure:.2f}" if measure > 0 else "-"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--exe", default=str(ROOT / "build" / "beadmob"))
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--beside", help="another build whose dry run is shown beside this one's")
    parser.add_argument("--large", action="store_true", help="and the 1e6-bead sphere (one run, about a minute)")
    args = parser.parse_args()
    exe = os.path.abspath(args.exe)
    other = os.path.abspath(args.beside) if args.beside else None
    rows = []
    with tempfile.TemporaryDirectory() as work:
        work = Path(work)
        for label, nml in jobs(work, args.large):
            estimate = dry_run(exe, nml, work)
            former = dry_run(other, nml, work) if other else None
            runs = [measured(exe, nml, work) for _ in range(1 if "one run" in label else args.repeats)]
            median = {k: statistics.median(r[k] for r in runs) for k in ("total", "blocks", "solve", "companion")}
            rows.append((label, estimate, median, runs[-1], former))
            print(label, estimate, median, flush=True)
    options = f" --repeats {args.repeats}" + (" --beside OTHER_EXE" if other else "") + (" --large" if args.large else "")
    out = ["# The dry run's expected time against the measured one (generated by "
           f"`python3 bench/scaling/time_estimate.py{options}`)", "",
           f"{platform.machine()}, {os.cpu_count()} cores, {RANKS} ranks, default settings; measured: medians of "
           f"{args.repeats} runs of the friction job's phases (`phase_seconds`); estimated: the dry run "
           "(`--estimate`) of the same job. Ratio: estimated / measured (above 1: the estimate is high). "
           "Iterations: the estimate's CG iterations per solve against the measured mean over the solved motions.", "",
           "| job | operator | solves | iterations est. / meas. | blocks est. / meas. (s) | solve est. / meas. (s) "
           "| companion est. / meas. (s) | total est. / meas. (s) | total ratio |" + (" other build: total est. | its ratio |" if other else ""),
           "|---|---|---|---|---|---|---|---|---|" + ("---|---|" if other else "")]
    worst, worst_other = 0.0, 0.0
    for label, e, m, last, former in rows:
        line = (f"| {label} | {last['operator']} | {last['solves']} | {e['iterations']} / {last['iterations']:.1f} | "
                f"{e['blocks']:.3g} / {m['blocks']:.3g} | {e['solve']:.3g} / {m['solve']:.3g} | "
                f"{e['companion']:.3g} / {m['companion']:.3g} | {e['total']:.3g} / {m['total']:.3g} | "
                f"{ratio(e['total'], m['total'])} |")
        worst = max(worst, e["total"] / m["total"], m["total"] / e["total"])
        if former:
            line += f" {former['total']:.3g} | {ratio(former['total'], m['total'])} |"
            worst_other = max(worst_other, former["total"] / m["total"], m["total"] / former["total"])
        out.append(line)
    out += ["", f"Largest factor between the estimated and the measured total: {worst:.2f}" +
            (f" (the other build's estimate: {worst_other:.2f})." if other else ".")]
    (Path(__file__).resolve().parent / "time_estimate.md").write_text("\n".join(out) + "\n")
    print("\n".join(out))


if __name__ == "__main__":
    main()
