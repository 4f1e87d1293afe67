#!/usr/bin/env bash
# Table cache gain (docs/input.md, "Table cache"): the paper's cone (shapes/cone.nml, L = 2, 5088 beads) on 2
# ranks, a run that fills an empty cache against a run that reads it, REPEATS times each (default
# 3); prints the 'blocks' phase (block table + FFT kernel set-up), the whole friction job, the
# process wall time and the CPU time (user + system, both ranks) of every run and their medians:
# on a shared machine the CPU time is the steadier measure. Extra beadmob options go after the script
# name (e.g. -fft_planner estimate). Needs a Release build (BUILD_DIR, default ./build).
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
source "$root/scripts/mpi-env.sh"
exe=${BUILD_DIR:-$root/build}/beadmob
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
for i in $(seq "${REPEATS:-3}"); do
  rm -f cache.h5
  for kind in fill read; do
    start=$(date +%s.%N)
    BEADMOB_CACHE=$work/cache.h5 /usr/bin/time -f "%U %S" -o cpu.txt mpirun -n 2 "$exe" "$root/shapes/cone.nml" "$@" \
      > run.log 2>&1
    end=$(date +%s.%N)
    python3 - "$kind" "$start" "$end" >> times.txt <<'PY'
import sys, h5py
kind, start, end = sys.argv[1], float(sys.argv[2]), float(sys.argv[3])
cpu = sum(float(x) for x in open("cpu.txt").read().split()[-2:])
with h5py.File("cone.h5", "r") as f:
    a = f["hydrodynamics"].attrs
    names = a["phase_names"].decode().split()
    seconds = dict(zip(names, a["phase_seconds"]))
    print(kind, seconds["blocks"], seconds["total"], end - start, cpu, a["cached_blocks"], a["computed_blocks"])
PY
  done
done
python3 - <<'PY'
import statistics
rows = [line.split() for line in open("times.txt")]
print("run   blocks (s)  friction job (s)  process (s)  CPU (s)  blocks read  computed")
for r in rows:
    print(f"{r[0]:5} {float(r[1]):10.2f} {float(r[2]):17.2f} {float(r[3]):12.2f} {float(r[4]):8.2f} {r[5]:>12} {r[6]:>9}")
for kind in ("fill", "read"):
    sel = [r for r in rows if r[0] == kind]
    med = [statistics.median(float(r[k]) for r in sel) for k in (1, 2, 3, 4)]
    print(f"median {kind}: blocks {med[0]:.2f} s, friction job {med[1]:.2f} s, process {med[2]:.2f} s, CPU {med[3]:.2f} s")
PY
