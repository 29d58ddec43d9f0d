#!/usr/bin/env bash
# The test suite from scratch: installs the missing Debian packages (scripts/install-deps.sh),
# builds into BUILD_DIR (default: build) and runs every test with ctest. Usage:
# scripts/test.sh [BUILD_DIR] [ctest arguments...], e.g. scripts/test.sh build -L service.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build}
shift || true
bash "$root/scripts/install-deps.sh"
bash "$root/scripts/build.sh" "$build"
ctest --test-dir "$build" --output-on-failure -j"${HGRAPH_JOBS:-2}" "$@"
