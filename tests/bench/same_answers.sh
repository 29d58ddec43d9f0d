#!/usr/bin/env bash
# Prints what the CLI's merge answers on the bench's 21 kept problems (7 scenes x the three
# seeds' committed inputs, one thread, defaults): per problem its collision checks, distance
# queries, edges checked and the merged path's length and a digest of its waypoints. A change meant to keep
# behaviour keeps this printout: run it before and after and diff the two.
# Usage: tests/bench/same_answers.sh [BUILD_DIR] > answers.txt
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
build=${1:-$root/build}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
scene_of() {
  case "$1" in
    wall_planar) echo "$root/tests/data/ompl_app/wall_planar.cfg" ;;
    hole_wall | two_slots) echo "$root/tests/bench/scenes/$1/scene.json" ;;
    *) echo "$root/scenes/$1/scene.json" ;;
  esac
}
for seed in 1 2 3; do
  for problem in grid maze circles wrench wall_planar hole_wall two_slots; do
    "$build/hgraph" merge -q --threads 1 --scene "$(scene_of "$problem")" \
      --paths "$root/tests/bench/results/seed$seed/inputs/$problem.json" --out "$out/r.json" > /dev/null
    python3 - "$out/r.json" "seed$seed/$problem" <<'PY'
import hashlib, json, sys
r = json.load(open(sys.argv[1]))
s = r.get("stats", {})
q = r.get("quality", {})
print(sys.argv[2], s.get("collision_checks", 0), s.get("distance_queries", 0),
      s.get("edges_checked", 0), repr(q.get("length")),
      hashlib.sha256(json.dumps(r.get("path", {}).get("waypoints", [])).encode()).hexdigest()[:12])
PY
  done
done
