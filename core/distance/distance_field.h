// A distance field of a scene's static world: a grid of points over a box, each holding its
// distance to the obstacles as FCL measures it (CollisionContext::ObstacleDistance), rounded
// down. Distance to a fixed set is 1-Lipschitz, so any point p is at least D(g) - |p - g| from
// the obstacles, for g any grid point (the nearest gives the tightest bound).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "core/collision/collision_world.h"

namespace hgraph {

// Immutable after construction; thread safe. Copyable and movable (plain data).
class DistanceField {
 public:
  // Samples the world on the grid of spacing cell_size whose first point is box.min() and
  // which reaches box.max(), on `threads` threads (0: all cores). Throws InputError naming
  // "cell_size" unless it is positive and finite, or "max_cells" if the grid would have more
  // points than max_cells.
  DistanceField(const CollisionWorld& world, const Eigen::AlignedBox3d& box, double cell_size,
                int64_t max_cells, int threads = 0);

  // A lower bound on the distance from p to the obstacles (possibly negative): the nearest grid
  // point's distance minus how far p is from it. Outside the box the nearest grid point is on
  // its border, and the bound is looser but still holds.
  double LowerBound(const Eigen::Vector3d& p) const {
    Eigen::Vector3d g;
    int64_t at = 0;
    for (int d = 0; d < 3; ++d) {
      const double x = (p[d] - origin_[d]) * inverse_cell_;
      const int64_t i = std::clamp<int64_t>(std::llround(x), 0, counts_[d] - 1);
      g[d] = origin_[d] + static_cast<double>(i) * cell_size_;
      at += i * stride_[d];
    }
    return static_cast<double>(values_[at]) - (p - g).norm();
  }

  // The distance stored at grid point (i, j, k) and where that point is.
  double Value(int64_t i, int64_t j, int64_t k) const {
    return values_[i * stride_[0] + j * stride_[1] + k * stride_[2]];
  }
  Eigen::Vector3d Point(int64_t i, int64_t j, int64_t k) const {
    return origin_ + cell_size_ * Eigen::Vector3d(static_cast<double>(i), static_cast<double>(j),
                                                  static_cast<double>(k));
  }
  const Eigen::Vector3i& counts() const { return counts_; }
  double cell_size() const { return cell_size_; }
  int64_t cells() const { return static_cast<int64_t>(values_.size()); }
  size_t memory_bytes() const { return sizeof(*this) + values_.size() * sizeof(float); }

 private:
  Eigen::Vector3d origin_;
  double cell_size_ = 0;
  double inverse_cell_ = 0;
  Eigen::Vector3i counts_;
  Eigen::Matrix<int64_t, 3, 1> stride_;
  // Floats, each no larger than the double FCL returned: 4 bytes a point.
  std::vector<float> values_;
};

}  // namespace hgraph
