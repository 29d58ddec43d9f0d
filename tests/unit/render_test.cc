// SVG pictures: structure of the document, what is drawn for which robot, and the errors. That
// librsvg renders the pictures is checked end to end in tests/integration/picture_test.py.
#include <gtest/gtest.h>

#include <sstream>
#include <string>
#include <vector>

#include "core/collision/collision_world.h"
#include "core/common/error.h"
#include "core/merge/merge.h"
#include "core/motion/local_planner.h"
#include "core/render/svg_render.h"
#include "tests/unit/test_scenes.h"

namespace hgraph {
namespace {

int Count(const std::string& text, const std::string& what) {
  int n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

// A bar rotating through a gap between two boxes (SE(2)).
Scene BarScene() {
  Scene scene{.name = "bar & gap",
              .space = Space::SE2(Eigen::Vector2d(0, 0), Eigen::Vector2d(10, 10))};
  for (double x : {2.0, 8.0}) {
    Obstacle wall{.name = "wall",
                  .shape = Shape{.type = ShapeType::kBox, .box_size = Eigen::Vector3d(4, 1, 1)}};
    wall.pose.translation() = Eigen::Vector3d(x, 5, 0);
    scene.obstacles.push_back(wall);
  }
  scene.robot.push_back(RobotBody{
      .name = "bar",
      .shape = Shape{.type = ShapeType::kBox, .box_size = Eigen::Vector3d(1.5, 0.3, 0.3)}});
  return scene;
}

// The points of the first polyline drawn in `colour` (pixel coordinates).
std::vector<Eigen::Vector2d> PolylineOfColour(const std::string& svg, const std::string& colour) {
  const std::string tag = "<polyline points=\"";
  for (size_t at = svg.find(tag); at != std::string::npos; at = svg.find(tag, at + 1)) {
    const size_t end = svg.find("/>", at);
    const std::string element = svg.substr(at, end - at);
    if (element.find("stroke=\"" + colour + "\"") == std::string::npos) continue;
    std::istringstream in(element.substr(tag.size(), element.find('"', tag.size()) - tag.size()));
    std::vector<Eigen::Vector2d> points;
    double x = 0, y = 0;
    char comma = 0;
    while (in >> x >> comma >> y) points.emplace_back(x, y);
    return points;
  }
  return {};
}

// The picture `hgraph merge --svg` draws: the inputs with their reported quality, the merged path.
RenderRequest MergeRenderRequest(const std::vector<InputPath>& inputs, const MergeResult& result) {
  RenderRequest request;
  for (size_t i = 0; i < inputs.size(); ++i) {
    request.inputs.push_back(RenderPath{.path = inputs[i], .quality = result.inputs[i].quality});
  }
  request.merged = RenderPath{.path = result.path, .quality = result.quality};
  request.merged->path.name = "merged";
  return request;
}

InputPath Path(const std::string& name, std::vector<Eigen::Vector3d> points) {
  InputPath path{.name = name};
  for (const auto& p : points) path.waypoints.push_back(p);
  return path;
}

TEST(RenderTest, MergeOfCirclesHasEveryLayer) {
  const auto scene = testing::CirclesScene();
  const auto world = std::make_shared<const CollisionWorld>(scene);
  LocalPlanner planner(world, LocalPlannerOptions{.resolution = 0.005});
  const std::vector<InputPath> inputs = testing::CirclePaths();
  const MergeResult result = Merge(planner, MergeRequest{.paths = inputs});

  const std::string svg = RenderSvg(*scene, MergeRenderRequest(inputs, result));
  EXPECT_TRUE(svg.starts_with("<?xml"));
  EXPECT_TRUE(svg.ends_with("</svg>\n"));
  EXPECT_EQ(Count(svg, "<svg "), 1);
  // One path element per disc, the inputs grey, the merged path red, once each in the legend.
  EXPECT_EQ(Count(svg, "<path d="), static_cast<int>(scene->obstacles.size()));
  EXPECT_EQ(Count(svg, "stroke=\"#a0a0a0\""), 2 * static_cast<int>(inputs.size()));
  EXPECT_EQ(Count(svg, "stroke=\"#d62728\""), 2);
  // The legend carries the merge's numbers; a point robot has no footprint entry.
  char length[32];
  std::snprintf(length, sizeof(length), "length %.4g", result.quality.length);
  EXPECT_NE(svg.find(length), std::string::npos) << length;
  EXPECT_NE(svg.find(">merged<"), std::string::npos);
  EXPECT_EQ(svg.find(">robot<"), std::string::npos);
}

TEST(RenderTest, RotatingRobotIsDrawnAlongTheMergedPath) {
  const Scene scene = BarScene();
  const InputPath input = Path("in", {{5, 2, 0}, {5, 8, 1.5}});
  RenderRequest request{
      .inputs = {RenderPath{.path = input}}, .merged = RenderPath{.path = input}, .footprints = 7};
  const std::string svg = RenderSvg(scene, request);
  // One more for the legend's swatch.
  EXPECT_EQ(Count(svg, "fill=\"#1f77b4\" fill-opacity"), 7 + 1);
  EXPECT_NE(svg.find("bar &amp; gap"), std::string::npos) << "names are escaped";
  // Without a result the legend computes the length with the space's metric (translation 6,
  // rotation 0.5 * 1.5) and says nothing about clearance.
  EXPECT_NE(svg.find("length 6.75"), std::string::npos);
  EXPECT_NE(svg.find("min clearance n/a"), std::string::npos);

  request.footprints = 0;
  EXPECT_EQ(Count(RenderSvg(scene, request), "fill=\"#1f77b4\" fill-opacity"), 2 + 1)
      << "start and goal only";
}

TEST(RenderTest, TranslatingRobotIsDrawnAtStartAndGoalOnly) {
  Scene scene{.name = "square",
              .space = Space::RealVector(Eigen::Vector2d(0, 0), Eigen::Vector2d(10, 10))};
  scene.robot.push_back(RobotBody{.name = "square", .shape = Shape{.type = ShapeType::kBox}});
  InputPath path{.name = "p"};
  path.waypoints = {Eigen::Vector2d(1, 1), Eigen::Vector2d(5, 5), Eigen::Vector2d(9, 9)};
  const std::string svg =
      RenderSvg(scene, RenderRequest{.merged = RenderPath{.path = path}, .footprints = 9});
  EXPECT_EQ(Count(svg, "fill=\"#1f77b4\" fill-opacity"), 2 + 1);
}

TEST(RenderTest, MeshTrianglesAreTurnedToOneWinding) {
  // A unit cube seen from above: its top and bottom faces project with opposite windings; with
  // the nonzero rule they would cancel unless every triangle is turned the same way.
  auto mesh = std::make_shared<Mesh>();
  for (int i = 0; i < 8; ++i) mesh->vertices.emplace_back(i & 1, (i >> 1) & 1, (i >> 2) & 1);
  mesh->triangles = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}};  // bottom (down), top (up)
  Scene scene{.name = "cube",
              .space = Space::RealVector(Eigen::Vector2d(0, 0), Eigen::Vector2d(4, 4))};
  scene.obstacles.push_back(Obstacle{.shape = Shape{.type = ShapeType::kMesh, .mesh = mesh}});
  scene.robot.push_back(RobotBody{.shape = Shape{.type = ShapeType::kSphere, .radius = 0}});
  const std::string svg = RenderSvg(
      scene,
      RenderRequest{
          .inputs = {RenderPath{
              .path = InputPath{
                  .name = "p", .waypoints = {Eigen::Vector2d(3, 3), Eigen::Vector2d(3.5, 3.5)}}}}});
  const size_t at = svg.find("<path d=\"");
  ASSERT_NE(at, std::string::npos);
  const std::string d = svg.substr(at + 9, svg.find('"', at + 9) - at - 9);
  EXPECT_EQ(Count(d, "M"), 4);
  // Each triangle is "Mx0 y0Lx1 y1Lx2 y2Z"; all four must wind the same way.
  int positive = 0;
  for (size_t m = d.find('M'); m != std::string::npos; m = d.find('M', m + 1)) {
    double x[3], y[3];
    ASSERT_EQ(std::sscanf(d.c_str() + m, "M%lf %lfL%lf %lfL%lf %lfZ", &x[0], &y[0], &x[1], &y[1],
                          &x[2], &y[2]),
              6);
    positive += ((x[1] - x[0]) * (y[2] - y[0]) - (y[1] - y[0]) * (x[2] - x[0])) > 0;
  }
  EXPECT_TRUE(positive == 0 || positive == 4) << positive;
}

TEST(RenderTest, PlanesProjectTheRightAxes) {
  EXPECT_EQ(ParsePlane("xy", "f"), Plane::kXY);
  EXPECT_EQ(ParsePlane("xz", "f"), Plane::kXZ);
  EXPECT_EQ(ParsePlane("yz", "f"), Plane::kYZ);
  try {
    ParsePlane("top", "--plane");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "--plane: plane must be xy, xz or yz, got 'top'");
  }
  // A 3D scene seen from the side still renders (a 2D view of the z range).
  Scene scene{.name = "s", .space = Space::SE3(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(4, 4, 2))};
  scene.robot.push_back(
      RobotBody{.shape = Shape{.type = ShapeType::kCylinder, .radius = 0.2, .length = 1}});
  // The motion moves (2, 0.5, 1) in (x, y, z): each plane sees another pair of those, so the
  // drawn segment's slope tells which axes were projected (the view keeps the aspect ratio,
  // the first axis points right and the second up).
  Eigen::VectorXd a(7), b(7);
  a << 1, 1, 0.5, 0, 0, 0, 1;
  b << 3, 1.5, 1.5, 0, 0.7071067811865476, 0, 0.7071067811865476;
  InputPath path{.name = "p", .waypoints = {a, b}};
  const std::vector<std::pair<Plane, Eigen::Vector2d>> expected = {
      {Plane::kXY, {2, 0.5}}, {Plane::kXZ, {2, 1}}, {Plane::kYZ, {0.5, 1}}};
  for (const auto& [plane, step] : expected) {
    SCOPED_TRACE(PlaneName(plane));
    const std::string svg =
        RenderSvg(scene, RenderRequest{.merged = RenderPath{.path = path}, .plane = plane});
    EXPECT_NE(svg.find(std::string("(") + PlaneName(plane) + " plane)"), std::string::npos);
    const std::vector<Eigen::Vector2d> points = PolylineOfColour(svg, "#d62728");
    ASSERT_EQ(points.size(), 2u);
    const Eigen::Vector2d d = points[1] - points[0];
    EXPECT_GT(d.x(), 0) << "the first axis points right";
    EXPECT_LT(d.y(), 0) << "the second axis points up";
    EXPECT_NEAR(-d.y() / d.x(), step.y() / step.x(), 0.01 * step.y() / step.x());
  }
}

TEST(RenderTest, BadRequestsNameTheField) {
  const Scene scene = BarScene();
  InputPath bad{.name = "bad"};
  bad.waypoints = {Eigen::Vector2d(1, 1)};
  try {
    RenderSvg(scene, RenderRequest{.inputs = {RenderPath{.path = bad}}});
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "request.inputs[0].waypoints[0]");
  }
  try {
    RenderSvg(scene, RenderRequest{.width_px = 10});
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "request.width_px");
  }
}

}  // namespace
}  // namespace hgraph
