// Certified partial shortcuts (the post-optimization of a merge, docs/design.md, "Anytime
// post-optimization"): a path is shortened by replacing the stretch between two of its points,
// anywhere along its edges, by the straight motion between them when the local planner proves
// that motion free (EdgeCheckRequest::certify). OMPL's PathSimplifier does the same with a
// sampled check; every motion accepted here carries a certificate, unless the caller asks for
// sampled checks only (ShortcutRequest::lazy) and certifies what it keeps, or takes motions
// valid at their samples (ShortcutRequest::sampled, a sampled merge).
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <optional>
#include <tuple>
#include <vector>

#include "core/common/progress.h"
#include "core/hgraph/hgraph.h"
#include "core/motion/motion_checker.h"

namespace hgraph {

// Random pairs drawn and checked together (ShortcutCertified): enough to keep the threads busy,
// few enough that little is checked on a path about to change. Fixed, so that the result does
// not depend on the thread count.
inline constexpr int kShortcutBatch = 8;

// The source of the point a fraction t of the way from a waypoint of source `a` to one of
// source `b`: on the input edge both lie on (their motion is a piece of it), else on none.
WaypointSource SourceBetween(const WaypointSource& a, const WaypointSource& b, double t);

struct ShortcutRequest {
  InputPath path;
  // The reports of the path's edges when they are known (certified), else empty.
  std::vector<EdgeReport> edges;
  // An id per waypoint that the result carries along (an H-Graph node); empty: none.
  std::vector<int> ids;
  // The source of each waypoint; empty: none known. The result's new points get theirs from it.
  std::vector<WaypointSource> sources;
  uint64_t seed = 1;
  // Random pairs of points tried per pass; 0: 5 per waypoint, at least 30.
  int attempts = 0;
  // > 0: a shortcut must also keep this clearance everywhere (safe length); its edges then
  // carry clearance profiles.
  double safety = 0;
  // Only cut corners (see ShortcutCertified), no waypoint drops or random pairs: the final
  // polish of a path that random shortcuts no longer improve.
  bool corners_only = false;
  // The share of the random pairs drawn as partial shortcuts, in [0, 1]: one part of the
  // configuration (Space::Part, a translation or a rotation) moves straight from the first point
  // to the second while the others keep their motion along the path, through the waypoints in
  // between. A path that turns while it moves loses the turns' detours where no straight motion
  // is free. Only in spaces with two parts or more.
  double partial = 0;
  // Motions taken when valid at the resolution's samples (EdgeProof::kSamples), without a
  // certificate: for a path that a certified search over the H-Graph takes apart afterwards
  // (lazy), where most motions a shortcut takes are replaced by later ones. Not with safety.
  bool lazy = false;
  // A path that needs its motions valid at their samples only (a merge with CheckMode::kSampled):
  // motions are checked at their samples (with safety, profiled, and taken without a
  // certificate), and a piece of a motion that is not certified enters the result unchecked
  // (EdgeState::kUnchecked), since the samples of the whole motion are not the piece's own: the
  // caller checks it at its samples before a path takes it.
  bool sampled = false;
  // Threads that check a batch of shortcuts at once (0 = all cores). The result does not depend
  // on it: the batches are fixed, only their checks run in parallel.
  int threads = 1;
  // The report of the motion between the waypoints with ids a and b when the caller already
  // knows it (an H-Graph edge); nullptr when it does not. Only a report that is invalid, or
  // valid and certified (lazy, sampled: valid), is taken instead of a check. May be empty.
  std::function<const EdgeReport*(int a, int b)> known;
  // A budget's end: no pass of waypoint drops, batch of random pairs or corner cut starts after
  // it, and the result holds what was taken before. A token whose deadline passes at `until` too
  // stops the checks in flight, with the same result; any other stop throws.
  std::optional<std::chrono::steady_clock::time_point> until;
};

struct ShortcutResult {
  InputPath path;
  std::vector<EdgeReport> edges;  // one per edge of `path`
  std::vector<int> ids;           // per waypoint: the request's id, -1 for a new point
  // Per waypoint: the request's source, or for a new point where it lies (SourceBetween; none
  // for a partial shortcut's points).
  std::vector<WaypointSource> sources;
  int accepted = 0;  // shortcuts taken
  int64_t edges_checked = 0;
  // The motions checked between two waypoints that carry ids (a, b, report), so that the caller
  // can keep them.
  std::vector<std::tuple<int, int, EdgeReport>> id_checks;
};

// Shortens the path: first drops waypoints whose neighbours connect, then tries seeded random
// pairs of points, a share of them partial shortcuts (ShortcutRequest::partial); or, with
// corners_only, cuts every corner (a waypoint is replaced by the points a fraction
// f = 1/2, 1/4, ..., 1/16 of each of its edges away, the largest f whose joining motion
// is proven free). Keeps the endpoints; never lengthens the path. The checks run in parallel
// batches: the waypoints to drop are checked together and non-neighbouring ones dropped, until
// none is left to try; the random pairs are drawn kShortcutBatch at a time on the current path,
// and of those proven free the ones that gain most and share no edge of the path are taken.
// Thread safe if the checker is. Throws Error(kCancelled / kDeadlineExceeded) when stopped.
ShortcutResult ShortcutCertified(const MotionChecker& checker, const ShortcutRequest& request,
                                 const CancelToken& cancel = {});

}  // namespace hgraph
