// The baselines a merge is compared with, run through OMPL on the same input paths and with the
// same MotionChecker: PathSimplifier's shortcutting, and OMPL's own PathHybridization (the
// paper's algorithm as OMPL ships it: all paths in one graph, bridges at the matched pairs of a
// pairwise alignment, shortest path by length).
#pragma once

#include <cstdint>
#include <vector>

#include "core/motion/motion_checker.h"
#include "core/path/path.h"

namespace hgraph {

// How the baselines check a motion.
enum class OmplMotionCheck {
  // MotionChecker::CheckEdge with a certificate: OMPL accepts exactly the motions a merge accepts.
  kCertified,
  // OMPL's own DiscreteMotionValidator, as OMPL ships it: the states at the resolution's steps
  // only (MotionChecker::IsValid), so a motion may graze an obstacle between two of them. What
  // OMPL users run; its outputs are not certified.
  kDiscrete,
};

struct ShortcutOptions {
  uint64_t seed = 1;  // PathSimplifier draws random pairs of points to connect
  // Rounds of reduceVertices + shortcutPath; stops early when a round shortens nothing.
  int max_rounds = 20;
  double resolution = kDefaultResolution;  // OMPL's discretisation, as in PlanRequest::resolution
};

// OMPL's PathSimplifier on one path: reduceVertices (drop waypoints whose neighbours connect)
// and shortcutPath (connect random points of two edges), repeated. Keeps start and goal; every
// new edge is checked with `checker`. Throws InputError naming "path" for a path of fewer than
// two waypoints or of the wrong dimension.
InputPath ShortcutPath(const MotionChecker& checker, const InputPath& path,
                       const ShortcutOptions& options = {});

struct SimplifyMaxOptions {
  uint64_t seed = 1;
  double resolution = 0.01;
  OmplMotionCheck motion_check = OmplMotionCheck::kCertified;
};

// OMPL's PathSimplifier::simplifyMax on one path: OMPL's full simplification (reduceVertices,
// shortcutPath, collapseCloseVertices, B-spline smoothing, repeated while it improves) without a
// time limit, the pipeline OMPL users run after PathHybridization. Keeps start and goal; every
// new edge is checked with `checker` at OMPL's discretisation, as options.motion_check says.
// Throws InputError as ShortcutPath.
InputPath SimplifyMaxPath(const MotionChecker& checker, const InputPath& path,
                          const SimplifyMaxOptions& options = {});

struct OmplHybridizationOptions {
  double resolution = kDefaultResolution;
  // OMPL's recordPath(..., matchAcrossGaps): also bridge the ends of unmatched stretches.
  bool match_across_gaps = true;
  OmplMotionCheck motion_check = OmplMotionCheck::kCertified;
};

// OMPL's geometric::PathHybridization on `paths` (same start and goal). Throws InputError naming
// "paths" for fewer than one path, and Error(kFailedPrecondition) if OMPL finds no hybrid path.
InputPath OmplHybridize(const MotionChecker& checker, const std::vector<InputPath>& paths,
                        const OmplHybridizationOptions& options = {});

}  // namespace hgraph
