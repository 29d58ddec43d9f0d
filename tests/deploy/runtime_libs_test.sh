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
libs=()
for binary in "$@"; do
  [ -x "$binary" ] || { fail "$binary is not built"; continue; }
  if ldd "$binary" | grep -q "not found"; then fail "$binary: $(ldd "$binary" | grep 'not found')"; fi
  mapfile -t -O "${#libs[@]}" libs < <(ldd "$binary" | awk '/=> \// {print $3}')
done
mapfile -t libs < <(printf '%s\n' "${libs[@]}" | sort -u)
# One dpkg -S for every path (it reads the whole package database each time). usrmerge: ldd
# may name /lib/... where dpkg knows /usr/lib/... or the resolved file, so ask for all three.
candidates=()
for lib in "${libs[@]}"; do candidates+=("$lib" "$(readlink -f "$lib")" "/usr$lib"); done
owners=$(dpkg -S "${candidates[@]}" 2> /dev/null || true)
needed=()
for lib in "${libs[@]}"; do
  owner=""
  for path in "$lib" "$(readlink -f "$lib")" "/usr$lib"; do
    owner=$(awk -v p="$path" -F': ' '$2 == p {print $1; exit}' <<< "$owners")
    [ -n "$owner" ] && break
  done
  if [ -z "$owner" ]; then
    fail "the binaries load $lib, which no Debian package provides"
    continue
  fi
  needed+=("${owner%%:*}")
done
mapfile -t needed < <(printf '%s\n' "${needed[@]}" | sort -u)
for package in "${needed[@]}"; do
  # Not `printf | grep -q`: grep's early exit may kill printf with SIGPIPE, which pipefail
  # reports as a missing package.
  grep -qxF -- "$package" <(printf '%s\n' "${listed[@]}") ||
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
