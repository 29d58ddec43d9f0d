#!/usr/bin/env bash
# Builds the libFuzzer targets with Debian's clang (ASan + UBSan, its own build dir) and runs each
# for SECONDS seconds from a seed corpus made of tests/data and scenes/, plus the regression
# inputs of tests/fuzz/regressions/<target>/ (each is run first). A crasher is copied there,
# which ctest replays (fuzz_regressions.*) under any compiler. CI (.ci/run) runs it for 25 s a
# target in the tree of scripts/sanitize.sh asan (build-asan, which has the libFuzzer targets).
# Usage: tests/fuzz/run.sh SECONDS [BUILD_DIR]   (exit status 1 if any target found a crash)
set -euo pipefail
seconds=${1:?usage: run.sh SECONDS [BUILD_DIR]}
root=$(cd "$(dirname "$0")/../.." && pwd)
build=${2:-$root/build-fuzz}
targets="scene_fuzz mesh_fuzz ompl_files_fuzz merge_request_fuzz"

cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_COMPILER=clang++ -DHGRAPH_FUZZ=ON -DHGRAPH_SANITIZE=address,undefined \
  >/dev/null
cmake --build "$build" -j2 --target hgraph-mesh-import hgraph_python $(for t in $targets; do echo ${t}_libfuzzer; done)

corpus=$build/fuzz-corpus
rm -rf "$corpus"
/usr/bin/python3 "$root/tests/fuzz/make_seeds.py" "$corpus/seeds" "$build/python"
status=0
for t in $targets; do
  mkdir -p "$corpus/$t" "$build/fuzz-artifacts/$t"
  echo "== $t: $seconds s"
  # Findings stop a target's run; the others still run.
  if ! UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 ASAN_OPTIONS=detect_leaks=0 \
      "$build/tests/fuzz/${t}_libfuzzer" -max_total_time="$seconds" -timeout=20 -rss_limit_mb=4096 \
      -max_len=65536 -print_final_stats=1 -artifact_prefix="$build/fuzz-artifacts/$t/" \
      "$corpus/$t" "$corpus/seeds/$t" "$root/tests/fuzz/regressions/$t" \
      2>"$build/fuzz-artifacts/$t.log"; then
    status=1
    tail -40 "$build/fuzz-artifacts/$t.log"
    for crash in "$build/fuzz-artifacts/$t"/*; do
      [ -f "$crash" ] && cp "$crash" "$root/tests/fuzz/regressions/$t/"
    done
  fi
  grep -E "stat::number_of_executed_units|stat::peak_rss_mb" "$build/fuzz-artifacts/$t.log" || true
done
exit $status
