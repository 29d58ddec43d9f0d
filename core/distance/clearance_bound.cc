#include "core/distance/clearance_bound.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "core/common/error.h"
#include "core/common/limits.h"

namespace hgraph {
namespace {

bool HasMesh(const Scene& scene) {
  for (const Obstacle& o : scene.obstacles) {
    if (o.shape.type == ShapeType::kMesh) return true;
  }
  for (const RobotBody& b : scene.robot) {
    if (b.shape.type == ShapeType::kMesh) return true;
  }
  return false;
}

double SmallestBodyRadius(const CollisionWorld& world) {
  double smallest = std::numeric_limits<double>::infinity();
  for (int i = 0; i < static_cast<int>(world.scene().robot.size()); ++i) {
    smallest = std::min(smallest, world.BodyRadius(i));
  }
  return smallest;
}

}  // namespace

Eigen::AlignedBox3d ClearanceBound::ReachableBox(const CollisionWorld& world) {
  const Space& space = world.space();
  Eigen::AlignedBox3d box;
  for (int i = 0; i < static_cast<int>(world.scene().robot.size()); ++i) {
    const ComponentSpec& c = space.component(world.scene().robot[i].component);
    Eigen::Vector3d lo = Eigen::Vector3d::Zero();
    Eigen::Vector3d hi = Eigen::Vector3d::Zero();
    // Rotations keep the frame's origin at 0; R^2 and SE(2) move it in the plane z = 0.
    for (int d = 0; d < std::min<int>(3, static_cast<int>(c.lower.size())); ++d) {
      lo[d] = c.lower[d];
      hi[d] = c.upper[d];
    }
    const Eigen::Vector3d r = Eigen::Vector3d::Constant(world.BodyRadius(i));
    box.extend(lo - r);
    box.extend(hi + r);
  }
  return box;
}

std::shared_ptr<const ClearanceBound> ClearanceBound::Build(
    std::shared_ptr<const CollisionWorld> world, const ClearanceBoundOptions& options) {
  HGRAPH_CHECK(world != nullptr);
  if (!(options.cell_size >= 0) || !std::isfinite(options.cell_size)) {
    throw InputError("cell_size",
                     "must be 0 (automatic) or positive, got " + limits::Num(options.cell_size));
  }
  if (options.target_cells < 1 || options.max_cells < options.target_cells) {
    throw InputError("target_cells", "must be at least 1 and at most max_cells (" +
                                         std::to_string(options.max_cells) + "), got " +
                                         std::to_string(options.target_cells));
  }
  const Scene& scene = world->scene();
  if (scene.obstacles.empty() || scene.robot.empty() || !HasMesh(scene)) return nullptr;
  const Eigen::AlignedBox3d box = ReachableBox(*world);
  double cell = options.cell_size;
  if (cell == 0) {
    // Cubic cells; a flat box (a planar robot's) still has a layer of points per cell of height.
    const Eigen::Vector3d size = box.sizes();
    cell = std::cbrt(size.prod() / static_cast<double>(options.target_cells));
    // Grow until the points fit (the +2 per axis of the grid's ends).
    while ((std::floor(size.x() / cell) + 2) * (std::floor(size.y() / cell) + 2) *
               (std::floor(size.z() / cell) + 2) >
           static_cast<double>(options.target_cells)) {
      cell *= 1.05;
    }
  }
  if (cell > options.max_cell_to_body * SmallestBodyRadius(*world)) return nullptr;
  return std::make_shared<const ClearanceBound>(std::move(world), cell, options);
}

ClearanceBound::ClearanceBound(std::shared_ptr<const CollisionWorld> world, double cell_size,
                               const ClearanceBoundOptions& options)
    : world_(std::move(world)),
      field_(*world_, ReachableBox(*world_), cell_size, options.max_cells, options.threads) {
  // Spheres about as large as a cell: the bound loses up to a cell's half-diagonal to the
  // grid and a sphere's radius to the cover, and a cover much finer than the grid would cost
  // lookups without tightening it much.
  for (const RobotBody& body : world_->scene().robot) {
    covers_.push_back(CoverShape(body.shape, cell_size));
  }
  const Eigen::AlignedBox3d box = ReachableBox(*world_);
  const double scale = std::max(box.min().cwiseAbs().maxCoeff(), box.max().cwiseAbs().maxCoeff());
  slack_ = 1e-9 * (1 + scale);
}

double ClearanceBound::LowerBound(const Config& q) const {
  if (!world_->space().InBounds(q)) return 0.0;
  const int bodies = static_cast<int>(covers_.size());
  // Poses of the bodies, kept for the self terms.
  thread_local std::vector<Eigen::Isometry3d> poses;
  poses.resize(bodies);
  // Best first over the spheres' trees: every node's sphere holds its subtree's points, so the
  // bound of any set of nodes that together hold every leaf (a cut of the trees) is a lower
  // bound. The queue is such a cut; the node with the smallest bound is split until it is a
  // leaf, whose bound is then the cut's minimum. Only the nodes nearer than the answer are
  // visited: a few dozen of a thousand spheres in open space.
  struct Entry {
    double bound;
    int body;
    int node;
    bool operator<(const Entry& o) const { return bound > o.bound; }  // a min-heap
  };
  thread_local std::vector<Entry> heap;
  heap.clear();
  const auto push = [&](int body, int node) {
    const CoverSphere& s = covers_[body].nodes[node].sphere;
    heap.push_back({field_.LowerBound(poses[body] * s.centre) - s.radius, body, node});
    std::push_heap(heap.begin(), heap.end());
  };
  for (int i = 0; i < bodies; ++i) {
    poses[i] = world_->BodyPose(i, q);
    if (!covers_[i].nodes.empty()) push(i, 0);
  }
  double best = std::numeric_limits<double>::infinity();
  while (!heap.empty()) {
    std::pop_heap(heap.begin(), heap.end());
    const Entry e = heap.back();
    heap.pop_back();
    const SphereCover::Node& node = covers_[e.body].nodes[e.node];
    if (node.left < 0) {
      best = e.bound;
      break;
    }
    push(e.body, node.left);
    push(e.body, node.right);
  }
  for (const auto& [i, j] : world_->SelfPairs()) {
    best = CoverDistanceLowerBound(covers_[i], poses[i], covers_[j], poses[j], best);
  }
  return best - slack_;
}

size_t ClearanceBound::memory_bytes() const {
  size_t bytes = sizeof(*this) + field_.memory_bytes();
  for (const SphereCover& c : covers_) {
    bytes += c.spheres.size() * sizeof(CoverSphere) + c.nodes.size() * sizeof(SphereCover::Node);
  }
  return bytes;
}

}  // namespace hgraph
