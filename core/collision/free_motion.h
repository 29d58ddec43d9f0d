// Direction-aware conservative advancement of a rigid mesh along a straight motion against a
// static mesh: how far the motion is certainly free of contact. Internal to core/collision (it
// reads FCL's bounding-volume trees); CollisionContext::FreeFraction is the public face.
//
// The motion is a screw: in the moving mesh's frame at s = 0, a point m is at
//   center + AngleAxis(s * angle, axis) * (m - center) + s * translation.
// Its velocity is translation + angle * axis x (the point's offset from the axis line, turned): the
// turn's part is perpendicular to the axis and rho * angle long, so along a fixed unit vector n a
// point that starts at distance rho from the axis line moves at most
//   s * (translation . n + angle * rho * |n - (n . axis) axis|)
// over s (a turn about n itself moves nothing along n). Two convex sets whose nearest points are P
// (moving) and Q (static) lie on either side of the planes through P and Q normal to n = (Q - P) /
// |Q - P|: the moving set cannot reach the static one before that bound reaches |Q - P|. Bounding
// volumes give such a lower bound for every pair of triangles beneath them, with rho bounded over
// the volume, and prune the pairs whose bound is no lower than the least found so far: the answer
// is the least bound of a pair of triangles at their places at s = 0. A caller advances the robot
// by it and asks again from there (conservative advancement, one step per query: advancing every
// pair of triangles further within one query cost more than the queries it saved on the bench's
// real-size meshes). Unlike a bound by how far any point moves (|translation| + angle * radius), a
// motion that slides along an obstacle, or away from it, is not held back by it.
#pragma once

#include <fcl/geometry/bvh/BVH_model.h>
#include <fcl/math/bv/OBBRSS.h>

#include <Eigen/Geometry>

namespace hgraph::free_motion {

using MeshModel = fcl::BVHModel<fcl::OBBRSSd>;

struct Screw {
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();  // unit
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  double angle = 0;  // >= 0
  // Bound the turn's reach by the distance from `center` rather than from the axis line: for
  // turns too small for the axis to be known well.
  bool radial = false;

  // How far the point m (at s = 0) is from what the turn moves it about: the axis line, or the
  // center when radial.
  double Reach(const Eigen::Vector3d& m) const;
  // How much of the turn's speed a unit direction n can see: a point at Reach rho from the axis
  // moves at angle * rho across the axis, so along n at most angle * rho * |n across the axis|
  // (1 when radial).
  double Across(const Eigen::Vector3d& n) const;
};

// The largest Reach over the mesh's vertices.
double MeshReach(const MeshModel& mesh, const Screw& screw);

// A pair of triangles, the moving mesh's and the static one's (indices of their triangles).
struct TrianglePair {
  int mesh = -1;
  int obstacle = -1;
};

// The moving mesh (`reach` its MeshReach) against the static mesh placed at `obstacle_pose` in
// the moving mesh's frame at s = 0: a fraction s in [0, limit] such that no triangle of the one
// touches a triangle of the other for any parameter in [0, s), the least bound of a pair of
// triangles (above); 0 when they touch at s = 0, limit when no pair's bound is below it. limit >=
// 0. When the answer is below limit, `found` (may be null) gets the pair of triangles that set it.
double AdvanceBound(const MeshModel& mesh, const Screw& screw, double reach,
                    const MeshModel& obstacle, const Eigen::Isometry3d& obstacle_pose, double limit,
                    TrianglePair* found = nullptr);

// The bound of one pair of triangles alone, at most limit (limit for a pair that names no
// triangle of the meshes). The pair that bounded the previous step of a motion often bounds the
// next one too: starting AdvanceBound's limit from it prunes nearly every
// pair of volumes at once, and changes no answer (it is one of the pairs the answer is the
// minimum over).
double PairBound(const MeshModel& mesh, const Screw& screw, const MeshModel& obstacle,
                 const Eigen::Isometry3d& obstacle_pose, const TrianglePair& pair, double limit);

}  // namespace hgraph::free_motion
