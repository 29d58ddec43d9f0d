#include "core/collision/free_motion.h"

#include <fcl/narrowphase/detail/primitive_shape_algorithm/triangle_distance.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

namespace hgraph::free_motion {
namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

using TriangleDistance = fcl::detail::TriangleDistance<double>;

class Advancer {
 public:
  Advancer(const MeshModel& mesh, const Screw& screw, const MeshModel& obstacle,
           const Eigen::Isometry3d& obstacle_pose, double best)
      : mesh_(mesh),
        screw_(screw),
        obstacle_(obstacle),
        rotation_(obstacle_pose.linear()),
        translation_(obstacle_pose.translation()),
        best_(best),
        rho_(static_cast<size_t>(mesh.getNumBVs()), -1.0) {}

  double RunPair(const TrianglePair& pair) {
    Triangles(pair.mesh, pair.obstacle);
    return best_;
  }

  double Run(double reach) {
    double rho = reach;
    const double tau = Tau(0, 0, reach, &rho);
    if (tau < best_) Descend(0, 0, rho);
    return best_;
  }

 private:
  // A lower bound on when any triangle under the moving node `m` can touch one under the static
  // node `o` (infinity: never along this motion), and in `rho` the reach bound of node m (at
  // most `parent_rho`). 0 when the volumes overlap at s = 0.
  double Tau(int m, int o, double parent_rho, double* rho) {
    const fcl::OBBRSSd& a = mesh_.getBV(m).bv;
    const fcl::OBBRSSd& b = obstacle_.getBV(o).bv;
    // A node's bound depends on its ancestors alone: computed once, whichever static node it
    // meets.
    double& known = rho_[static_cast<size_t>(m)];
    if (known < 0) known = std::min(parent_rho, screw_.Reach(a.obb.To) + a.obb.extent.norm());
    *rho = known;
    fcl::Vector3d p;
    fcl::Vector3d q;
    const double d = fcl::distance(rotation_, translation_, a, b, &p, &q);
    if (d <= 0) return 0;
    // p and q are in the moving rectangle's frame; q - p is the separating direction.
    const Eigen::Vector3d n = (a.rss.axis * (q - p)).normalized();
    const double speed = screw_.translation.dot(n) + screw_.angle * *rho * screw_.Across(n);
    return speed > 0 ? d / speed : kInfinity;
  }

  void Descend(int m, int o, double rho) {
    const auto& node_m = mesh_.getBV(m);
    const auto& node_o = obstacle_.getBV(o);
    if (node_m.isLeaf() && node_o.isLeaf()) {
      Triangles(node_m.primitiveId(), node_o.primitiveId());
      return;
    }
    // Split the larger volume, as FCL's traversals do.
    const bool split_m =
        node_o.isLeaf() || (!node_m.isLeaf() && node_m.bv.size() > node_o.bv.size());
    std::pair<int, int> child[2];
    if (split_m) {
      child[0] = {node_m.leftChild(), o};
      child[1] = {node_m.rightChild(), o};
    } else {
      child[0] = {m, node_o.leftChild()};
      child[1] = {m, node_o.rightChild()};
    }
    double rho_child[2] = {rho, rho};
    double tau[2];
    for (int k = 0; k < 2; ++k) tau[k] = Tau(child[k].first, child[k].second, rho, &rho_child[k]);
    const int first = tau[1] < tau[0] ? 1 : 0;
    for (int k : {first, 1 - first}) {
      if (tau[k] < best_) Descend(child[k].first, child[k].second, rho_child[k]);
    }
  }

  // One pair of triangles: the advancement from their places at s = 0 (0 in contact).
  void Triangles(int m_id, int o_id) {
    const fcl::Triangle& tm = mesh_.tri_indices[m_id];
    const fcl::Triangle& to = obstacle_.tri_indices[o_id];
    fcl::Vector3d moving[3];
    fcl::Vector3d fixed[3];
    double rho = 0;
    for (int k = 0; k < 3; ++k) {
      moving[k] = mesh_.vertices[tm[k]];
      rho = std::max(rho, screw_.Reach(moving[k]));
      fixed[k] = rotation_ * obstacle_.vertices[to[k]] + translation_;
    }
    fcl::Vector3d p;
    fcl::Vector3d q;
    const double d = TriangleDistance::triDistance(moving, fixed, p, q);
    if (d <= 0) {
      Set(0, m_id, o_id);
      return;
    }
    const Eigen::Vector3d n = (q - p) / d;
    const double speed = screw_.translation.dot(n) + screw_.angle * rho * screw_.Across(n);
    if (speed > 0 && d / speed < best_) Set(d / speed, m_id, o_id);
  }

 public:
  const TrianglePair& found() const { return found_; }

 private:
  void Set(double s, int m_id, int o_id) {
    best_ = s;
    found_ = TrianglePair{.mesh = m_id, .obstacle = o_id};
  }

  const MeshModel& mesh_;
  const Screw& screw_;
  TrianglePair found_;
  const MeshModel& obstacle_;
  const Eigen::Matrix3d rotation_;
  const Eigen::Vector3d translation_;
  double best_;
  // Each moving node's reach bound (Tau's rho) once computed; -1 before.
  std::vector<double> rho_;
};

}  // namespace

double Screw::Reach(const Eigen::Vector3d& m) const {
  return radial ? (m - center).norm() : axis.cross(m - center).norm();
}

double Screw::Across(const Eigen::Vector3d& n) const {
  return radial ? 1.0 : std::min(1.0, (n - n.dot(axis) * axis).norm());
}

double MeshReach(const MeshModel& mesh, const Screw& screw) {
  double reach = 0;
  for (int v = 0; v < mesh.num_vertices; ++v)
    reach = std::max(reach, screw.Reach(mesh.vertices[v]));
  return reach;
}

double AdvanceBound(const MeshModel& mesh, const Screw& screw, double reach,
                    const MeshModel& obstacle, const Eigen::Isometry3d& obstacle_pose, double limit,
                    TrianglePair* found) {
  if (limit <= 0 || mesh.getNumBVs() == 0 || obstacle.getNumBVs() == 0) return std::max(0.0, limit);
  Advancer advancer(mesh, screw, obstacle, obstacle_pose, limit);
  const double best = advancer.Run(reach);
  if (found != nullptr && best < limit) *found = advancer.found();
  return best;
}

double PairBound(const MeshModel& mesh, const Screw& screw, const MeshModel& obstacle,
                 const Eigen::Isometry3d& obstacle_pose, const TrianglePair& pair, double limit) {
  if (limit <= 0 || pair.mesh < 0 || pair.mesh >= mesh.num_tris || pair.obstacle < 0 ||
      pair.obstacle >= obstacle.num_tris) {
    return std::max(0.0, limit);
  }
  return Advancer(mesh, screw, obstacle, obstacle_pose, limit).RunPair(pair);
}

}  // namespace hgraph::free_motion
