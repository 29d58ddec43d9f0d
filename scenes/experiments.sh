#!/usr/bin/env bash
# Reproduces the figures of scenes/README.md with the CLI:
#   grid:   three PRM inputs (1 s each) merged for length (neighborhood variant), 10 seeds:
#           mean over seeds of merged length / mean input length (paper: 0.28; target <= 0.35);
#   wrench, double_wrench: three PRM inputs merged for inverse clearance k = 3: the merged
#           path's minimum clearance against every input's.
# Usage: scenes/experiments.sh [path/to/hgraph] (default build/hgraph). Writes into $OUT
# (default a fresh temporary folder).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
hgraph=${1:-$here/../build/hgraph}
out=${OUT:-$(mktemp -d)}
seeds=${SEEDS:-10}
echo "writing into $out"

summary() {  # merge-result.json -> "merged_len mean_input_len merged_min_clear inputs_min_clear..."
  /usr/bin/python3 - "$1" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
ins = [i["quality"] for i in r["inputs"] if i["valid"]]
mean = sum(q["length"] for q in ins) / len(ins)
print(r["quality"]["length"], mean, r["quality"]["min_clearance"],
      " ".join(str(q["min_clearance"]) for q in ins))
PY
}

echo "== grid: length ratio over $seeds seeds"
ratios=()
for seed in $(seq 1 "$seeds"); do
  "$hgraph" plan --scene "$here/grid/scene.json" --planner prm --count 3 --time 1 --seed "$seed" \
    --out "$out/grid-$seed.json" > /dev/null || { echo "seed $seed: PRM missed a path"; continue; }
  "$hgraph" merge -q --scene "$here/grid/scene.json" --paths "$out/grid-$seed.json" \
    --variant neighborhood --measure length --out "$out/grid-$seed-merge.json" > /dev/null
  read -r merged mean _ <<< "$(summary "$out/grid-$seed-merge.json")"
  ratio=$(/usr/bin/python3 -c "print($merged / $mean)")
  ratios+=("$ratio")
  printf "seed %2d  merged %7.3f  mean input %7.3f  ratio %.3f\n" "$seed" "$merged" "$mean" "$ratio"
done
/usr/bin/python3 -c "import sys; r=[float(x) for x in sys.argv[1:]]; print('grid: mean ratio %.3f over %d seeds' % (sum(r)/len(r), len(r)))" "${ratios[@]}"

for scene in wrench double_wrench; do
  echo "== $scene: minimum clearance, inverse clearance k = 3"
  for seed in 1 2 3; do
    "$hgraph" plan --scene "$here/$scene/scene.json" --planner prm --count 3 --time 10 \
      --seed "$seed" --out "$out/$scene-$seed.json" > /dev/null || { echo "seed $seed: PRM missed a path"; continue; }
    "$hgraph" merge -q --scene "$here/$scene/scene.json" --paths "$out/$scene-$seed.json" \
      --variant neighborhood --measure inverse-clearance --k 3 \
      --out "$out/$scene-$seed-merge.json" > /dev/null
    read -r _ _ merged_clear inputs_clear <<< "$(summary "$out/$scene-$seed-merge.json")"
    verdict=$(/usr/bin/python3 -c "import sys; m=float(sys.argv[1]); i=[float(x) for x in sys.argv[2:]]; print('above every input' if all(m > x for x in i) else 'NOT above every input')" $merged_clear $inputs_clear)
    echo "seed $seed  merged min clearance $merged_clear  inputs $inputs_clear  -> $verdict"
  done
done
