// The scene model: obstacles and robot bodies made of meshes and primitives, their poses, and
// the configuration space the robot moves in. Immutable once loaded; shared between threads and
// sessions as shared_ptr<const Scene>.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/space/space.h"

namespace hgraph {

// A triangle mesh in its own frame, scale already applied. Copyable; usually shared as
// shared_ptr<const Mesh>.
struct Mesh {
  std::vector<Eigen::Vector3d> vertices;
  std::vector<Eigen::Vector3i> triangles;
  // OMPL.app's reference point of this mesh as a robot (MeshLoadOptions::ompl_app_center), in
  // the frame and scale of `vertices`; unset unless asked for.
  std::optional<Eigen::Vector3d> ompl_app_center;
};

enum class ShapeType { kMesh, kBox, kSphere, kCylinder };

// Geometry of one object in its own frame. Primitives are centred on the origin; a cylinder's
// axis is Z. Plain struct; copyable (meshes are shared).
struct Shape {
  ShapeType type = ShapeType::kBox;
  Eigen::Vector3d box_size = Eigen::Vector3d::Ones();  // full side lengths
  double radius = 0;                                   // sphere, cylinder (sphere may be 0: a point)
  double length = 0;                                   // cylinder, along Z
  std::shared_ptr<const Mesh> mesh;                    // kMesh
  std::string source;                                  // where the mesh came from, for messages
};

// A static obstacle placed in the world.
struct Obstacle {
  std::string name;
  Shape shape;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
};

// A rigid robot body driven by one component of the space: its world pose is
// space.Pose(component, q) * offset.
struct RobotBody {
  std::string name;
  Shape shape;
  int component = 0;
  Eigen::Isometry3d offset = Eigen::Isometry3d::Identity();
};

// Everything a merge needs to know about the world. Copyable and movable; treat as immutable
// once built.
struct Scene {
  std::string name;
  Space space;
  std::vector<Obstacle> obstacles;
  std::vector<RobotBody> robot;
  // Check pairs of robot bodies against each other (two wrenches must not hit each other).
  // Bodies driven by the same component move as one rigid body and are not checked.
  bool self_collision = false;
  // Optional query the scene was built for (the built-in scenes carry one).
  std::optional<Config> start;
  std::optional<Config> goal;
};

// Throws InputError naming the field if the robot is empty, a body's component index is out of
// range or cannot drive a body, or a primitive has a non-positive size.
void ValidateScene(const Scene& scene);
// The distinct space components that drive the robot's bodies, in increasing order.
std::vector<int> RobotComponents(const Scene& scene);

}  // namespace hgraph
