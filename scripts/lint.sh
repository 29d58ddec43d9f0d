#!/usr/bin/env bash
# Formatting and static checks, as CI runs them.
#   scripts/lint.sh [--all] [--format-only] [BUILD_DIR]
# clang-format --dry-run -Werror on the C++ files changed against origin/main or main (or on
# every file but those in scripts/format-exempt.txt with --all), then clang-tidy (.clang-tidy) on a few translation units that together
# include most core headers, with BUILD_DIR/compile_commands.json (default: build). Exits non-zero
# on the first kind of finding.
set -euo pipefail
cd "$(dirname "$0")/.."
all=0
format_only=0
build=build
for arg in "$@"; do
  case "$arg" in
    --all) all=1 ;;
    --format-only) format_only=1 ;;
    *) build="$arg" ;;
  esac
done

cpp_files() {
  git ls-files -- '*.cc' '*.h'
}
if [[ $all == 1 ]]; then
  mapfile -t files < <(cpp_files | grep -vxF -f <(grep -v '^#' scripts/format-exempt.txt))
else
  base=$(git rev-parse --verify -q origin/main || git rev-parse --verify -q main || true)
  if [[ -n $base ]]; then
    mapfile -t files < <(git diff --name-only --diff-filter=d "$(git merge-base "$base" HEAD)" \
                           -- '*.cc' '*.h'; git ls-files --others --exclude-standard -- '*.cc' '*.h')
  else
    mapfile -t files < <(cpp_files)
  fi
fi

start=$(date +%s.%N)
if [[ ${#files[@]} -gt 0 ]]; then
  clang-format --dry-run -Werror "${files[@]}"
fi
echo "clang-format: ${#files[@]} files clean"
if [[ $format_only == 1 ]]; then exit 0; fi

if [[ ! -f $build/compile_commands.json ]]; then
  echo "lint.sh: $build/compile_commands.json missing (configure with cmake first)" >&2
  exit 2
fi
tidy_files=(core/motion/local_planner.cc core/merge/path_check.cc core/render/svg_render.cc
            client/cli/plan_command.cc)
clang-tidy --quiet -p "$build" "${tidy_files[@]}" 2>/dev/null
echo "clang-tidy: ${#tidy_files[@]} files clean"
printf 'lint took %.1f s\n' "$(echo "$(date +%s.%N) - $start" | bc)"
