#!/usr/bin/env python3
"""check_resume.py: the checkpoint and resume of a friction job (docs/input.md, "Checkpoints and progress"), end to end.

    check_resume.py WORKDIR INPUT CHANGED_INPUT STOP_RANKS RESUME_RANKS MPIEXEC NUMPROC_FLAG BEADMOB

In WORKDIR, with INPUT (a body whose six motions are all solved, output 'resume_box.h5'):
  1. an uninterrupted run on RESUME_RANKS ranks: the reference; it leaves no checkpoint;
  2. a run on STOP_RANKS ranks stopped after 2 solves (-stop_after_solves 2, as a kill at a
     wall-time limit): fails, leaves no result file, leaves a checkpoint holding the two motions
     its progress lines report solved (the motions are solved together and finish in the order
     of their iteration counts) whose key_digest is the FNV-1a 64 of its key;
  3. the same job rerun on RESUME_RANKS ranks: resumes 2 motions (stdout and resumed_motions),
     gives the reference friction within the two files' solver error bounds, and removes the checkpoint;
  4. interrupted again, then CHANGED_INPUT (same output, another Krylov tolerance): one warning,
     nothing resumed (resumed_motions all 0), the checkpoint overwritten and removed at the end;
  5. a damaged checkpoint file: one warning, nothing resumed, the run succeeds;
  6. with &run checkpoint = .false.: an interrupted run leaves no checkpoint.
Every run: -ksp_rtol 1e-10 -fft_planner estimate (bitwise reproducible FFT plans).
"""
import os
import re
import subprocess
import sys

import h5py
import numpy as np

from solver_promise import allowed_difference, bound
from checklist import check, failures

OUTPUT = "resume_box.h5"
CHECKPOINT = OUTPUT + ".checkpoint.h5"
OPTIONS = ["-ksp_rtol", "1e-10", "-fft_planner", "estimate"]


def fnv1a_64(data: bytes) -> str:
    h = 0xCBF29CE484222325
    for byte in data:
        h = ((h ^ byte) * 0x100000001B3) % 2**64
    return f"{h:016X}"


def text(value):
    return value.decode() if isinstance(value, bytes) else str(value)


def run(ranks, input_path, *extra):
    command = [*MPIEXEC, NUMPROC_FLAG, str(ranks), BEADMOB, input_path, *OPTIONS, *extra]
    print("$", " ".join(command), flush=True)
    done = subprocess.run(command, capture_output=True, text=True)
    output = done.stdout + done.stderr
    print("\n".join(line for line in output.splitlines() if "runtime warning" not in line and
                    not line.startswith("At line")))
    return done.returncode, output


def hydro(path):
    with h5py.File(path, "r") as f:
        g = f["hydrodynamics"]
        return g["friction"][()], [int(x) for x in g.attrs["resumed_motions"]]


def solver_allowance(first, second):
    """|zeta_1 - zeta_2| that the two runs' files promise (solver_promise.py)."""
    with h5py.File(first, "r") as f, h5py.File(second, "r") as g:
        return allowed_difference([bound(f["hydrodynamics"]), bound(g["hydrodynamics"])],
                                  g["hydrodynamics/multipole_friction"][()])


MOTION_NAMES = ["U_x", "U_y", "U_z", "W_x", "W_y", "W_z"]


def solved_motions(output):
    """The motions a run's progress lines report solved, in order."""
    return re.findall(r"progress: solve (\w+): \d+ iterations", output)


def interrupted(ranks, input_path):
    status, output = run(ranks, input_path, "-stop_after_solves", "2")
    check(status != 0, "the interrupted run fails")
    check("stopped after 2 solves" in output, "it says it stopped after 2 solves")
    check(not os.path.exists(OUTPUT) and not os.path.exists(OUTPUT + ".partial"),
          "the interrupted run leaves no result file")
    return output


def main():
    os.makedirs(WORKDIR, exist_ok=True)
    os.chdir(WORKDIR)
    for name in (OUTPUT, OUTPUT + ".partial", CHECKPOINT, CHECKPOINT + ".tmp", "reference.h5"):
        if os.path.exists(name):
            os.remove(name)

    print(f"--- 1. uninterrupted run on {RESUME_RANKS} rank(s)")
    status, output = run(RESUME_RANKS, INPUT)
    check(status == 0 and os.path.exists(OUTPUT), "the uninterrupted run succeeds")
    check(not os.path.exists(CHECKPOINT), "a finished run leaves no checkpoint")
    if status != 0:
        return
    os.rename(OUTPUT, "reference.h5")
    reference, resumed = hydro("reference.h5")
    check(resumed == [0] * 6, f"nothing resumed in the uninterrupted run: {resumed}")

    print(f"--- 2. run stopped after 2 solves on {STOP_RANKS} rank(s)")
    first_two = solved_motions(interrupted(STOP_RANKS, INPUT))
    check(len(first_two) == 2, f"two solves reported before the stop: {first_two}")
    first_two = first_two[:2] if len(first_two) >= 2 else ["U_x", "U_y"]
    check(os.path.exists(CHECKPOINT) and not os.path.exists(CHECKPOINT + ".tmp"),
          "the checkpoint is there, no temporary file")
    if os.path.exists(CHECKPOINT):
        with h5py.File(CHECKPOINT, "r") as f:
            check(sorted(f.keys()) == sorted(first_two), f"the checkpoint holds {first_two}: {sorted(f.keys())}")
            check(text(f.attrs["format"]) == "beadmob-checkpoint", "checkpoint format")
            key = text(f.attrs["key"])
            check(text(f.attrs["key_digest"]) == fnv1a_64(key.encode()), "key_digest = FNV-1a 64 of the key")
            n_beads, nb = int(f.attrs["n_beads"]), int(f.attrs["unknowns_per_bead"])
            one, other = first_two
            if one in f and other in f:
                check(f[one].shape == (n_beads, nb), f"{one} is (beads, unknowns per bead): {f[one].shape}")
                check(np.isfinite(f[other][()]).all() and np.abs(f[other][()]).max() > 0, f"{other} holds a solution")

    print(f"--- 3. the same job rerun on {RESUME_RANKS} rank(s): resumes")
    status, output = run(RESUME_RANKS, INPUT)
    check(status == 0 and os.path.exists(OUTPUT), "the resumed run succeeds")
    check("resumed 2 motions from the checkpoint" in output, "stdout says 2 motions were resumed")
    check(f"solve {first_two[0]}: resumed from the checkpoint" in output, f"a progress line for the resumed {first_two[0]}")
    check(not os.path.exists(CHECKPOINT), "the checkpoint is removed once the result is written")
    if status == 0:
        friction, resumed = hydro(OUTPUT)
        expected = [int(name in first_two) for name in MOTION_NAMES]
        check(resumed == expected, f"resumed_motions = {resumed}, expected {expected}")
        ratio = (np.abs(friction - reference) / solver_allowance(OUTPUT, "reference.h5")).max()
        check(ratio <= 1, f"friction equals the uninterrupted run's within the solver bounds ({ratio:.2f} of them)")
        os.remove(OUTPUT)

    print("--- 4. interrupted again, then a changed input: no resume")
    interrupted(STOP_RANKS, INPUT)
    status, output = run(RESUME_RANKS, CHANGED)
    check(status == 0 and os.path.exists(OUTPUT), "the changed run succeeds")
    check("is of another job" in output, "a warning that the checkpoint is of another job")
    check(output.count("beadmob: warning: checkpoint") == 1, "exactly one checkpoint warning")
    check("resumed" not in output.replace("resumed_motions", ""), "nothing said resumed")
    check(not os.path.exists(CHECKPOINT), "the stale checkpoint is gone after the run")
    if status == 0:
        check(hydro(OUTPUT)[1] == [0] * 6, f"resumed_motions all 0: {hydro(OUTPUT)[1]}")
        os.remove(OUTPUT)

    print("--- 5. a damaged checkpoint: warning, ignored")
    with open(CHECKPOINT, "wb") as f:
        f.write(b"not an HDF5 file\n" * 100)
    status, output = run(RESUME_RANKS, INPUT, "-quiet")
    check(status == 0 and os.path.exists(OUTPUT), "the run with a damaged checkpoint succeeds")
    check("not readable as an HDF5 file; ignored" in output, "a warning names the damaged checkpoint")
    check("beadmob: progress:" not in output, "-quiet: no progress line")
    if status == 0:
        check(hydro(OUTPUT)[1] == [0] * 6, "nothing resumed from a damaged checkpoint")
        os.remove(OUTPUT)

    print("--- 6. checkpoint = .false.: nothing saved")
    with open(INPUT) as f:
        source = f.read()
    with open("no_checkpoint.nml", "w") as f:
        f.write(source.replace("&run output = 'resume_box.h5'", "&run output = 'resume_box.h5', checkpoint = .false."))
    interrupted(STOP_RANKS, "no_checkpoint.nml")
    check(not os.path.exists(CHECKPOINT), "no checkpoint with checkpoint = .false.")


if __name__ == "__main__":
    WORKDIR, INPUT, CHANGED = sys.argv[1], os.path.abspath(sys.argv[2]), os.path.abspath(sys.argv[3])
    STOP_RANKS, RESUME_RANKS = int(sys.argv[4]), int(sys.argv[5])
    MPIEXEC, NUMPROC_FLAG, BEADMOB = [sys.argv[6]], sys.argv[7], sys.argv[8]
    main()
    print(f"check_resume: {len(failures)} failed")
    sys.exit(1 if failures else 0)
