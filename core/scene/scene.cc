#include "core/scene/scene.h"

#include <cmath>
#include <set>
#include <string>

#include "core/common/error.h"

namespace hgraph {
namespace {

bool Positive(double v) { return std::isfinite(v) && v > 0; }

void ValidateShape(const Shape& shape, const std::string& field) {
  switch (shape.type) {
    case ShapeType::kBox:
      for (int k = 0; k < 3; ++k) {
        if (!Positive(shape.box_size[k])) {
          throw InputError(
              field + ".box_size[" + std::to_string(k) + "]",
              "box side must be positive and finite, got " + std::to_string(shape.box_size[k]));
        }
      }
      break;
    case ShapeType::kSphere:
      // Radius 0 is allowed on purpose: a point robot (OMPL's 2D point problems).
      if (!std::isfinite(shape.radius) || shape.radius < 0) {
        throw InputError(field + ".radius", "sphere radius must be >= 0 and finite, got " +
                                                std::to_string(shape.radius));
      }
      break;
    case ShapeType::kCylinder:
      if (!Positive(shape.radius)) {
        throw InputError(field + ".radius", "cylinder radius must be positive and finite, got " +
                                                std::to_string(shape.radius));
      }
      if (!Positive(shape.length)) {
        throw InputError(field + ".length", "cylinder length must be positive and finite, got " +
                                                std::to_string(shape.length));
      }
      break;
    case ShapeType::kMesh:
      if (shape.mesh == nullptr || shape.mesh->triangles.empty()) {
        throw InputError(field + ".mesh",
                         "mesh" +
                             (shape.source.empty() ? std::string() : " '" + shape.source + "'") +
                             " has no triangles");
      }
      {
        const int n = static_cast<int>(shape.mesh->vertices.size());
        for (size_t t = 0; t < shape.mesh->triangles.size(); ++t) {
          const Eigen::Vector3i& tri = shape.mesh->triangles[t];
          if (tri.minCoeff() < 0 || tri.maxCoeff() >= n) {
            throw InputError(field + ".mesh.triangles[" + std::to_string(t) + "]",
                             "vertex index out of range (" + std::to_string(n) + " vertices)");
          }
        }
      }
      break;
  }
}

}  // namespace

void ValidateScene(const Scene& scene) {
  if (scene.robot.empty()) throw InputError("robot", "the robot has no bodies");
  for (size_t i = 0; i < scene.robot.size(); ++i) {
    const RobotBody& body = scene.robot[i];
    const std::string field = "robot[" + std::to_string(i) + "]";
    if (body.component < 0 || body.component >= scene.space.num_components()) {
      throw InputError(field + ".component", "component " + std::to_string(body.component) +
                                                 " is out of range (space has " +
                                                 std::to_string(scene.space.num_components()) +
                                                 " components)");
    }
    if (!scene.space.CanDriveBody(body.component)) {
      throw InputError(field + ".component",
                       "component " + std::to_string(body.component) + " (" +
                           ComponentTypeName(scene.space.component(body.component).type) +
                           ") cannot drive a rigid body");
    }
    ValidateShape(body.shape, field + ".shape");
  }
  for (size_t i = 0; i < scene.obstacles.size(); ++i) {
    ValidateShape(scene.obstacles[i].shape, "obstacles[" + std::to_string(i) + "].shape");
  }
}

std::vector<int> RobotComponents(const Scene& scene) {
  std::set<int> components;
  for (const RobotBody& body : scene.robot) components.insert(body.component);
  return {components.begin(), components.end()};
}

}  // namespace hgraph
