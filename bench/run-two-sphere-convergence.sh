#!/usr/bin/env bash
# Regenerate bench/two_sphere_convergence.md (needs a build: scripts/build.sh).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
"${BUILD_DIR:-$root/build}/bench/two_sphere_convergence" > "$root/bench/two_sphere_convergence.md"
echo "wrote bench/two_sphere_convergence.md"
