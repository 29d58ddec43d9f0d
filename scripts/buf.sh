#!/usr/bin/env bash
# Runs buf (the protobuf linter and breaking-change checker) on proto/, installing it from npm
# (@bufbuild/buf) into BUF_PREFIX (default: build/tools) on first use. Usage:
#   scripts/buf.sh lint
#   scripts/buf.sh breaking --against tests/contract/v0.1.0.txtpb
# Exits 77 (ctest's skip code here) when npm is absent or the install fails.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
prefix=${BUF_PREFIX:-$root/build/tools}
buf="$prefix/node_modules/.bin/buf"
if [ ! -x "$buf" ]; then
  if ! command -v npm > /dev/null; then
    echo "SKIP: npm is not installed (scripts/install-deps.sh installs it); cannot install buf"
    exit 77
  fi
  mkdir -p "$prefix"
  if ! npm install --silent --no-audit --no-fund --prefix "$prefix" @bufbuild/buf@1 >&2; then
    echo "SKIP: npm install @bufbuild/buf failed (no registry access?)"
    exit 77
  fi
fi
cd "$root"
exec "$buf" "$@"
