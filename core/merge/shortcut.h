// Certified partial shortcuts (the post-optimization of a merge, DESIGN.md "Anytime
// post-optimization"): a path is shortened by replacing the stretch between two of its points,
// anywhere along its edges, by the straight motion between them when the local planner proves
// that motion free (EdgeCheckRequest::certify). OMPL's PathSimplifier does the same with a
// sampled check; every motion accepted here carries a certificate.
#pragma once

#include <cstdint>
#include <vector>

#include "core/common/progress.h"
#include "core/hgraph/hgraph.h"
#include "core/motion/motion_checker.h"

namespace hgraph {

struct ShortcutRequest {
  InputPath path;
  // The reports of the path's edges when they are known (certified), else empty.
  std::vector<EdgeReport> edges;
  // An id per waypoint that the result carries along (an H-Graph node); empty: none.
  std::vector<int> ids;
  uint64_t seed = 1;
  // Random pairs of points tried per pass; 0: 10 per waypoint, at least 50.
  int attempts = 0;
  // > 0: a shortcut must also keep this clearance everywhere (safe length); its edges then
  // carry clearance profiles.
  double safety = 0;
};

struct ShortcutResult {
  InputPath path;
  std::vector<EdgeReport> edges;  // one per edge of `path`
  std::vector<int> ids;           // per waypoint: the request's id, -1 for a new point
  int accepted = 0;               // shortcuts taken
  int64_t edges_checked = 0;
};

// Shortens the path: first drops each waypoint whose neighbours connect, then tries seeded
// random pairs of points. Keeps the endpoints; never lengthens the path. Single-threaded (each
// accepted shortcut changes the path the next one is drawn on); thread safe if the checker is.
// Throws Error(kCancelled / kDeadlineExceeded) when stopped.
ShortcutResult ShortcutCertified(const MotionChecker& checker, const ShortcutRequest& request,
                                 const CancelToken& cancel = {});

}  // namespace hgraph
