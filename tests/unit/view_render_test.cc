// The 3D view's document: which stretch of a merged path is whose, the data each path carries,
// meshes written once and refused above the limit, text that cannot break out of the page, and
// the errors. That a browser draws it is checked in tests/view (headless Chromium).
#include "core/render/view_render.h"

#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "core/common/error.h"

namespace hgraph {
namespace {

int Count(const std::string& text, const std::string& what) {
  int n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

std::shared_ptr<const Mesh> Tetrahedron() {
  auto mesh = std::make_shared<Mesh>();
  mesh->vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  mesh->triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  return mesh;
}

// Two SE(3) bodies (a product space) among two obstacles that share one mesh.
Scene TwoBodyScene() {
  Scene scene{.name = "two bodies",
              .space = Space({ComponentSpec{.type = ComponentType::kSE3,
                                            .lower = Eigen::Vector3d(-5, -5, -5),
                                            .upper = Eigen::Vector3d(5, 5, 5)},
                              ComponentSpec{.type = ComponentType::kSE3,
                                            .lower = Eigen::Vector3d(-5, -5, -5),
                                            .upper = Eigen::Vector3d(5, 5, 5)}})};
  const std::shared_ptr<const Mesh> mesh = Tetrahedron();
  for (double x : {-2.0, 2.0}) {
    Obstacle o{.name = "tet",
               .shape = Shape{.type = ShapeType::kMesh, .mesh = mesh, .source = "tet.obj"}};
    o.pose.translation() = Eigen::Vector3d(x, 0, 0);
    scene.obstacles.push_back(o);
  }
  scene.robot.push_back(RobotBody{
      .name = "a", .shape = Shape{.type = ShapeType::kBox, .box_size = Eigen::Vector3d(1, 1, 1)}});
  scene.robot.push_back(
      RobotBody{.name = "b",
                .shape = Shape{.type = ShapeType::kCylinder, .radius = 0.3, .length = 1},
                .component = 1});
  return scene;
}

Config TwoBodies(double x1, double x2) {
  Config q(14);
  q << x1, 0, 0, 0, 0, 0, 1, x2, 1, 0, 0, 0, 0, 1;
  return q;
}

TEST(ViewRenderTest, StretchesAreNamedByInputBridgeAndShortcut) {
  const std::vector<WaypointSource> sources = {
      {.path = 0, .index = 0},           {.path = 0, .index = 1},  // input 0's edge 0
      {.path = 0, .index = 1, .t = 0.5},                           // on its edge 1 (subdivision)
      {.path = 1, .index = 4},                                     // a bridge to input 1
      {.path = 1, .index = 3},                                     // input 1's edge 3, backwards
      {.path = -1, .index = -1},                                   // a shortcut's end
      {.path = 1, .index = 9},                                     // from the shortcut
      {.path = 1, .index = 7},                                     // two edges apart: a bridge
  };
  EXPECT_EQ(StretchSources(sources), (std::vector<int>{0, 0, kBridgeStretch, 1, kShortcutStretch,
                                                       kShortcutStretch, kBridgeStretch}));
  EXPECT_TRUE(StretchSources({}).empty());
  // The shared start and goal, reported from input 0, lie on input 1 too: its first and last
  // edges are input 1's, not bridges. Without the inputs' sizes only the start is known.
  const std::vector<WaypointSource> ends = {{.path = 0, .index = 0},
                                            {.path = 1, .index = 1},
                                            {.path = 1, .index = 5},
                                            {.path = 1, .index = 6},
                                            {.path = 0, .index = 9}};
  EXPECT_EQ(StretchSources(ends, {10, 8}), (std::vector<int>{1, kBridgeStretch, 1, 1}));
  EXPECT_EQ(StretchSources(ends), (std::vector<int>{1, kBridgeStretch, 1, kBridgeStretch}));
}

TEST(ViewRenderTest, DocumentCarriesEveryPathAndEachMeshOnce) {
  const Scene scene = TwoBodyScene();
  ViewRequest request;
  request.inputs.push_back(RenderPath{
      .path = InputPath{.name = "in0", .waypoints = {TwoBodies(-4, -3), TwoBodies(4, 3)}}});
  request.merged = RenderPath{
      .path = InputPath{.name = "merged",
                        .waypoints = {TwoBodies(-4, -3), TwoBodies(0, 0), TwoBodies(4, 3)}}};
  request.sources = {{.path = 0, .index = 0}, {.path = -1}, {.path = 0, .index = 1}};
  request.measure = "length";
  request.objective = 16.5;
  request.rounds = {{.round = 0, .elapsed_ms = 1, .objective = 17},
                    {.round = 1, .elapsed_ms = 2, .objective = 16.5}};
  request.frames = 10;
  const std::string html = RenderViewHtml(scene, request);
  EXPECT_EQ(html.rfind("<!DOCTYPE html>", 0), 0u);
  EXPECT_EQ(Count(html, "\"positions\":"), 1) << "the shared mesh is written once";
  EXPECT_EQ(Count(html, "\"type\":\"mesh\""), 2);
  EXPECT_EQ(Count(html, "\"type\":\"cylinder\""), 1);
  EXPECT_EQ(Count(html, "\"frame_count\":10"), 2);
  // Two bodies, two components: one trace per component.
  EXPECT_NE(html.find("\"segment_sources\":[-1,-1]"), std::string::npos);
  EXPECT_NE(html.find("\"objective\":16.5"), std::string::npos);
  EXPECT_EQ(Count(html, "\"round\":"), 2);
  EXPECT_NE(html.find("\"planar\":false"), std::string::npos);
  EXPECT_EQ(Count(html, "<script src="), 0) << "nothing is loaded from elsewhere";
}

TEST(ViewRenderTest, NamesCannotEndTheDataScript) {
  Scene scene = TwoBodyScene();
  scene.obstacles[0].name = "</script><script>alert(1)</script>";
  ViewRequest request;
  request.inputs.push_back(RenderPath{
      .path = InputPath{.name = "<b>", .waypoints = {TwoBodies(0, 0), TwoBodies(1, 1)}}});
  const std::string html = RenderViewHtml(scene, request);
  EXPECT_EQ(html.find("alert(1)</script>"), std::string::npos);
  EXPECT_NE(html.find("\\u003c/script>\\u003cscript>alert(1)"), std::string::npos);
}

TEST(ViewRenderTest, BadRequestsNameTheField) {
  const Scene scene = TwoBodyScene();
  const InputPath path{.name = "p", .waypoints = {TwoBodies(0, 0), TwoBodies(1, 1)}};
  const auto field_of = [&](const ViewRequest& request) {
    try {
      RenderViewHtml(scene, request);
    } catch (const InputError& e) {
      return e.field() + " | " + e.what();
    }
    return std::string("no error");
  };
  ViewRequest too_small{.inputs = {RenderPath{.path = path}}, .max_mesh_triangles = 3};
  const std::string mesh = field_of(too_small);
  EXPECT_EQ(mesh.rfind("scene.obstacles[0] |", 0), 0u) << mesh;
  EXPECT_NE(mesh.find("tet.obj"), std::string::npos) << mesh;
  EXPECT_NE(mesh.find("4 triangles"), std::string::npos) << mesh;
  EXPECT_NE(mesh.find("limit of 3"), std::string::npos) << mesh;

  ViewRequest sources{.merged = RenderPath{.path = path}, .sources = {{.path = 0}}};
  EXPECT_EQ(field_of(sources).rfind("request.sources |", 0), 0u);
  ViewRequest frames{.inputs = {RenderPath{.path = path}}, .frames = 1};
  EXPECT_EQ(field_of(frames).rfind("request.frames |", 0), 0u);
  InputPath short_path = path;
  short_path.waypoints[1] = Config::Zero(7);
  ViewRequest dimension{.inputs = {RenderPath{.path = short_path}}};
  EXPECT_EQ(field_of(dimension).rfind("request.inputs[0].waypoints[1] |", 0), 0u)
      << field_of(dimension);
}

}  // namespace
}  // namespace hgraph
