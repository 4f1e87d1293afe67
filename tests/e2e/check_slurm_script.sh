#!/usr/bin/env bash
# check_slurm_script.sh SCRIPT BEADMOB INPUT RANKS OUT: scripts/beadmob-slurm.sh writes OUT with
# --ntasks = RANKS, --mem-per-cpu = 1.25 x the dry run's memory per rank (MiB, rounded up, at least 256, read
# back from the estimate it quotes), a --time of at least 15 minutes and the srun line of the job.
set -u
script=$1 beadmob=$2 input=$3 ranks=$4 out=$5
rm -f "$out"
BEADMOB=$beadmob bash "$script" "$input" "$ranks" "$out" || { echo "FAIL: beadmob-slurm.sh failed"; exit 1; }
[ -f "$out" ] || { echo "FAIL: no $out"; exit 1; }
cat "$out"
gib=$(sed -nE 's/.*memory per rank: +([0-9.]+) GiB.*/\1/p' "$out")
expected=$(python3 -c "import math; print(max(256, math.ceil(1.25 * $gib * 1024)))")
for line in "#SBATCH --ntasks=$ranks" "#SBATCH --mem-per-cpu=${expected}M" "#SBATCH --time=00:15:00" \
            "srun $beadmob $(basename "$input")"; do
  grep -qxF -- "$line" "$out" || { echo "FAIL: no line '$line'"; exit 1; }
done
grep -q "estimate for $ranks rank(s)" "$out" || { echo "FAIL: the estimate is not for $ranks ranks"; exit 1; }
echo "PASS"
