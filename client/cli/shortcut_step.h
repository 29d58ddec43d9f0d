// `hgraph merge --shortcut`: hybridize, then shortcut the merged path with OMPL's
// PathSimplifier (core/plan), and report the quality after it.
#pragma once

#include <cstdint>

#include "core/measure/measure.h"
#include "core/merge/merge.h"
#include "core/motion/motion_checker.h"

namespace hgraph::cli {

struct ShortcutStep {
  InputPath path;
  PathQuality quality;
  double elapsed_ms = 0;
};

// Shortcuts result.path (seeded) and evaluates every measure of the outcome under `measure`
// with the same checker, so the row compares directly with the merge's own rows.
ShortcutStep ShortcutMergedPath(const MotionChecker& checker, const MergeResult& result,
                                const MeasureSpec& measure, double resolution, uint64_t seed);

// One more row under the merge's quality table.
void PrintShortcutRow(const ShortcutStep& step, const MergeResult& result);

}  // namespace hgraph::cli
