#!/usr/bin/env bash
# The demo: starts hgraph-server on a loopback port, plans three input paths with the paper's PRM
# on the built-in grid scene through it, merges them for length (all-pairs on a subdivided
# H-Graph; every path profiled so that the legend has its clearance) and writes a picture (SVG)
# and the interactive 3D view (view.html, one file that opens in a browser) beside it.
# Usage: scripts/demo.sh [BUILD_DIR] [OUT_DIR] (defaults: build, a fresh temporary folder). From
# a fresh clone it first installs the missing Debian packages and builds the server and the CLI.
# Exits non-zero if any step fails.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build}
if [ ! -x "$build/hgraph-server" ] || [ ! -x "$build/hgraph" ]; then
  bash "$root/scripts/install-deps.sh"
  bash "$root/scripts/build.sh" "$build"
fi
build=$(cd "$build" && pwd)
out=${2:-$(mktemp -d)}
mkdir -p "$out"
scene="$root/scenes/grid/scene.json"

"$build/hgraph-server" --listen 127.0.0.1:0 --metrics-listen "" --drain-s 0 \
  > "$out/server.out" 2> "$out/server.log" &
server=$!
trap 'kill -TERM $server 2>/dev/null || true; wait $server 2>/dev/null || true' EXIT
for _ in $(seq 100); do
  grep -q "grpc_port=" "$out/server.out" 2>/dev/null && break
  sleep 0.1
done
port=$(sed -n 's/.*grpc_port=\([0-9]*\).*/\1/p' "$out/server.out")
[ -n "$port" ] || { echo "hgraph-server did not start:"; cat "$out/server.log"; exit 1; }
echo "hgraph-server listening on 127.0.0.1:$port (log: $out/server.log)"

"$build/hgraph" plan --server "127.0.0.1:$port" --scene "$scene" --planner prm --count 3 \
  --time 30 --seed 1 --out "$out/inputs.json"
"$build/hgraph" merge --server "127.0.0.1:$port" --scene "$scene" --paths "$out/inputs.json" \
  --variant all-pairs --max-node-spacing 0.5 --measure length --report-inputs --report-clearance \
  --out "$out/result.json" --out-path "$out/merged.json" --svg "$out/grid.svg"
"$build/hgraph" check --server "127.0.0.1:$port" --scene "$scene" --paths "$out/merged.json"
"$build/hgraph" view --scene "$scene" --paths "$out/inputs.json" --result "$out/result.json" \
  --out "$out/view.html"
echo "picture: $out/grid.svg (rsvg-convert $out/grid.svg -o grid.png)"
echo "3D view: $out/view.html (open it in a browser)"
