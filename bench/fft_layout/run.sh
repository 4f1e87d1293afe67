#!/bin/bash
# The slow-axis layouts of the FFT operator's transforms (fft_layout.c) at the sizes the paper
# shapes use (2 ranks: n_slow, complex numbers per slow-axis site, middle lines per rank; L = 2 and
# the order-1 companion; the mirror-class transform, and the whole-box one of the random and
# jittered bodies), and at a few others; writes fft_layout.md next to this script. One process at a time;
# the machine otherwise idle. REPEATS (default 7) timings per case, alternated.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
repeats=${REPEATS:-7}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cc -O2 -o "$work/fft_layout" "$here/fft_layout.c" -lfftw3 -lm
# case name | n_slow pairs lines (from size_mirror_transform: n_slow the slow padded size, pairs
# (n_fast/2 + 1) fields / 2, lines (n_middle/2 + 1) / 2 on the larger rank)
cases=(
  "paper cone, L = 2|96 176 11"
  "paper cone, companion|96 66 11"
  "arrowhead, L = 2|45 104 16"
  "crescent moon, L = 2|48 80 29"
  "ring_1mm, L = 2|125 64 36"
  "ring_1mm, companion|125 24 36"
  "ring_2mm and ring_3mm, L = 2|120 64 41"
  "ring_4mm, L = 2|112 64 46"
  "1e6-bead sphere, L = 2|250 1008 63"
  "random 1000 beads (whole-box transform: pairs = (n_fast/2 + 1) fields), L = 2|40 224 16"
  "2000 jittered beads (whole box, the pfft grid), L = 2|40 336 20"
  "other sizes|140 64 32"
  "other sizes|100 64 16"
  "other sizes|128 64 32"
)
{
  echo "# The slow axis of the FFT operator's transforms: strided against contiguous lines"
  echo
  echo "Written by \`bench/fft_layout/run.sh\` (\`fft_layout.c\`, FFTW $(pkg-config --modversion fftw3 2>/dev/null || echo 3)): one process, medians of $repeats alternated timings per case, each the median of 5 passes over the lines. A pass transforms every slow-axis line of one rank's middle lines (\`pairs\` complex numbers per slow-axis site; in the mirror-class transform two real lines in each). *strided*: each line's numbers a row apart (the layout of the spectrum, which beadmob transformed in place before 3e95435); *contiguous*: each line contiguous, as in the per-line scratch of \`forward_line\` / \`backward_line\` since then. *estimate* and *measure* are FFTW's planners (beadmob's default is the estimate, reproducible to the last bit; the measured plans are used with a table cache). Times in ms per pass; the last column is FFTW_MEASURE's planning time for the strided case."
  echo
  echo "| case | n_slow | pairs | lines | strided, estimate | contiguous, estimate | strided, measure | contiguous, measure | strided estimate / contiguous estimate | planning (measure, s) |"
  echo "|---|---|---|---|---|---|---|---|---|---|"
  for c in "${cases[@]}"; do
    name=${c%%|*}
    read -r n p l <<<"${c#*|}"
    read -r _ _ _ se ce sm cm ps _ < <("$work/fft_layout" "$n" "$p" "$l" "$repeats")
    ratio=$(python3 -c "print(f'{$se / $ce:.2f}')")
    echo "| $name | $n | $p | $l | $se | $ce | $sm | $cm | $ratio | $ps |"
  done
  echo
  if [ -f "$here/reading.md" ]; then echo; cat "$here/reading.md"; fi
} > "$here/fft_layout.md"
cat "$here/fft_layout.md"
