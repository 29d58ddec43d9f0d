#include "client/cli/shortcut_step.h"

#include <chrono>
#include <cstdio>

#include "client/cli/cli_common.h"
#include "core/plan/baselines.h"

namespace hgraph::cli {

ShortcutStep ShortcutMergedPath(const MotionChecker& checker, const MergeResult& result,
                                const MeasureSpec& measure, double resolution, uint64_t seed) {
  const auto t0 = std::chrono::steady_clock::now();
  ShortcutStep step;
  step.path = ShortcutPath(checker, result.path, {.seed = seed, .resolution = resolution});
  step.path.name = "merged+shortcut";
  step.elapsed_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  // A merge of the one path evaluates it exactly as the merge evaluated its inputs.
  const MergeResult evaluated =
      Merge(checker, MergeRequest{.paths = {step.path}, .measure = measure});
  step.quality = evaluated.inputs.at(0).quality;
  return step;
}

void PrintShortcutRow(const ShortcutStep& step, const MergeResult& result) {
  const PathQuality& q = step.quality;
  std::printf("%-20.20s %9zu %5s %12s %10s %10s %14s\n", step.path.name.c_str(),
              step.path.waypoints.size(), "yes", Cell(q.length, 12).c_str(),
              Cell(q.min_clearance, 10).c_str(), Cell(q.avg_clearance, 10).c_str(),
              Cell(q.inverse_clearance, 14).c_str());
  std::printf("shortcut (OMPL PathSimplifier, %.1f ms): objective %s after the merge's %s\n",
              step.elapsed_ms, Cell(Objective(result.measure, q), 0).c_str(),
              Cell(result.objective, 0).c_str());
}

}  // namespace hgraph::cli
