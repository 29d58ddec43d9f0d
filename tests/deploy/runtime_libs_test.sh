#!/usr/bin/env bash
# The Docker image's runtime libraries, checked without Docker: derives the Debian packages that
# the built binaries load (ldd, then dpkg -S on each library) and fails when one of them is not
# in scripts/runtime-packages.txt, the list the Dockerfile's runtime stage installs. Also checks
# the Dockerfile's shape: two stages, the list installed, a non-root user, the health check.
# Usage: runtime_libs_test.sh SOURCE_DIR BINARY...
set -euo pipefail
root=$1
shift
list="$root/scripts/runtime-packages.txt"
dockerfile="$root/Dockerfile"
status=0
fail() { echo "FAIL: $*"; status=1; }

mapfile -t listed < <(grep -v '^#' "$list" | grep -v '^$')
needed=()
for binary in "$@"; do
  [ -x "$binary" ] || { fail "$binary is not built"; continue; }
  if ldd "$binary" | grep -q "not found"; then fail "$binary: $(ldd "$binary" | grep 'not found')"; fi
  while read -r lib; do
    # usrmerge: ldd may name /lib/... where dpkg knows /usr/lib/... (or the reverse).
    owner=$(dpkg -S "$lib" 2> /dev/null || dpkg -S "$(readlink -f "$lib")" 2> /dev/null ||
            dpkg -S "/usr$lib" 2> /dev/null || true)
    if [ -z "$owner" ]; then
      fail "$binary loads $lib, which no Debian package provides"
      continue
    fi
    needed+=("${owner%%:*}")
  done < <(ldd "$binary" | awk '/=> \// {print $3}')
done
mapfile -t needed < <(printf '%s\n' "${needed[@]}" | sort -u)
for package in "${needed[@]}"; do
  printf '%s\n' "${listed[@]}" | grep -qx "$package" ||
    fail "$package is loaded by the binaries but missing from scripts/runtime-packages.txt"
done
echo "binaries need ${#needed[@]} packages: ${needed[*]}"

[ "$(grep -c '^FROM ' "$dockerfile")" -ge 2 ] || fail "Dockerfile is not multi-stage"
grep -q '^FROM debian:bookworm AS build' "$dockerfile" || fail "build stage is not debian:bookworm"
grep -q '^FROM debian:bookworm-slim' "$dockerfile" || fail "runtime stage is not bookworm-slim"
grep -q 'scripts/install-deps.sh' "$dockerfile" || fail "build stage skips scripts/install-deps.sh"
grep -q 'scripts/build.sh' "$dockerfile" || fail "build stage skips scripts/build.sh"
grep -q 'runtime-packages.txt' "$dockerfile" || fail "runtime stage does not install the list"
user=$(awk '$1 == "USER" {u = $2} END {print u}' "$dockerfile")
case "$user" in "" | root | 0 | 0:*) fail "the image runs as root (USER '$user')" ;; esac
grep -q '^HEALTHCHECK.*' "$dockerfile" && grep -q '"health", "--server"' "$dockerfile" ||
  fail "no HEALTHCHECK through hgraph health"
grep -q '^ENTRYPOINT \["hgraph-server"\]' "$dockerfile" || fail "entrypoint is not hgraph-server"
[ $status -eq 0 ] && echo "runtime package list and Dockerfile: ok"
exit $status
