// A cheap certified lower bound on clearance (what CollisionContext::Clearance measures): the
// static world's distance field (DistanceField) and the robot's bodies covered by spheres
// (SphereCover). A point of a body lies in some sphere (c, r); with g the grid point nearest to
// c (placed by the body's pose), the point is at least D(g) - |c - g| - r from the obstacles.
// Between bodies that count towards clearance (self-collision), the spheres' own distances
// bound the bodies' distance. The minimum of all of these is at most the exact clearance, so a
// clearance certificate that holds with it holds exactly.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "core/collision/collision_world.h"
#include "core/distance/distance_field.h"
#include "core/distance/sphere_cover.h"

namespace hgraph {

struct ClearanceBoundOptions {
  // Grid spacing; 0 picks the one that puts target_cells points on the box the robot can reach.
  double cell_size = 0;
  int64_t target_cells = 1'000'000;
  // No field is built with more points than this (4 bytes each).
  int64_t max_cells = 4'000'000;
  // A grid coarser than this fraction of the smallest body's radius would lose more of the
  // clearance than it saves: Build returns null and the checker measures exactly.
  double max_cell_to_body = 0.25;
  // Threads that sample the field (0: all cores).
  int threads = 0;
};

// Immutable after construction; thread safe. Not copyable (held through shared_ptr).
class ClearanceBound {
 public:
  // The bound for a world, or null where it cannot pay: a scene without meshes (primitive
  // distances are analytic, about as cheap as the bound), with no obstacles, or whose field would
  // be too coarse (ClearanceBoundOptions::max_cell_to_body). Throws InputError naming the
  // option's field for invalid options.
  static std::shared_ptr<const ClearanceBound> Build(std::shared_ptr<const CollisionWorld> world,
                                                     const ClearanceBoundOptions& options = {});
  ClearanceBound(std::shared_ptr<const CollisionWorld> world, double cell_size,
                 const ClearanceBoundOptions& options);
  ClearanceBound(const ClearanceBound&) = delete;
  ClearanceBound& operator=(const ClearanceBound&) = delete;

  // At most CollisionContext::Clearance(q) (0 out of bounds, like it); may be negative.
  double LowerBound(const Config& q) const;

  const CollisionWorld& world() const { return *world_; }
  const DistanceField& field() const { return field_; }
  const SphereCover& cover(int body) const { return covers_.at(body); }
  size_t memory_bytes() const;

  // The box a grid must cover: every point a robot body can reach within the space's bounds.
  static Eigen::AlignedBox3d ReachableBox(const CollisionWorld& world);

 private:
  std::shared_ptr<const CollisionWorld> world_;
  DistanceField field_;
  std::vector<SphereCover> covers_;
  // Rounding of the poses and distances above, subtracted from every bound.
  double slack_ = 0;
};

}  // namespace hgraph
