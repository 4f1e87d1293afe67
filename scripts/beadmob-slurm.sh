#!/usr/bin/env bash
# Writes a Slurm batch script for a beadmob job whose ranks, memory and time limit come from the
# dry run (docs/cluster.md):
#
#   scripts/beadmob-slurm.sh JOB.nml RANKS [OUT.slurm]    then   sbatch OUT.slurm
#
# The dry run (`beadmob --estimate JOB.nml -estimate_ranks RANKS`, run here on one rank: it builds
# only the bead model) gives the memory per rank and the expected wall time; the script asks for
# 25 % more memory per rank (--mem-per-cpu, one rank per CPU, at least 256 MiB) and twice the
# expected time (at least 15 minutes). A job killed at the time limit loses nothing: each solved motion is in the
# checkpoint (<output>.checkpoint.h5) and `sbatch OUT.slurm` again resumes from it.
# BEADMOB (default: build/beadmob next to this script) names the executable; ACCOUNT, PARTITION
# and MODULES (e.g. "petsc hdf5 fftw") are passed through when set.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
job=${1:?usage: beadmob-slurm.sh JOB.nml RANKS [OUT.slurm]}
ranks=${2:?usage: beadmob-slurm.sh JOB.nml RANKS [OUT.slurm]}
out=${3:-${job%.nml}.slurm}
exe=${BEADMOB:-$root/build/beadmob}
[ -f "$job" ] || { echo "beadmob-slurm: no input file $job" >&2; exit 1; }
[[ "$ranks" =~ ^[1-9][0-9]*$ ]] || { echo "beadmob-slurm: RANKS must be a positive integer, got $ranks" >&2; exit 1; }
[ -x "$exe" ] || { echo "beadmob-slurm: no beadmob executable at $exe (build it, or set BEADMOB)" >&2; exit 1; }
source "$root/scripts/mpi-env.sh"

estimate=$("$exe" --estimate "$job" -estimate_ranks "$ranks") || { echo "$estimate" >&2; exit 1; }
echo "$estimate"
gib=$(sed -nE 's/.*memory per rank: +([0-9.]+) GiB.*/\1/p' <<<"$estimate")
time_text=$(sed -nE 's/.*expected wall time: +([0-9.e+]+ (s|min|h)).*/\1/p' <<<"$estimate")
box=$(sed -nE 's/.*padded box ([0-9]+) x ([0-9]+) x ([0-9]+).*/\2/p' <<<"$estimate")
[ -n "$gib" ] && [ -n "$time_text" ] || { echo "beadmob-slurm: could not read the estimate" >&2; exit 1; }
read -r mem_mib minutes < <(python3 - "$gib" $time_text <<'PY'
import math, sys
gib, value, unit = float(sys.argv[1]), float(sys.argv[2]), sys.argv[3]
seconds = value * {"s": 1, "min": 60, "h": 3600}[unit]
print(max(256, math.ceil(1.25 * gib * 1024)), max(15, math.ceil(2 * seconds / 60)))
PY
)
if [ -n "$box" ] && [ "$ranks" -gt "$box" ]; then
  echo "beadmob-slurm: warning: $ranks ranks for an FFT box whose slabs have $box planes: ranks beyond $box hold no frequencies" >&2
fi
output=$(sed -nE "s/^[[:space:]]*&run.*output *= *'([^']+)'.*/\1/p" "$job" | head -1)
{
  echo "#!/bin/bash"
  echo "# Written by scripts/beadmob-slurm.sh from the dry run of $job on $ranks ranks:"
  sed 's/^/#   /' <<<"$estimate"
  echo "#SBATCH --job-name=beadmob-$(basename "${job%.nml}")"
  echo "#SBATCH --ntasks=$ranks"
  echo "#SBATCH --cpus-per-task=1"
  echo "#SBATCH --mem-per-cpu=${mem_mib}M"
  printf "#SBATCH --time=%02d:%02d:00\n" $((minutes / 60)) $((minutes % 60))
  [ -n "${ACCOUNT:-}" ] && echo "#SBATCH --account=$ACCOUNT"
  [ -n "${PARTITION:-}" ] && echo "#SBATCH --partition=$PARTITION"
  echo "set -euo pipefail"
  [ -n "${MODULES:-}" ] && echo "module load $MODULES"
  echo "cd $(cd "$(dirname "$job")" && pwd)"
  echo "# Rerunning this script after a time-limit kill resumes from ${output:-beadmob_result.h5}.checkpoint.h5."
  echo "srun $exe $(basename "$job")"
} > "$out"
echo "beadmob-slurm: wrote $out (--ntasks=$ranks, --mem-per-cpu=${mem_mib}M, --time=${minutes} min); submit with: sbatch $out"
