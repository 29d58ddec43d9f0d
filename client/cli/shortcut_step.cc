#include "client/cli/shortcut_step.h"

#include <chrono>
#include <cstdio>

#include "client/cli/cli_common.h"
#include "core/merge/path_check.h"
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
  // Evaluated exactly as the merge evaluated its inputs.
  const PathCheckResult evaluated =
      CheckPaths(checker, PathCheckRequest{.paths = {step.path}, .k = measure.k});
  const InputReport& report = evaluated.paths.at(0);
  if (!report.valid) {
    throw Error(ErrorCode::kFailedPrecondition, "--shortcut",
                "the shortcut path fails the check a merge runs: " + report.invalid_reason);
  }
  step.quality = report.quality;
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

RenderRequest MergePicture(const std::vector<InputPath>& inputs, const MergeResult& result,
                           const ShortcutStep* shortcut) {
  RenderRequest picture;
  for (size_t i = 0; i < inputs.size(); ++i) {
    RenderPath path{.path = inputs[i]};
    if (i < result.inputs.size()) path.quality = result.inputs[i].quality;
    picture.inputs.push_back(std::move(path));
  }
  picture.merged = RenderPath{.path = result.path, .quality = result.quality};
  if (picture.merged->path.name.empty()) picture.merged->path.name = "merged";
  if (shortcut != nullptr) {
    picture.merged = RenderPath{.path = shortcut->path, .quality = shortcut->quality};
    picture.merged->path.name = "merged + shortcut";
  }
  return picture;
}

}  // namespace hgraph::cli
