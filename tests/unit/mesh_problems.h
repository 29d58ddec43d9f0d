// Mesh scenes the unit tests share: named scene files of the repository, and a box as triangles.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "core/adapter/scene_proto.h"
#include "core/collision/collision_world.h"
#include "core/scene/scene.h"

namespace hgraph::testing {

struct MeshProblem {
  std::string name;
  std::string file;
};

// Meshes from a few dozen triangles (the bench's walls) to OMPL.app's size (the home), SE(2)
// and SE(3), one with self-collision (double_wrench).
inline std::vector<MeshProblem> MeshProblems() {
  const std::string root = HGRAPH_SOURCE_DIR;
  return {{"hole_wall", root + "/tests/bench/scenes/hole_wall/scene.json"},
          {"double_wrench", root + "/scenes/double_wrench/scene.json"},
          {"car_planar", root + "/tests/data/ompl_app_car/car_planar.cfg"},
          {"home", root + "/tests/bench/scenes/home/scene.json"},
          {"car_maze", root + "/tests/bench/scenes/car_maze/scene.json"}};
}

inline std::shared_ptr<const CollisionWorld> LoadWorld(const MeshProblem& p) {
  return std::make_shared<const CollisionWorld>(LoadSceneFile(p.file));
}

// A box mesh centred on the origin: the same solid as ShapeType::kBox, as triangles.
inline std::shared_ptr<const Mesh> BoxMesh(const Eigen::Vector3d& size) {
  auto mesh = std::make_shared<Mesh>();
  for (int i = 0; i < 8; ++i) {
    mesh->vertices.push_back(
        Eigen::Vector3d(i & 1 ? 0.5 : -0.5, i & 2 ? 0.5 : -0.5, i & 4 ? 0.5 : -0.5)
            .cwiseProduct(size));
  }
  const int quads[6][4] = {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4},
                           {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}};
  for (const auto& q : quads) {
    mesh->triangles.emplace_back(q[0], q[1], q[2]);
    mesh->triangles.emplace_back(q[0], q[2], q[3]);
  }
  return mesh;
}

}  // namespace hgraph::testing
