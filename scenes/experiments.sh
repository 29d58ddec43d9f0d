#!/usr/bin/env bash
# Reproduces the figures of scenes/README.md with the CLI:
#   grid:   three PRM inputs (1 s each) merged for length, 10 seeds: mean over seeds of merged
#           length / mean input length (paper: 0.28; target <= 0.35), for the paper's
#           neighborhood variant and for all-pairs on a subdivided H-Graph;
#   wrench, double_wrench: three PRM inputs merged for inverse clearance k = 3: the merged
#           path's minimum clearance against every input's, for the same two variants.
# Usage: scenes/experiments.sh [path/to/hgraph] (default build/hgraph). Writes into $OUT
# (default a fresh temporary folder).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
hgraph=${1:-$here/../build/hgraph}
out=${OUT:-$(mktemp -d)}
mkdir -p "$out"
seeds=${SEEDS:-10}
# PRM's budget per input path, seconds (the paper: 1 s on grid). PRM stops at its first
# solution, so a larger budget only saves seeds that a loaded machine would lose.
grid_time=${GRID_TIME:-1}
wrench_time=${WRENCH_TIME:-10}
echo "writing into $out"

summary() {  # merge-result.json -> "merged_len mean_input_len merged_min_clear inputs_min_clear..."
  /usr/bin/python3 - "$1" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
ins = [i["quality"] for i in r["inputs"] if i["valid"]]
mean = sum(q["length"] for q in ins) / len(ins)
# Clearances are absent where unknown (PathQuality.has_clearance false): printed as "-".
print(r["quality"]["length"], mean, r["quality"].get("min_clearance", "-"),
      " ".join(str(q.get("min_clearance", "-")) for q in ins))
PY
}

echo "== grid: length ratio over $seeds seeds (neighborhood = the paper's variant; all-pairs on the"
echo "   H-Graph subdivided to nodes at most 0.5 apart)"
ratios_nb=()
ratios_ap=()
for seed in $(seq 1 "$seeds"); do
  "$hgraph" plan --scene "$here/grid/scene.json" --planner prm --count 3 --time "$grid_time" --seed "$seed" \
    --out "$out/grid-$seed.json" > /dev/null || { echo "seed $seed: PRM missed a path"; continue; }
  "$hgraph" merge -q --scene "$here/grid/scene.json" --paths "$out/grid-$seed.json" \
    --variant neighborhood --measure length --out "$out/grid-$seed-nb.json" > /dev/null
  "$hgraph" merge -q --scene "$here/grid/scene.json" --paths "$out/grid-$seed.json" \
    --variant all-pairs --max-node-spacing 0.5 --measure length --out "$out/grid-$seed-ap.json" > /dev/null
  read -r merged_nb mean _ <<< "$(summary "$out/grid-$seed-nb.json")"
  read -r merged_ap _ _ <<< "$(summary "$out/grid-$seed-ap.json")"
  ratio_nb=$(/usr/bin/python3 -c "print($merged_nb / $mean)")
  ratio_ap=$(/usr/bin/python3 -c "print($merged_ap / $mean)")
  ratios_nb+=("$ratio_nb")
  ratios_ap+=("$ratio_ap")
  printf "seed %2d  mean input %7.3f  neighborhood %7.3f (ratio %.3f)  all-pairs+subdivision %7.3f (ratio %.3f)\n" \
    "$seed" "$mean" "$merged_nb" "$ratio_nb" "$merged_ap" "$ratio_ap"
done
mean_of() { /usr/bin/python3 -c "import sys; r=[float(x) for x in sys.argv[1:]]; print('%.3f over %d seeds' % (sum(r)/len(r), len(r)))" "$@"; }
echo "grid: mean ratio, neighborhood $(mean_of "${ratios_nb[@]}")"
echo "grid: mean ratio, all-pairs + subdivision $(mean_of "${ratios_ap[@]}")"

verdict() {  # merged_clear inputs_clear...
  /usr/bin/python3 -c "import sys; m=float(sys.argv[1]); i=[float(x) for x in sys.argv[2:]]; print('above every input' if all(m > x for x in i) else 'NOT above every input')" "$@"
}

for scene in wrench double_wrench; do
  echo "== $scene: minimum clearance, inverse clearance k = 3 (neighborhood; all-pairs on the"
  echo "   H-Graph subdivided to nodes at most 1 apart)"
  for seed in 1 2 3; do
    "$hgraph" plan --scene "$here/$scene/scene.json" --planner prm --count 3 --time "$wrench_time" \
      --seed "$seed" --out "$out/$scene-$seed.json" > /dev/null || { echo "seed $seed: PRM missed a path"; continue; }
    "$hgraph" merge -q --scene "$here/$scene/scene.json" --paths "$out/$scene-$seed.json" \
      --variant neighborhood --measure inverse-clearance --k 3 \
      --out "$out/$scene-$seed-nb.json" > /dev/null
    "$hgraph" merge -q --scene "$here/$scene/scene.json" --paths "$out/$scene-$seed.json" \
      --variant all-pairs --max-node-spacing 1 --measure inverse-clearance --k 3 \
      --out "$out/$scene-$seed-ap.json" > /dev/null
    read -r _ _ clear_nb inputs_clear <<< "$(summary "$out/$scene-$seed-nb.json")"
    read -r _ _ clear_ap inputs_clear_ap <<< "$(summary "$out/$scene-$seed-ap.json")"
    # Each run samples the inputs' clearance at its own points (subdivision moves them): judge
    # against the larger of the two readings of every input.
    inputs_max=$(/usr/bin/python3 -c "import sys; n=len(sys.argv)//2; a=sys.argv[1:n+1]; b=sys.argv[n+1:]; print(' '.join(str(max(float(x), float(y))) for x, y in zip(a, b)))" $inputs_clear $inputs_clear_ap)
    echo "seed $seed  inputs $inputs_max"
    echo "        neighborhood $clear_nb -> $(verdict $clear_nb $inputs_max)"
    echo "        all-pairs+subdivision $clear_ap -> $(verdict $clear_ap $inputs_max)"
  done
done
