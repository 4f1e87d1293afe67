#!/usr/bin/env bash
# Regenerate bench/two_sphere_convergence/two_sphere_convergence.md (needs a build: scripts/build.sh); its wall time is
# appended to the table.
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
out="$root/bench/two_sphere_convergence/two_sphere_convergence.md"
start=$(date +%s%N)
"${BUILD_DIR:-$root/build}/bench/two_sphere_convergence" > "$out"
ms=$(( ($(date +%s%N) - start) / 1000000 ))
printf 'Wall time of the whole table (4 distances, L = 1 ... 16 and the L = 30 references, one process): %d.%03d s\n' \
  $((ms / 1000)) $((ms % 1000)) >> "$out"
echo "wrote bench/two_sphere_convergence/two_sphere_convergence.md ($((ms / 1000)).$((ms % 1000)) s)"
