#!/usr/bin/env bash
# The proto contract's CI checks. Usage: buf_check.sh lint | breaking TAG
#   lint:     buf lint on proto/ with buf.yaml's rules.
#   breaking: buf breaking against proto/ and buf.yaml as they were at git tag TAG.
# Exits 77 (skipped) when buf cannot be installed, or when TAG does not exist in this clone.
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
buf=(bash "$root/scripts/buf.sh")
case "${1:-}" in
  lint)
    "${buf[@]}" lint
    echo "buf lint: clean"
    ;;
  breaking)
    tag=$2
    if ! git -C "$root" rev-parse -q --verify "refs/tags/$tag" > /dev/null; then
      echo "SKIP: git tag $tag is not in this clone (git fetch --tags), nothing to compare with"
      exit 77
    fi
    "${buf[@]}" --version > /dev/null  # installs buf, or exits 77
    against=$(mktemp -d)
    trap 'rm -rf "$against"' EXIT
    git -C "$root" archive "$tag" proto buf.yaml | tar -x -C "$against"
    "${buf[@]}" breaking --against "$against"
    echo "buf breaking: proto/ is compatible with $tag"
    ;;
  *)
    echo "usage: $0 lint | breaking TAG" >&2
    exit 2
    ;;
esac
