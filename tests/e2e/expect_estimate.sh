#!/usr/bin/env bash
# expect_estimate.sh RESULT_FILE COMMAND...: the dry run (COMMAND) exits 0, prints each part of the
# estimate, and writes no result file. The bead count and the FFT box are checked against values
# computed here independently: the lattice points with |r| <= 5 (python, below) and 2 span + 1 = 21
# sites per axis (21 = 3 x 7 needs no padding); the sphere is its own mirror image, so its
# products run by mirror class (docs/theory.md T4), which pads two axes to an even size: 24 = 2^3 x 3
# (22 = 2 x 11 is not a 2-3-5-7 size).
set -u
result=$1; shift
rm -f "$result" "$result.partial"
output=$("$@" 2>&1); status=$?
echo "$output"
[ "$status" -eq 0 ] || { echo "FAIL: exit status $status"; exit 1; }
beads=$(python3 -c "print(sum(1 for x in range(-5, 6) for y in range(-5, 6) for z in range(-5, 6) if x*x + y*y + z*z <= 25))")
for pattern in "estimate for [0-9]+ rank" "beads: +$beads \([0-9]+ in the solve\)" "unknowns: +[0-9]+ \(16 per bead\)" \
               "padded box 24 x 24 x 21" "memory per rank: +[0-9.]+ GiB \(base .*FFT kernel .*vectors" \
               "expected wall time: .*solve\(s\) of"; do
  grep -Eq -- "$pattern" <<<"$output" || { echo "FAIL: no line matches: $pattern"; exit 1; }
done
if [ -e "$result" ] || [ -e "$result.partial" ]; then echo "FAIL: the dry run wrote $result"; exit 1; fi
echo "PASS"
