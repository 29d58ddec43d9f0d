// ClearanceWitness: core/collision makes them, core/motion's checker interface passes them on,
// lazy evaluation bounds clearance with them. It lives here, below both layers, so that the
// layers keep depending one way.
#pragma once

#include <Eigen/Core>

namespace hgraph {

// Where a clearance was found: a point of robot body `body`, in the body's own frame (its world
// pose is the body's pose times the point), and the point nearest to it, of an obstacle (in the
// world frame, other_body == -1) or of another body (in that body's frame). The two points stay
// on the robot and the obstacle as the robot moves, so the distance between them, at any
// configuration, bounds the clearance there from above. body == -1: none known.
struct ClearanceWitness {
  int body = -1;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  int other_body = -1;
  Eigen::Vector3d other_point = Eigen::Vector3d::Zero();
};

}  // namespace hgraph
