#!/usr/bin/env bash
# Installs every Debian package hgraph needs to build, test and run. Run as root.
set -euo pipefail
export DEBIAN_FRONTEND=noninteractive
SUDO=""
if [ "$(id -u)" != "0" ]; then SUDO="sudo"; fi
$SUDO apt-get update -q
$SUDO apt-get install -y -q --no-install-recommends \
  build-essential cmake ninja-build ccache pkg-config git \
  libgrpc++-dev protobuf-compiler-grpc libprotobuf-dev protobuf-compiler \
  libfcl-dev libccd-dev liboctomap-dev libeigen3-dev libassimp-dev \
  libspdlog-dev libfmt-dev libtbb-dev libompl-dev libboost-all-dev \
  libgtest-dev libgmock-dev libbenchmark-dev libcli11-dev nlohmann-json3-dev \
  libcivetweb-dev libssl-dev zlib1g-dev \
  python3 python3-grpcio python3-protobuf python3-grpc-tools python3-pytest \
  librsvg2-bin \
  clang libclang-rt-14-dev
