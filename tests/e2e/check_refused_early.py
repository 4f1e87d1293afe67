#!/usr/bin/env python3
"""check_refused_early.py BEADMOB MPIEXEC RANKS WORKDIR CASE: a run whose output cannot be
written is refused before anything is built.

CASE names where the result file would go:
  missing_dir   WORKDIR/no_such_directory/out.h5
  read_only     a directory without write permission (as root, which may write anywhere its
                permissions forbid, /sys: the kernel refuses new files there to everyone)
  checkpoint    a writable directory where a directory takes the checkpoint's name

Passes when the run exits non-zero; prints one error line naming the path and the reason; has
reached no phase of the friction job (progress lines are on); prints no HDF5 error stack; leaves
no result file, '.partial' or checkpoint; and beadmob's own lines number at most three (lines of
mpiexec's exit report not counted).
"""
import os
import re
import shutil
import stat
import subprocess
import sys

beadmob, mpiexec, ranks, workdir, case = sys.argv[1:6]
shutil.rmtree(workdir, ignore_errors=True)
os.makedirs(workdir)

if case == "missing_dir":
    output = os.path.join(workdir, "no_such_directory", "out.h5")
    expected = r"cannot write the result file '.*no_such_directory/out\.h5': .*No such file or directory"
elif case == "read_only":
    locked = os.path.join(workdir, "locked")
    os.makedirs(locked)
    os.chmod(locked, stat.S_IRUSR | stat.S_IXUSR)
    try:  # root ignores the permission bits: take a directory that refuses even root
        open(os.path.join(locked, "probe"), "w").close()
        os.remove(os.path.join(locked, "probe"))
        locked = "/sys"
    except OSError:
        pass
    output = os.path.join(locked, "out.h5")
    expected = r"cannot write the result file '.*out\.h5': .*(Permission denied|Read-only file system)"
elif case == "checkpoint":
    output = os.path.join(workdir, "out.h5")
    os.makedirs(output + ".checkpoint.h5")
    expected = r"cannot write the checkpoint '.*out\.h5\.checkpoint\.h5' .*Is a directory"
else:
    sys.exit(f"unknown case {case}")

input_path = os.path.join(workdir, "job.nml")
with open(input_path, "w") as f:
    f.write(f"&run output = '{output}' /\n&shape name = 'sphere', radius = 4 /\n&hydrodynamics /\n")

run = subprocess.run([mpiexec, "-n", ranks, beadmob, input_path], capture_output=True, text=True, timeout=300)
text = run.stdout + run.stderr
print(text)
# mpiexec's own report of a non-zero exit: framed by lines of dashes.
own_lines, inside_report = [], False
for line in text.splitlines():
    if re.fullmatch(r"-{20,}", line.strip()):
        inside_report = not inside_report
    elif not inside_report and line.strip():
        own_lines.append(line)

failures = []
if run.returncode == 0:
    failures.append("exit status 0, expected a refusal")
if not re.search(r"beadmob: error: " + expected, text):
    failures.append(f"no error line matching: {expected}")
if "progress: phase" in text:
    failures.append("the run reached a phase of the friction job before refusing")
if "HDF5-DIAG" in text:
    failures.append("HDF5's error stack was printed")
if len(own_lines) > 3:
    failures.append(f"{len(own_lines)} lines printed, at most 3 expected")
for leftover in (output, output + ".partial"):
    if os.path.isfile(leftover):
        failures.append(f"left a file: {leftover}")
if case != "checkpoint" and os.path.exists(output + ".checkpoint.h5"):
    failures.append("left a checkpoint")
for failure in failures:
    print("FAIL:", failure)
print("PASS" if not failures else f"{len(failures)} failures")
sys.exit(1 if failures else 0)
