#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <string>

#include "core/adapter/json_io.h"
#include "core/adapter/merge_proto.h"
#include "core/adapter/path_io.h"
#include "core/adapter/scene_proto.h"
#include "core/common/error.h"

namespace hgraph {
namespace {

namespace fs = std::filesystem;

// A unit cube centred on the origin: 8 vertices, 12 triangles.
constexpr const char* kCubeObj = R"(v -0.5 -0.5 -0.5
v 0.5 -0.5 -0.5
v 0.5 0.5 -0.5
v -0.5 0.5 -0.5
v -0.5 -0.5 0.5
v 0.5 -0.5 0.5
v 0.5 0.5 0.5
v -0.5 0.5 0.5
f 1 3 2
f 1 4 3
f 5 6 7
f 5 7 8
f 1 2 6
f 1 6 5
f 2 3 7
f 2 7 6
f 3 4 8
f 3 8 7
f 4 1 5
f 4 5 8
)";

// Runs f and returns the Error it throws; fails the test if it throws none.
Error ErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e;
  }
  ADD_FAILURE() << "expected an hgraph::Error";
  return Error(ErrorCode::kInvalidArgument, "", "none");
}

class TempDir {
 public:
  TempDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = fs::temp_directory_path() /
            ("hgraph_adapter_test_" + std::to_string(getpid()) + "_" + info->name());
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() { fs::remove_all(path_); }
  std::string Write(const std::string& name, const std::string& contents) const {
    const fs::path file = path_ / name;
    fs::create_directories(file.parent_path());
    std::ofstream(file, std::ios::binary) << contents;
    return file.string();
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

v1::Scene PointRobotScene() {
  v1::Scene scene;
  scene.set_name("test");
  v1::Component* c = scene.mutable_space()->add_components();
  c->set_type(v1::Component::TYPE_RN);
  c->set_dimension(2);
  c->add_lower(0);
  c->add_lower(0);
  c->add_upper(10);
  c->add_upper(10);
  v1::RobotBody* body = scene.add_robot();
  body->set_name("point");
  body->mutable_shape()->mutable_sphere()->set_radius(0);
  return scene;
}

v1::Obstacle* AddBox(v1::Scene* scene, double x, double y) {
  v1::Obstacle* o = scene->add_obstacles();
  for (int k = 0; k < 3; ++k) o->mutable_shape()->mutable_box()->add_size(1);
  o->mutable_pose()->add_position(x);
  o->mutable_pose()->add_position(y);
  o->mutable_pose()->add_position(0);
  return o;
}

Eigen::Vector3d MeshExtent(const Mesh& mesh) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const Eigen::Vector3d& v : mesh.vertices) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  return hi - lo;
}

// --- Space and configurations ---

TEST(AdapterTest, SpaceRoundTripKeepsTypesBoundsAndWeights) {
  const Space space({
      ComponentSpec{.type = ComponentType::kSE2,
                    .lower = Eigen::Vector2d(-1, -2),
                    .upper = Eigen::Vector2d(3, 4),
                    .name = "base"},
      ComponentSpec{.type = ComponentType::kRealVector,
                    .dimension = 3,
                    .lower = Eigen::Vector3d(0, 0, 0),
                    .upper = Eigen::Vector3d(1, 1, 1),
                    .translation_weight = 2.0},
      ComponentSpec{.type = ComponentType::kSO3, .rotation_weight = 0.25},
  });
  const Space copy = SpaceFromProto(SpaceToProto(space), "space");
  ASSERT_EQ(copy.num_components(), 3);
  EXPECT_EQ(copy.dimension(), space.dimension());
  EXPECT_EQ(copy.component(0).name, "base");
  EXPECT_EQ(copy.component(1).dimension, 3);
  EXPECT_EQ(copy.component(2).type, ComponentType::kSO3);
  Config a = Config::Zero(space.dimension());
  Config b = Config::Zero(space.dimension());
  a[space.offset(2) + 3] = 1;
  b << 1, 2, 0.5, 0.5, 0.5, 0.5, 0, 0, std::sqrt(0.5), std::sqrt(0.5);
  EXPECT_DOUBLE_EQ(copy.Distance(a, b), space.Distance(a, b));
}

TEST(AdapterTest, SpaceErrorsNameTheProtoField) {
  v1::Space proto;
  proto.add_components();  // type unset
  EXPECT_EQ(ErrorOf([&] { SpaceFromProto(proto, "scene.space"); }).field(),
            "scene.space.components[0].type");

  v1::Component* c = proto.mutable_components(0);
  c->set_type(v1::Component::TYPE_SE2);
  c->add_lower(0);  // SE(2) needs two lower bounds
  c->add_upper(1);
  c->add_upper(1);
  const Error e = ErrorOf([&] { SpaceFromProto(proto, "scene.space"); });
  EXPECT_TRUE(e.field().starts_with("scene.space.components[0].")) << e.what();

  EXPECT_EQ(ErrorOf([] { SpaceFromProto(v1::Space(), "scene.space"); }).field(),
            "scene.space.components");
}

TEST(AdapterTest, ConfigRoundTripIsExact) {
  Config q(3);
  q << 0.1, -2.5e-17, 1e300;
  EXPECT_EQ(ConfigFromProto(ConfigToProto(q)), q);
}

// --- Poses ---

TEST(AdapterTest, PoseDefaultsToIdentityAndNormalisesNearUnitQuaternions) {
  EXPECT_TRUE(PoseFromProto(v1::Pose(), "p").isApprox(Eigen::Isometry3d::Identity()));
  v1::Pose pose;
  for (double v : {1.0, 2.0, 3.0}) pose.add_position(v);
  // 90 degrees about Z, slightly off unit norm.
  const double s = std::sqrt(0.5) * 1.0004;
  for (double v : {0.0, 0.0, s, s}) pose.add_orientation(v);
  const Eigen::Isometry3d p = PoseFromProto(pose, "p");
  EXPECT_TRUE(p.translation().isApprox(Eigen::Vector3d(1, 2, 3)));
  EXPECT_TRUE((p.linear() * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d::UnitY(), 1e-9));
}

TEST(AdapterTest, PoseRejectsNonUnitQuaternionAndBadCounts) {
  v1::Scene scene = PointRobotScene();
  v1::Obstacle* o = AddBox(&scene, 5, 5);
  for (double v : {0.0, 0.0, 0.0, 1.1}) o->mutable_pose()->add_orientation(v);
  const Error e = ErrorOf([&] { SceneFromProto(scene, "", {}); });
  EXPECT_EQ(e.field(), "scene.obstacles[0].pose.orientation");
  EXPECT_NE(std::string(e.what()).find("norm"), std::string::npos) << e.what();

  v1::Pose pose;
  pose.add_position(1);
  EXPECT_EQ(ErrorOf([&] { PoseFromProto(pose, "scene.robot[0].offset"); }).field(),
            "scene.robot[0].offset.position");
}

// --- Scenes ---

TEST(AdapterTest, PrimitivesWithScale) {
  v1::Scene scene = PointRobotScene();
  AddBox(&scene, 5, 5)->mutable_shape()->add_scale(2);
  v1::Obstacle* cylinder = scene.add_obstacles();
  cylinder->set_name("pillar");
  cylinder->mutable_shape()->mutable_cylinder()->set_radius(1);
  cylinder->mutable_shape()->mutable_cylinder()->set_length(2);
  for (double v : {0.5, 0.5, 3.0}) cylinder->mutable_shape()->add_scale(v);
  const auto loaded = SceneFromProto(scene, "", {});
  ASSERT_EQ(loaded->obstacles.size(), 2u);
  EXPECT_EQ(loaded->obstacles[0].shape.type, ShapeType::kBox);
  EXPECT_TRUE(loaded->obstacles[0].shape.box_size.isApprox(Eigen::Vector3d(2, 2, 2)));
  EXPECT_TRUE(loaded->obstacles[0].pose.translation().isApprox(Eigen::Vector3d(5, 5, 0)));
  EXPECT_EQ(loaded->obstacles[0].name, "obstacles[0]");
  EXPECT_EQ(loaded->obstacles[1].name, "pillar");
  EXPECT_DOUBLE_EQ(loaded->obstacles[1].shape.radius, 0.5);
  EXPECT_DOUBLE_EQ(loaded->obstacles[1].shape.length, 6.0);
  EXPECT_EQ(loaded->robot[0].shape.type, ShapeType::kSphere);
  EXPECT_EQ(loaded->robot[0].shape.radius, 0.0);
}

TEST(AdapterTest, ShapeErrorsNameTheField) {
  v1::Scene scene = PointRobotScene();
  v1::Obstacle* o = AddBox(&scene, 5, 5);
  o->mutable_shape()->add_scale(1);
  o->mutable_shape()->add_scale(2);
  EXPECT_EQ(ErrorOf([&] { SceneFromProto(scene, "", {}); }).field(),
            "scene.obstacles[0].shape.scale");

  o->mutable_shape()->clear_scale();
  o->mutable_shape()->mutable_box()->set_size(1, -1);
  EXPECT_EQ(ErrorOf([&] { SceneFromProto(scene, "", {}); }).field(),
            "scene.obstacles[0].shape.box.size[1]");

  o->mutable_shape()->Clear();
  EXPECT_EQ(ErrorOf([&] { SceneFromProto(scene, "", {}); }).field(), "scene.obstacles[0].shape");

  v1::Scene sphere = PointRobotScene();
  for (double v : {1.0, 1.0, 2.0}) sphere.mutable_robot(0)->mutable_shape()->add_scale(v);
  EXPECT_EQ(ErrorOf([&] { SceneFromProto(sphere, "", {}); }).field(), "scene.robot[0].shape.scale");
}

TEST(AdapterTest, RobotAndQueryAreValidatedAgainstTheSpace) {
  v1::Scene scene = PointRobotScene();
  scene.mutable_robot(0)->set_component(1);
  EXPECT_EQ(ErrorOf([&] { SceneFromProto(scene, "", {}); }).field(), "scene.robot[0].component");

  scene = PointRobotScene();
  scene.clear_robot();
  EXPECT_EQ(ErrorOf([&] { SceneFromProto(scene, "", {}); }).field(), "scene.robot");

  scene = PointRobotScene();
  scene.mutable_start()->add_values(1);
  EXPECT_EQ(ErrorOf([&] { SceneFromProto(scene, "", {}); }).field(), "scene.start");

  scene = PointRobotScene();
  for (double v : {1.0, 2.0}) scene.mutable_start()->add_values(v);
  for (double v : {11.0, 2.0}) scene.mutable_goal()->add_values(v);
  EXPECT_EQ(ErrorOf([&] { SceneFromProto(scene, "", {}); }).field(), "scene.goal");

  scene.mutable_goal()->set_values(0, 9);
  const auto loaded = SceneFromProto(scene, "", {});
  ASSERT_TRUE(loaded->start.has_value());
  EXPECT_EQ(*loaded->start, Eigen::Vector2d(1, 2));
  EXPECT_EQ(*loaded->goal, Eigen::Vector2d(9, 2));

  scene.set_resolution(-0.5);
  EXPECT_EQ(ErrorOf([&] { SceneFromProto(scene, "", {}); }).field(), "scene.resolution");
}

TEST(AdapterTest, MeshPathIsRelativeToTheSceneFileAndScaled) {
  const TempDir dir;
  dir.Write("meshes/cube.obj", kCubeObj);
  const std::string scene_file = dir.Write("scene.json", R"({
    "name": "mesh scene",
    "space": {"components": [{"type": "TYPE_RN", "dimension": 2,
                              "lower": [0, 0], "upper": [10, 10]}]},
    "obstacles": [
      {"name": "a", "shape": {"mesh": {"path": "meshes/cube.obj"}, "scale": [2, 3, 4]}},
      {"name": "b", "shape": {"mesh": {"path": "meshes/cube.obj"}, "scale": [2, 3, 4]}}
    ],
    "robot": [{"name": "point", "shape": {"sphere": {"radius": 0}}}],
    "resolution": 0.002
  })");
  const auto scene = LoadSceneFile(scene_file);
  ASSERT_EQ(scene->obstacles.size(), 2u);
  const Shape& shape = scene->obstacles[0].shape;
  EXPECT_EQ(shape.type, ShapeType::kMesh);
  ASSERT_NE(shape.mesh, nullptr);
  EXPECT_EQ(shape.mesh->triangles.size(), 12u);
  EXPECT_TRUE(MeshExtent(*shape.mesh).isApprox(Eigen::Vector3d(2, 3, 4)));
  // One load serves both obstacles.
  EXPECT_EQ(scene->obstacles[1].shape.mesh, shape.mesh);
  EXPECT_DOUBLE_EQ(SceneResolution(ReadSceneFile(scene_file)), 0.002);
  EXPECT_DOUBLE_EQ(SceneResolution(v1::Scene()), 0.01);
}

TEST(AdapterTest, MissingMeshFileIsNotFoundNamingTheField) {
  const TempDir dir;
  v1::Scene scene = PointRobotScene();
  AddBox(&scene, 1, 1);
  v1::Obstacle* o = scene.add_obstacles();
  o->mutable_shape()->mutable_mesh()->set_path("nowhere.obj");
  const Error e = ErrorOf([&] { SceneFromProto(scene, dir.path().string(), {}); });
  EXPECT_EQ(e.code(), ErrorCode::kNotFound);
  EXPECT_EQ(e.field(), "scene.obstacles[1].shape.mesh.path");
  EXPECT_NE(std::string(e.what()).find("nowhere.obj"), std::string::npos) << e.what();
}

TEST(AdapterTest, CorruptMeshIsAnInputError) {
  const TempDir dir;
  dir.Write("bad.stl", "solid nonsense\nthis is not a mesh\n");
  v1::Scene scene = PointRobotScene();
  scene.mutable_robot(0)->mutable_shape()->mutable_mesh()->set_path("bad.stl");
  const Error e = ErrorOf([&] { SceneFromProto(scene, dir.path().string(), {}); });
  EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument);
  EXPECT_EQ(e.field(), "scene.robot[0].shape.mesh.path");
}

TEST(AdapterTest, InlineMeshBytesNeedAFormat) {
  v1::Scene scene = PointRobotScene();
  v1::MeshRef* mesh = scene.add_obstacles()->mutable_shape()->mutable_mesh();
  mesh->set_data(kCubeObj);
  EXPECT_EQ(ErrorOf([&] { SceneFromProto(scene, "", {}); }).field(),
            "scene.obstacles[0].shape.mesh.format");
  mesh->set_format("obj");
  const auto loaded = SceneFromProto(scene, "", {});
  ASSERT_NE(loaded->obstacles[0].shape.mesh, nullptr);
  EXPECT_EQ(loaded->obstacles[0].shape.mesh->vertices.size(), 8u);
}

TEST(AdapterTest, DigestMeshesUseTheResolver) {
  v1::Scene scene = PointRobotScene();
  v1::MeshRef* mesh = scene.add_obstacles()->mutable_shape()->mutable_mesh();
  mesh->mutable_digest()->set_sha256("abc123");
  mesh->set_format("obj");
  EXPECT_EQ(ErrorOf([&] { SceneFromProto(scene, "", {}); }).field(),
            "scene.obstacles[0].shape.mesh.digest");

  const BlobResolver none = [](const v1::Digest&) { return std::optional<std::string>(); };
  const Error missing = ErrorOf([&] { SceneFromProto(scene, "", none); });
  EXPECT_EQ(missing.code(), ErrorCode::kNotFound);
  EXPECT_EQ(missing.field(), "scene.obstacles[0].shape.mesh.digest");

  const BlobResolver store = [](const v1::Digest& d) {
    return d.sha256() == "abc123" ? std::optional<std::string>(kCubeObj) : std::nullopt;
  };
  EXPECT_EQ(SceneFromProto(scene, "", store)->obstacles[0].shape.mesh->triangles.size(), 12u);
}

TEST(AdapterTest, SceneFileRejectsUnknownFieldsNamingTheFile) {
  const TempDir dir;
  const std::string file = dir.Write("scene.json", R"({"name": "x", "obstacle": []})");
  const Error e = ErrorOf([&] { LoadSceneFile(file); });
  EXPECT_EQ(e.field(), file);
  EXPECT_NE(std::string(e.what()).find("obstacle"), std::string::npos) << e.what();

  const Error missing = ErrorOf([&] { LoadSceneFile((dir.path() / "none.json").string()); });
  EXPECT_EQ(missing.code(), ErrorCode::kNotFound);
}

TEST(AdapterTest, TextFilesRoundTripAndTheirErrorsNameThePath) {
  const TempDir dir;
  // Larger than one read of the reader, with every byte value.
  std::string bytes;
  for (int i = 0; i < 200000; ++i) bytes.push_back(static_cast<char>(i * 7919 % 256));
  const std::string file = (dir.path() / "bytes.bin").string();
  WriteTextFile(file, bytes);
  EXPECT_EQ(ReadTextFile(file), bytes);
  WriteTextFile(file, "");
  EXPECT_EQ(ReadTextFile(file), "");

  const std::string none = (dir.path() / "none.json").string();
  const Error missing = ErrorOf([&] { ReadTextFile(none); });
  EXPECT_EQ(missing.code(), ErrorCode::kNotFound);
  EXPECT_EQ(missing.field(), none);
  EXPECT_STREQ(missing.what(), (none + ": cannot open: No such file or directory").c_str());
  // A path through a file is not missing: it cannot be opened.
  const std::string through = file + "/x";
  const Error not_dir = ErrorOf([&] { ReadTextFile(through); });
  EXPECT_EQ(not_dir.code(), ErrorCode::kFailedPrecondition);
  EXPECT_STREQ(not_dir.what(), (through + ": cannot open: Not a directory").c_str());
  // A directory opens, and its read fails: an error, not an empty document.
  const Error directory = ErrorOf([&] { ReadTextFile(dir.path().string()); });
  EXPECT_EQ(directory.code(), ErrorCode::kFailedPrecondition);
  EXPECT_STREQ(directory.what(), (dir.path().string() + ": read failed").c_str());
}

TEST(AdapterTest, ToJsonUsesSnakeCaseAndPrintsDefaults) {
  const std::string json = ToJson(PointRobotScene());
  EXPECT_NE(json.find("\"self_collision\": false"), std::string::npos) << json;
  EXPECT_NE(json.find("\"resolution\": 0"), std::string::npos) << json;
  v1::Scene back;
  ParseJson(json, "round trip", &back);
  EXPECT_EQ(back.SerializeAsString(), PointRobotScene().SerializeAsString());
}

// --- Paths ---

TEST(AdapterTest, OmplTextFormatWithCommentsAndBlankLines) {
  const Space space = Space::RealVector(Eigen::Vector2d(0, 0), Eigen::Vector2d(10, 10));
  const std::vector<InputPath> paths = ParsePathsText(
      "# header\n\n# first\n1 2\n  3\t4.5   # trailing comment\n\n\n+5 6e-1\n# not a separator\n7 "
      "8\n\n",
      "p.txt", space);
  ASSERT_EQ(paths.size(), 2u);
  EXPECT_EQ(paths[0].name, "first");
  EXPECT_EQ(paths[1].name, "path1");
  ASSERT_EQ(paths[0].waypoints.size(), 2u);
  ASSERT_EQ(paths[1].waypoints.size(), 2u);
  EXPECT_EQ(paths[0].waypoints[1], Eigen::Vector2d(3, 4.5));
  EXPECT_EQ(paths[1].waypoints[0], Eigen::Vector2d(5, 0.6));
  EXPECT_EQ(paths[1].waypoints[1], Eigen::Vector2d(7, 8));
}

TEST(AdapterTest, OmplTextErrorsNameFileAndLine) {
  const Space space = Space::RealVector(Eigen::Vector2d(0, 0), Eigen::Vector2d(10, 10));
  Error e = ErrorOf([&] { ParsePathsText("1 2\n3 x4\n", "p.txt", space); });
  EXPECT_EQ(e.field(), "p.txt:2");
  EXPECT_NE(std::string(e.what()).find("'x4' is not a number"), std::string::npos) << e.what();
  EXPECT_EQ(ErrorOf([&] { ParsePathsText("1 2 3\n", "p.txt", space); }).field(), "p.txt:1");
  EXPECT_EQ(ErrorOf([&] { ParsePathsText("\n1 nan\n", "p.txt", space); }).field(), "p.txt:2");
}

TEST(AdapterTest, PathsFileRoundTripsInBothFormats) {
  const TempDir dir;
  const Space space = Space::RealVector(Eigen::Vector2d(0, 0), Eigen::Vector2d(10, 10));
  std::vector<InputPath> paths(2);
  paths[0].name = "a";
  paths[0].waypoints = {Eigen::Vector2d(0.1, 1.0 / 3.0), Eigen::Vector2d(9.999999999999, 5)};
  paths[1].name = "b";
  paths[1].waypoints = {Eigen::Vector2d(0.1, 1.0 / 3.0), Eigen::Vector2d(2, 2),
                        Eigen::Vector2d(9.999999999999, 5)};
  for (const std::string name : {"paths.json", "paths.txt"}) {
    const std::string file = (dir.path() / name).string();
    WritePathsFile(file, paths, space);
    const std::vector<InputPath> back = LoadPathsFile(file, space);
    ASSERT_EQ(back.size(), 2u) << name;
    for (size_t p = 0; p < 2; ++p) {
      EXPECT_EQ(back[p].name, paths[p].name) << name;
      ASSERT_EQ(back[p].waypoints.size(), paths[p].waypoints.size()) << name;
      for (size_t i = 0; i < back[p].waypoints.size(); ++i) {
        EXPECT_EQ(back[p].waypoints[i], paths[p].waypoints[i]) << name;
      }
    }
  }
}

TEST(AdapterTest, PathSetJsonNamesUnnamedPaths) {
  const TempDir dir;
  const Space space = Space::RealVector(Eigen::Vector2d(0, 0), Eigen::Vector2d(10, 10));
  const std::string file = dir.Write(
      "p.json", R"(  {"paths": [{"waypoints": [{"values": [1, 2]}, {"values": [3, "NaN"]}]}]})");
  const std::vector<InputPath> paths = LoadPathsFile(file, space);
  ASSERT_EQ(paths.size(), 1u);
  EXPECT_EQ(paths[0].name, "path0");
  EXPECT_TRUE(std::isnan(paths[0].waypoints[1][1]));  // HGraph rejects it, naming the waypoint

  const std::string bad = dir.Write("bad.json", R"({"paths": [{"points": []}]})");
  EXPECT_EQ(ErrorOf([&] { LoadPathsFile(bad, space); }).field(), bad);
}

// --- Merge messages ---

TEST(AdapterTest, MeasureDefaultsAndErrors) {
  v1::Measure proto;
  MeasureSpec spec = MeasureFromProto(proto);
  EXPECT_EQ(spec.type, MeasureType::kLength);
  EXPECT_EQ(spec.k, MeasureSpec().k);
  proto.set_type(v1::Measure::TYPE_SAFE_LENGTH);
  proto.set_k(0);
  proto.set_safety(0.5);
  spec = MeasureFromProto(proto);
  EXPECT_EQ(spec.type, MeasureType::kSafeLength);
  EXPECT_EQ(spec.k, 0);
  EXPECT_EQ(spec.safety, 0.5);
  const MeasureSpec back = MeasureFromProto(MeasureToProto(spec));
  EXPECT_EQ(back.type, spec.type);

  proto.set_k(-1);
  EXPECT_EQ(ErrorOf([&] { MeasureFromProto(proto); }).field(), "measure.k");
  proto.set_k(3);
  proto.set_safety(-0.1);
  EXPECT_EQ(ErrorOf([&] { MeasureFromProto(proto); }).field(), "measure.safety");
}

TEST(AdapterTest, MergeOptionsDefaultsAndErrors) {
  v1::MergeOptions proto;
  MergeOptions options = MergeOptionsFromProto(proto);
  EXPECT_EQ(options.candidates.variant, Variant::kEditDistance);
  EXPECT_EQ(options.candidates.radius, CandidateOptions().radius);
  EXPECT_EQ(options.candidates.gap_init, CandidateOptions().gap_init);
  EXPECT_EQ(options.endpoint_tolerance, MergeOptions().endpoint_tolerance);
  EXPECT_EQ(options.max_node_spacing, 0);
  EXPECT_EQ(options.check_mode, CheckMode::kCertified);
  proto.set_check_mode(v1::CHECK_MODE_SAMPLED);
  EXPECT_EQ(MergeOptionsFromProto(proto).check_mode, CheckMode::kSampled);
  proto.set_check_mode(v1::CHECK_MODE_CERTIFIED);
  EXPECT_EQ(MergeOptionsFromProto(proto).check_mode, CheckMode::kCertified);

  proto.set_max_node_spacing(-0.5);
  EXPECT_EQ(ErrorOf([&] { MergeOptionsFromProto(proto); }).field(), "options.max_node_spacing");
  proto.set_max_node_spacing(0.25);
  EXPECT_EQ(MergeOptionsFromProto(proto).max_node_spacing, 0.25);
  proto.set_variant(v1::VARIANT_K_NEAREST);
  proto.set_phi(7);
  proto.set_radius(2.5);
  proto.set_gap_init(0);
  proto.set_threads(3);
  options = MergeOptionsFromProto(proto);
  EXPECT_EQ(options.candidates.variant, Variant::kKNearest);
  EXPECT_EQ(options.candidates.phi, 7);
  EXPECT_EQ(options.candidates.radius, 2.5);
  EXPECT_EQ(options.candidates.gap_init, 0);
  EXPECT_EQ(options.threads, 3);

  for (const auto& [set, field] :
       std::vector<std::pair<std::function<void(v1::MergeOptions*)>, std::string>>{
           {[](v1::MergeOptions* o) { o->set_radius(-1); }, "options.radius"},
           {[](v1::MergeOptions* o) { o->set_phi(0); }, "options.phi"},
           {[](v1::MergeOptions* o) { o->set_gap_extend(-1); }, "options.gap_extend"},
           {[](v1::MergeOptions* o) { o->set_resolution(-0.01); }, "options.resolution"},
           {[](v1::MergeOptions* o) { o->set_threads(-2); }, "options.threads"},
           // A value from a newer client (proto3 enums are open): refused, not read as certified.
           {[](v1::MergeOptions* o) { o->set_check_mode(static_cast<v1::CheckMode>(7)); },
            "options.check_mode"},
       }) {
    v1::MergeOptions bad;
    set(&bad);
    EXPECT_EQ(ErrorOf([&] { MergeOptionsFromProto(bad); }).field(), field);
  }
}

TEST(AdapterTest, ResolutionPrefersTheOptionThenTheScene) {
  v1::Scene scene;
  v1::MergeOptions options;
  EXPECT_DOUBLE_EQ(ResolutionFromProto(options, scene), 0.01);
  scene.set_resolution(0.003);
  EXPECT_DOUBLE_EQ(ResolutionFromProto(options, scene), 0.003);
  options.set_resolution(0.05);
  EXPECT_DOUBLE_EQ(ResolutionFromProto(options, scene), 0.05);
}

TEST(AdapterTest, MergeResultToProtoAndJson) {
  MergeResult result;
  result.path.name = "merged";
  result.path.waypoints = {Eigen::Vector2d(0, 0), Eigen::Vector2d(1, 1)};
  result.quality = PathQuality{.length = 1.5,
                               .min_clearance = 0.25,
                               .avg_clearance = 0.5,
                               .inverse_clearance = 7,
                               .k = 3,
                               .has_clearance = true};
  result.inputs.push_back(InputReport{.name = "a",
                                      .valid = false,
                                      .invalid_edge = 2,
                                      .invalid_reason = "collision",
                                      .waypoints = 4});
  result.stats.nodes = 12;
  result.stats.collision_checks = 1234567890123;
  result.timing.total_ms = 8.5;
  result.source_path = {0, 0};
  result.source_index = {0, 3};
  result.source_fraction = {0, 0.5};
  result.variant = Variant::kNeighborhood;
  result.best_input = 0;
  result.objective = 1.5;

  const v1::MergeResult proto = MergeResultToProto(result);
  EXPECT_EQ(proto.path().waypoints_size(), 2);
  EXPECT_EQ(proto.quality().min_clearance(), 0.25);
  EXPECT_EQ(proto.inputs(0).invalid_edge(), 2);
  EXPECT_EQ(proto.stats().collision_checks(), 1234567890123);
  EXPECT_EQ(proto.variant(), v1::VARIANT_NEIGHBORHOOD);
  EXPECT_EQ(proto.source_index(1), 3);
  EXPECT_EQ(proto.source_fraction(1), 0.5);

  const std::string json = ToJson(proto);
  for (const char* key :
       {"\"min_clearance\": 0.25", "\"avg_clearance\": 0.5", "\"inverse_clearance\": 7",
        "\"invalid_reason\": \"collision\"", "\"total_ms\": 8.5", "\"edges_reused\""}) {
    EXPECT_NE(json.find(key), std::string::npos) << key << "\n" << json;
  }

  // And back: where each merged waypoint came from survives the round trip.
  const MergeResult back = MergeResultFromProto(proto);
  EXPECT_EQ(back.source_path, result.source_path);
  EXPECT_EQ(back.source_index, result.source_index);
  EXPECT_EQ(back.source_fraction, result.source_fraction);
  EXPECT_EQ(back.best_input, 0);
  EXPECT_EQ(back.objective, 1.5);
  EXPECT_TRUE(back.quality.has_clearance);
  EXPECT_EQ(back.quality.min_clearance, 0.25);
}

// The result says how its path was checked, so that a sampled path never reads as certified:
// check_mode echoed and `certified` set (with presence) either way, and a reader takes either
// field saying sampled as sampled.
TEST(AdapterTest, MergeResultSaysWhetherItsPathIsCertified) {
  MergeResult result;
  v1::MergeResult proto = MergeResultToProto(result);
  EXPECT_EQ(proto.check_mode(), v1::CHECK_MODE_CERTIFIED);
  ASSERT_TRUE(proto.has_certified());
  EXPECT_TRUE(proto.certified());
  EXPECT_EQ(MergeResultFromProto(proto).check_mode, CheckMode::kCertified);

  result.check_mode = CheckMode::kSampled;
  proto = MergeResultToProto(result);
  EXPECT_EQ(proto.check_mode(), v1::CHECK_MODE_SAMPLED);
  ASSERT_TRUE(proto.has_certified());
  EXPECT_FALSE(proto.certified());
  EXPECT_NE(ToJson(proto).find("\"certified\": false"), std::string::npos) << ToJson(proto);
  EXPECT_EQ(MergeResultFromProto(proto).check_mode, CheckMode::kSampled);
  proto.clear_check_mode();
  EXPECT_EQ(MergeResultFromProto(proto).check_mode, CheckMode::kSampled);
  proto.set_check_mode(v1::CHECK_MODE_SAMPLED);
  proto.clear_certified();
  EXPECT_EQ(MergeResultFromProto(proto).check_mode, CheckMode::kSampled);
  // A server older than both fields certified every merged path.
  proto.clear_check_mode();
  EXPECT_EQ(MergeResultFromProto(proto).check_mode, CheckMode::kCertified);
}

TEST(AdapterTest, QualityFromAServerBeforeHasClearanceKeepsItsClearances) {
  // Such a server sent clearances without has_clearance; today's sends 0 when unknown.
  v1::PathQuality older;
  older.set_length(2);
  older.set_min_clearance(0.125);
  older.set_avg_clearance(0.5);
  EXPECT_TRUE(QualityFromProto(older).has_clearance);
  v1::PathQuality unknown;
  unknown.set_length(2);
  EXPECT_FALSE(QualityFromProto(unknown).has_clearance);
  unknown.set_has_clearance(true);
  EXPECT_TRUE(QualityFromProto(unknown).has_clearance);
}

}  // namespace
}  // namespace hgraph
