#!/usr/bin/env bash
# Sanitizer runs of the tests, each in its own build tree (clang, -O1, line tables), after the
# normal run in .ci/run:
#   asan  ASan + UBSan (halts on the first UBSan finding; LeakSanitizer on), build-asan/. The
#         tree also builds the libFuzzer targets (HGRAPH_FUZZ), so tests/fuzz/run.sh can then
#         fuzz in it without another build. Runs the unit, integration and fuzz-replay tests.
#   tsan  ThreadSanitizer, build-tsan/, with the std::thread backend of core/common/parallel.h
#         (Debian's libtbb is not instrumented). Runs the unit tests and the service tests.
# Suppressions: tests/sanitizers/*.supp (libraries we do not build only), compiled into every
# executable of these trees. Usage: scripts/sanitize.sh asan|tsan [BUILD_DIR] [ctest arguments]
# (extra ctest arguments replace the default selection, e.g. -R ParallelFor).
set -euo pipefail
mode=${1:?usage: sanitize.sh asan|tsan [BUILD_DIR] [ctest arguments...]}
root=$(cd "$(dirname "$0")/.." && pwd)
jobs=${HGRAPH_JOBS:-2}
case "$mode" in
  asan)
    build=${2:-$root/build-asan}
    config=(-DHGRAPH_SANITIZE=address,undefined -DHGRAPH_FUZZ=ON)
    # Everything but what needs the network or only checks files (lint, layering, deploy, docs,
    # contract) and the pip install of the Python package.
    select=(-L "unit|integration|fuzz" -LE "python")
    export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:halt_on_error=1:log_path=$build/sanitizer-reports/asan}
    ;;
  tsan)
    build=${2:-$root/build-tsan}
    config=(-DHGRAPH_SANITIZE=thread)
    # The unit tests (the engine's parallel loops, per-thread collision contexts), the service
    # tests and the load test's smoke run (real server: gRPC threads, worker pool, concurrent
    # merges, cancellation, disconnects, restart).
    select=(-L "unit|service|load")
    export TSAN_OPTIONS=${TSAN_OPTIONS:-halt_on_error=0:second_deadlock_stack=1:log_path=$build/sanitizer-reports/tsan}
    ;;
  *)
    echo "sanitize.sh: unknown mode '$mode' (asan or tsan)" >&2
    exit 2
    ;;
esac
# Three planner tests give OMPL a wall-clock budget that must suffice to find a path; a sanitizer's
# slowdown makes them fail on time alone (OMPL itself is not instrumented; the plan tests without
# such a budget, and cli.plan_* under ASan, still run our planning code).
select+=(-E "PlanTest\.(EveryPlannerFindsValidPathsWithExactEndpoints|SameSeedSamePathsForSingleThreadedPlanners|OptimizingPlannersSpendTheirTimeAndReportWhetherTheirPathIsCertified)")
shift $(($# >= 2 ? 2 : 1))
if [ $# -gt 0 ]; then select=("$@"); fi

started=$(date +%s)
generator=()
if [ ! -f "$build/CMakeCache.txt" ]; then generator=(-G Ninja); fi
mkdir -p "$build"
cmake -S "$root" -B "$build" "${generator[@]}" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -gline-tables-only -DNDEBUG" \
  -DHGRAPH_SKIP_MODULES=bench "${config[@]}" > "$build/hgraph-configure.log" ||
  { cat "$build/hgraph-configure.log"; exit 1; }
cmake --build "$build" -j"$jobs"
built=$(date +%s)
echo "== sanitize.sh $mode: built in $((built - started)) s"
# Reports go to files (log_path), one per process that had any: a test that captures a
# subprocess's stderr still fails on its exit status, and the report is kept here.
rm -rf "$build/sanitizer-reports"
mkdir -p "$build/sanitizer-reports"
status=0
ctest --test-dir "$build" --output-on-failure -j"$jobs" "${select[@]}" || status=$?
reports=$(find "$build/sanitizer-reports" -type f | wc -l)
echo "== sanitize.sh $mode: tests in $(($(date +%s) - built)) s, exit $status, $reports processes with sanitizer reports"
if [ "$reports" -gt 0 ]; then
  find "$build/sanitizer-reports" -type f | head -5 | xargs head -60
  status=1
fi
exit $status
