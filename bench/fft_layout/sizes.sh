#!/bin/bash
# FFTW's slow-axis lines at every padded size beadmob can choose (fft_sizes.c): the sizes with
# prime factors 2, 3, 5, 7 from 16 to 300, 64 complex lines per pass (a ring's middle line),
# planned as beadmob plans them (FFTW_ESTIMATE, contiguous lines at the scratch's odd leading
# dimension); writes fft_sizes.md next to this script. One process, the machine otherwise idle;
# REPEATS (default 7) alternated timings per size.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
repeats=${REPEATS:-7}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cc -O2 -o "$work/fft_sizes" "$here/fft_sizes.c" -lfftw3 -lm
sizes=$(python3 -c "
def smooth(n):
    for p in (2, 3, 5, 7):
        while n % p == 0: n //= p
    return n == 1
print(' '.join(str(n) for n in range(16, 301) if smooth(n)))")
"$work/fft_sizes" 64 20 "$repeats" $sizes > "$work/times.txt"
python3 - "$work/times.txt" "$repeats" > "$here/fft_sizes.md" <<'PY'
import sys
rows = [line.split() for line in open(sys.argv[1])]
times = {int(n): (float(us), float(ns)) for n, us, ns in rows}
def factors(n):
    out = []
    for p in (2, 3, 5, 7):
        k = 0
        while n % p == 0:
            n //= p
            k += 1
        if k: out.append(f"{p}^{k}" if k > 1 else str(p))
    return " ".join(out)
def power_at_least(n):
    p = 1
    while p < n: p *= 2
    return p
print("# FFTW's slow-axis lines at each padded size")
print()
print(f"Written by `bench/fft_layout/sizes.sh` (`fft_sizes.c`): one process, FFTW_ESTIMATE plans (beadmob's default), 64 contiguous complex lines per pass at the scratch's odd leading dimension (as `forward_line` / `backward_line` transform them), medians of {sys.argv[2]} alternated timings, each the median of 5 batches of 20 passes. Per size: microseconds per line, nanoseconds per point, and the next power of two's time per line over this size's (below 1: the power of two, though longer, is transformed faster).")
print()
print("| n | factors | us per line | ns per point | next power of two | its us per line / this |")
print("|---|---|---|---|---|---|")
for n in sorted(times):
    us, ns = times[n]
    p = power_at_least(n)
    ratio = f"{times[p][0] / us:.2f}" if p in times and p != n else ""
    print(f"| {n} | {factors(n)} | {us:.3f} | {ns:.3f} | {p if p != n else ''} | {ratio} |")
PY
if [ -f "$here/sizes_reading.md" ]; then { echo; cat "$here/sizes_reading.md"; } >> "$here/fft_sizes.md"; fi
cat "$here/fft_sizes.md"
