// The robot as spheres: every point of a body that its clearance is measured from (a mesh's
// triangles, since FCL meshes are surfaces; a primitive's whole solid) lies in one of its
// cover's spheres, given in the body's frame (the frame CollisionWorld::BodyPose places).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "core/scene/scene.h"

namespace hgraph {

struct CoverSphere {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double radius = 0;
};

// The spheres of one body and a binary tree over them (each node a sphere holding its
// children's), for distance bounds between two bodies. Plain data; copyable and movable.
struct SphereCover {
  struct Node {
    CoverSphere sphere;
    int left = -1;  // both -1 for a leaf, which holds spheres[index]
    int right = -1;
    int index = -1;
  };
  std::vector<CoverSphere> spheres;
  std::vector<Node> nodes;  // nodes[0] is the root; empty when there are no spheres
};

// Covers `shape` with spheres of radius at most max_radius (triangles are halved through their
// longest edge until their
// smallest enclosing sphere is that small; primitives are cut into pieces), or more
// where a cut would make more than max_pieces spheres of one triangle or primitive.
// Throws InputError("max_radius") unless max_radius is positive and finite.
SphereCover CoverShape(const Shape& shape, double max_radius, int max_pieces = 256);

// A lower bound on the distance between every point of cover a posed at pa and every point of
// cover b posed at pb, or `best` if that is smaller (the descent stops where it cannot go
// below `best`).
double CoverDistanceLowerBound(const SphereCover& a, const Eigen::Isometry3d& pa,
                               const SphereCover& b, const Eigen::Isometry3d& pb, double best);

}  // namespace hgraph
