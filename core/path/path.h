// The basic path type every module passes around: named waypoints in a configuration space, and
// the few facts about a path that need only the space (its length, whether its waypoints fit).
#pragma once

#include <string>
#include <vector>

#include "core/space/space.h"

namespace hgraph {

// How far the first (last) waypoint of an input may be from the shared start (goal): the merge's
// default endpoint tolerance, and what a planned path's ends may deviate before they are snapped.
inline constexpr double kEndpointTolerance = 1e-6;

// A discrete input path. Plain struct; copyable.
// Where a waypoint lies on the input paths of a merge (MergeResult source_path, source_index,
// source_fraction; an H-Graph node's path, index and t): on input `path`'s edge (index,
// index + 1) at fraction t in [0, 1), t = 0 at its waypoint `index`; path -1 where it lies on
// none (a shortcut's end off the inputs, a partial shortcut's point).
struct WaypointSource {
  int path = -1;
  int index = -1;
  double t = 0;
};

struct InputPath {
  std::string name;
  std::vector<Config> waypoints;
};

// Sum of Space::Distance over consecutive waypoints (0 for fewer than two).
double PathLength(const Space& space, const InputPath& path);
// `count` configurations evenly spaced by arc length along the path, ends included (its ends
// only when count < 2).
std::vector<Config> SamplesAlong(const Space& space, const InputPath& path, int count);

// Space::Validate on every waypoint, naming "<field>.waypoints[i]" in the InputError. With
// min_waypoints > 0, a path with fewer waypoints is an InputError naming `field`.
void ValidatePath(const Space& space, const InputPath& path, const std::string& field,
                  size_t min_waypoints = 0);

}  // namespace hgraph
