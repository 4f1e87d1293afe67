#!/usr/bin/env python3
"""same_numbers.py OLD_EXE NEW_EXE [--ranks P] [--out same_numbers.md]: does a change of the code's
structure change any number? Runs both executables on the same inputs (2 ranks, reproducible FFT
plans: -fft_planner estimate) and compares every dataset and attribute of the two result files
bit for bit, except what belongs to the run (its date, timings and memory: the list of
tests/e2e/compare_result_files.py) and the build stamp. Writes a markdown table: per input, the
entries compared and those that differ, with the largest relative difference of each.
"""
import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "e2e"))
from compare_result_files import RUN_SPECIFIC, collect  # noqa: E402

#: The build, not the computation.
BUILD_STAMP = {"program_version", "git_hash", "beadmob_version", "version"}

#: One job per path through the code: the default job (FFT operator, shell, symmetries, error bar),
#: a body solved in its body frame off the lattice, a sphere (two solves of six), the lubrication
#: correction with the bead forces, some motions only, a few beads, the accuracy target, shells.
INPUTS = ["shapes/cone.nml", "tests/e2e/inputs/plan_turned_cone.nml", "tests/e2e/inputs/symmetry_sphere.nml",
          "tests/e2e/inputs/multipole_cone.nml", "tests/e2e/inputs/motions_u_x.nml",
          "tests/e2e/inputs/rpy_pyramid.nml", "tests/e2e/inputs/accuracy_target.nml",
          "tests/e2e/inputs/shell_sphere.nml", "tests/e2e/inputs/plan_shell_cone.nml"]


def run(exe, input_path, workdir, ranks):
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    command = ["mpiexec", "--oversubscribe", "-n", str(ranks), exe, str(ROOT / input_path), "-quiet",
               "-fft_planner", "estimate"]
    done = subprocess.run(command, cwd=workdir, env=env, capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"{exe} {input_path} failed:\n{done.stderr}")
    outputs = [p for p in Path(workdir).glob("*.h5") if not p.name.endswith("checkpoint.h5")]
    if len(outputs) != 1:
        sys.exit(f"{input_path}: expected one result file in {workdir}, found {outputs}")
    return outputs[0]


def differences(a, b):
    old, new = collect(a), collect(b)
    skipped = {key for key in old.keys() | new.keys() if key.split("/")[-1] in RUN_SPECIFIC | BUILD_STAMP}
    keys = sorted((old.keys() | new.keys()) - skipped)
    changed = []
    for key in keys:
        if key not in old or key not in new:
            changed.append((key, "only in " + ("new" if key in new else "old")))
            continue
        x, y = np.asarray(old[key]), np.asarray(new[key])
        if x.shape != y.shape or x.dtype.kind != y.dtype.kind:
            changed.append((key, f"shape or type {x.shape} {x.dtype} -> {y.shape} {y.dtype}"))
        elif x.dtype.kind == "f":
            if x.tobytes() != y.tobytes():
                scale = max(np.nanmax(np.abs(x)), 1e-300) if x.size else 1.0
                changed.append((key, f"largest relative difference {np.nanmax(np.abs(x - y)) / scale:.1e}"))
        elif not np.array_equal(x, y):
            changed.append((key, "text or integers differ"))
    return len(keys), changed


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("old_exe")
    parser.add_argument("new_exe")
    parser.add_argument("--ranks", type=int, default=2)
    parser.add_argument("--out", default=str(Path(__file__).with_name("same_numbers.md")))
    parser.add_argument("--title", default="")
    args = parser.parse_args()
    rows = []
    for input_path in INPUTS:
        with tempfile.TemporaryDirectory() as old_dir, tempfile.TemporaryDirectory() as new_dir:
            compared, changed = differences(run(args.old_exe, input_path, old_dir, args.ranks),
                                            run(args.new_exe, input_path, new_dir, args.ranks))
        detail = "; ".join(f"`{key}`: {what}" for key, what in changed) or "none"
        rows.append(f"| `{input_path}` | {compared} | {len(changed)} | {detail} |")
        print(rows[-1], flush=True)
    text = [f"# Same numbers{': ' + args.title if args.title else ''}", "",
            f"Written by `bench/same_numbers/same_numbers.py` on {args.ranks} ranks with `-fft_planner estimate`: "
            "every dataset and attribute of the two builds' result files compared bit for bit, except the "
            "run's date, timings and memory and the build stamp.", "",
            "| input | entries compared | entries that differ | which |", "|---|---|---|---|"] + rows
    Path(args.out).write_text("\n".join(text) + "\n")


if __name__ == "__main__":
    main()
