#!/usr/bin/env bash
# The proto contract's CI checks. Usage:
#   buf_check.sh lint                     buf lint on proto/ with buf.yaml's rules.
#   buf_check.sh breaking IMAGE           buf breaking of proto/ against the buf image IMAGE (the
#                                         committed baseline of a release, e.g. v0.1.0.txtpb).
#   buf_check.sh baseline COMMIT IMAGE    writes IMAGE: proto/ and buf.yaml as they were at git
#                                         COMMIT, built by buf into a text image (no comments).
# The baseline is a file in the repository, not a git tag, so a fresh clone without tags runs the
# breaking check too. Exits 77 (skipped) when buf cannot be installed.
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
buf=(bash "$root/scripts/buf.sh")
case "${1:-}" in
  lint)
    "${buf[@]}" lint
    echo "buf lint: clean"
    ;;
  breaking)
    image=${2:?usage: $0 breaking IMAGE}
    if [ ! -f "$image" ]; then
      echo "buf_check.sh: baseline image $image does not exist" >&2
      exit 2
    fi
    image=$(cd "$(dirname "$image")" && pwd)/$(basename "$image")  # buf.sh runs from the root
    "${buf[@]}" breaking --against "$image"
    echo "buf breaking: proto/ is compatible with $(basename "$image")"
    ;;
  baseline)
    commit=${2:?usage: $0 baseline COMMIT IMAGE}
    image=${3:?usage: $0 baseline COMMIT IMAGE}
    image=$(cd "$(dirname "$image")" && pwd)/$(basename "$image")
    "${buf[@]}" --version > /dev/null  # installs buf, or exits 77
    tree=$(mktemp -d)
    trap 'rm -rf "$tree"' EXIT
    git -C "$root" archive "$commit" proto buf.yaml | tar -x -C "$tree"
    # Without source info the image holds only what buf breaking compares (names, numbers, types,
    # JSON names), and the text format keeps a later diff of the baseline readable.
    "${buf[@]}" build "$tree" --exclude-source-info -o "$image#format=txtpb"
    echo "buf_check.sh: wrote $image from proto/ at $(git -C "$root" rev-parse --short "$commit")"
    ;;
  *)
    echo "usage: $0 lint | breaking IMAGE | baseline COMMIT IMAGE" >&2
    exit 2
    ;;
esac
