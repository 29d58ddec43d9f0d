#include "core/path/path.h"

#include "core/common/error.h"

namespace hgraph {

double PathLength(const Space& space, const InputPath& path) {
  double length = 0;
  for (size_t i = 0; i + 1 < path.waypoints.size(); ++i) {
    length += space.Distance(path.waypoints[i], path.waypoints[i + 1]);
  }
  return length;
}

void ValidatePath(const Space& space, const InputPath& path, const std::string& field,
                  size_t min_waypoints) {
  if (path.waypoints.size() < min_waypoints) {
    throw InputError(field, "needs at least " + std::to_string(min_waypoints) + " waypoints, got " +
                                std::to_string(path.waypoints.size()));
  }
  for (size_t i = 0; i < path.waypoints.size(); ++i) {
    space.Validate(path.waypoints[i], field + ".waypoints[" + std::to_string(i) + "]");
  }
}

}  // namespace hgraph
