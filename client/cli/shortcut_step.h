// `hgraph merge --shortcut`: hybridize, then shortcut the merged path with OMPL's
// PathSimplifier (core/plan), and report the quality after it. Also the picture of a merge
// (--svg), which shows the path --out-path gets. Both run in process, also after a merge through
// the service (--server): the CLI holds the scene.
#pragma once

#include <cstdint>
#include <vector>

#include "core/measure/measure.h"
#include "core/merge/merge.h"
#include "core/motion/motion_checker.h"
#include "core/render/svg_render.h"

namespace hgraph::cli {

struct ShortcutStep {
  InputPath path;
  PathQuality quality;
  double elapsed_ms = 0;
};

// Shortcuts result.path (seeded) and evaluates every measure of the outcome with the check a
// merge runs on its inputs (CheckPaths), with the measure's k, so the row compares directly with
// the merge's own rows.
ShortcutStep ShortcutMergedPath(const MotionChecker& checker, const MergeResult& result,
                                const MeasureSpec& measure, double resolution, uint64_t seed);

// One more row under the merge's quality table.
void PrintShortcutRow(const ShortcutStep& step, const MergeResult& result);

// The picture of a merge: the inputs with their reported quality, and the merged path, or the
// shortcut path when there is one.
RenderRequest MergePicture(const std::vector<InputPath>& inputs, const MergeResult& result,
                           const ShortcutStep* shortcut);

}  // namespace hgraph::cli
