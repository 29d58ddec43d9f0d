#!/usr/bin/env bash
# Installs the Debian 12 packages hgraph needs to build, test and run, and only those missing:
# when everything is there it changes nothing and needs no privileges. Runs apt-get directly as
# root (a container or a fresh machine has no sudo) and through sudo otherwise.
# `install-deps.sh --build` installs only what building needs (the Dockerfile's build stage).
set -euo pipefail
export DEBIAN_FRONTEND=noninteractive
packages=(
  build-essential cmake ninja-build ccache pkg-config git
  libgrpc++-dev protobuf-compiler-grpc libprotobuf-dev protobuf-compiler
  libfcl-dev libccd-dev liboctomap-dev libeigen3-dev libassimp-dev
  libspdlog-dev libfmt-dev libtbb-dev libompl-dev libboost-all-dev
  libgtest-dev libgmock-dev libbenchmark-dev libcli11-dev nlohmann-json3-dev
  libcivetweb-dev libssl-dev zlib1g-dev
  # The shared store's Redis client (server/redis_store.cc: hiredis parses the replies).
  libhiredis-dev
  # google/rpc/status.proto and error_details.proto (the rich error details the server attaches;
  # proto/CMakeLists.txt compiles them): Debian ships googleapis' protos only in this package.
  golang-github-gogo-googleapis-dev
  python3 python3-grpcio python3-protobuf python3-grpc-tools python3-pytest python3-pip
  python3-setuptools python3-wheel
  clang libclang-rt-14-dev
)
# npm installs the pinned packages of core/render/view (three, which the 3D view inlines; the
# build runs `npm ci`) and buf (scripts/buf.sh). Debian's npm conflicts with a nodejs that
# bundles its own npm: only when absent.
command -v npm > /dev/null || packages+=(npm)
if [ "${1:-}" != "--build" ]; then
  # Tests: pictures (librsvg), nginx as the gRPC front (tests/deploy/affinity_test.py),
  # openssl for the certificates of tests/integration/test_security.py, chromium for the 3D
  # view's browser test (tests/view, headless, WebGL through SwiftShader).
  packages+=(librsvg2-bin nginx openssl chromium)
  # Redis 7 for the shared store's tests (tests/integration/store_test.py, tests/deploy).
  packages+=(redis-server redis-tools)
  # kubectl renders deploy/ (tests/deploy); Debian's kubernetes-client provides it, but an
  # image may already carry kubectl from another package (they conflict): only when absent.
  command -v kubectl > /dev/null || packages+=(kubernetes-client)
fi

missing=()
for p in "${packages[@]}"; do
  status=$(dpkg-query -W -f='${Status}' "$p" 2> /dev/null || true)
  [ "$status" = "install ok installed" ] || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: every package is installed"
  exit 0
fi
echo "install-deps: installing ${missing[*]}"
SUDO=()
if [ "$(id -u)" != "0" ]; then SUDO=(sudo); fi
"${SUDO[@]}" apt-get update -q
"${SUDO[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
