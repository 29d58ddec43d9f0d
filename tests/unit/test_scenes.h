// Scenes built in code from OMPL's test data (tests/data/ompl-2d), for tests of the engine.
#pragma once

#include <fstream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/hgraph/hgraph.h"
#include "core/scene/scene.h"

namespace hgraph::testing {

// Opens a file under tests/data, or throws naming it: a test must fail loudly, never run on an
// empty scene.
inline std::ifstream OpenTestData(const std::string& relative) {
  const std::string path = std::string(HGRAPH_TEST_DATA_DIR) + "/" + relative;
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open test data file " + path);
  return in;
}

// The 72 discs of ompl-2d/circle_obstacles.txt as vertical cylinders, and a point robot driven
// by an R^2 component with bounds [0, 80]^2.
inline std::shared_ptr<const Scene> CirclesScene() {
  auto scene = std::make_shared<Scene>(Scene{
      .name = "circles",
      .space = Space::RealVector(Eigen::Vector2d(0, 0), Eigen::Vector2d(80, 80)),
  });
  std::ifstream in = OpenTestData("ompl-2d/circle_obstacles.txt");
  std::string line;
  std::getline(in, line);
  std::getline(in, line);
  int id;
  double x, y, r;
  while (in >> id >> x >> y >> r) {
    Obstacle disc{.name = "disc" + std::to_string(id),
                  .shape = Shape{.type = ShapeType::kCylinder, .radius = r, .length = 2.0}};
    disc.pose.translation() = Eigen::Vector3d(x, y, 0);
    scene->obstacles.push_back(disc);
  }
  if (scene->obstacles.empty()) throw std::runtime_error("ompl-2d/circle_obstacles.txt: no discs");
  scene->robot.push_back(
      RobotBody{.name = "point", .shape = Shape{.type = ShapeType::kSphere, .radius = 0.0}});
  return scene;
}

// The two paths of ompl-2d/circle_paths_to_simplify.txt.
inline std::vector<InputPath> CirclePaths() {
  std::ifstream in = OpenTestData("ompl-2d/circle_paths_to_simplify.txt");
  std::vector<InputPath> paths(1);
  std::string line;
  std::getline(in, line);
  std::getline(in, line);
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    double x, y;
    if (!(fields >> x >> y)) {
      if (!paths.back().waypoints.empty()) paths.emplace_back();
      continue;
    }
    paths.back().waypoints.push_back(Eigen::Vector2d(x, y));
  }
  if (paths.back().waypoints.empty()) paths.pop_back();
  if (paths.size() != 2) {
    throw std::runtime_error("ompl-2d/circle_paths_to_simplify.txt: expected 2 paths");
  }
  for (size_t p = 0; p < paths.size(); ++p) paths[p].name = "ompl" + std::to_string(p);
  return paths;
}

}  // namespace hgraph::testing
