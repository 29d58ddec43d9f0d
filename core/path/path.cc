#include "core/path/path.h"

#include <algorithm>

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

std::vector<Config> SamplesAlong(const Space& space, const InputPath& path, int count) {
  std::vector<Config> samples;
  if (path.waypoints.empty()) return samples;
  if (count < 2 || path.waypoints.size() < 2) {
    samples.push_back(path.waypoints.front());
    if (path.waypoints.size() > 1) samples.push_back(path.waypoints.back());
    return samples;
  }
  std::vector<double> at(path.waypoints.size(), 0.0);
  for (size_t i = 1; i < path.waypoints.size(); ++i) {
    at[i] = at[i - 1] + space.Distance(path.waypoints[i - 1], path.waypoints[i]);
  }
  const double total = at.back();
  size_t segment = 0;
  for (int k = 0; k < count; ++k) {
    const double s = total * k / (count - 1);
    while (segment + 2 < at.size() && at[segment + 1] < s) ++segment;
    const double span = at[segment + 1] - at[segment];
    const double t = span > 0 ? std::clamp((s - at[segment]) / span, 0.0, 1.0) : 0.0;
    samples.push_back(space.Interpolate(path.waypoints[segment], path.waypoints[segment + 1], t));
  }
  return samples;
}

}  // namespace hgraph
