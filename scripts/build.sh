#!/usr/bin/env bash
# Configures and builds hgraph (RelWithDebInfo, warnings as errors) into BUILD_DIR (default:
# build). Usage: scripts/build.sh [BUILD_DIR] [extra cmake arguments...]. HGRAPH_JOBS sets the
# parallel jobs (default 2); HGRAPH_TARGETS builds only those targets (the Dockerfile: the
# binaries it ships). Used by demo.sh, test.sh,
# .ci/run and the Dockerfile's build stage.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build}
shift || true
generator=()
if [ ! -f "$build/CMakeCache.txt" ] && command -v ninja > /dev/null; then generator=(-G Ninja); fi
cmake -S "$root" -B "$build" "${generator[@]}" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DHGRAPH_WERROR=ON "$@"
if [ -z "${HGRAPH_TARGETS:-}" ]; then
  cmake --build "$build" -j"${HGRAPH_JOBS:-2}"
  exit 0
fi
targets=()
for t in $HGRAPH_TARGETS; do targets+=(--target "$t"); done
cmake --build "$build" -j"${HGRAPH_JOBS:-2}" "${targets[@]}"
