// OMPL.app problem import: the conventions of ompl_cfg.h, checked against assimp's default
// import (what OMPL.app itself sees) on the problem in tests/data/ompl_app.
#include "core/adapter/ompl_cfg.h"

#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <google/protobuf/io/coded_stream.h>
#include <google/protobuf/io/zero_copy_stream_impl_lite.h>
#include <gtest/gtest.h>

#include <assimp/Importer.hpp>
#include <filesystem>
#include <fstream>

#include "core/adapter/json_io.h"
#include "core/adapter/path_io.h"
#include "core/adapter/scene_proto.h"
#include "core/common/error.h"

namespace hgraph {
namespace {

namespace fs = std::filesystem;

const std::string kDir = std::string(HGRAPH_SOURCE_DIR) + "/tests/data/ompl_app";
const std::string kCfg = kDir + "/wall_planar.cfg";

struct Box3 {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300);
  Eigen::Vector3d hi = Eigen::Vector3d::Constant(-1e300);
  void Add(const Eigen::Vector3d& v) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
};

void AddNode(const aiScene& scene, const aiNode& node, const aiMatrix4x4& parent, Box3* box) {
  const aiMatrix4x4 t = parent * node.mTransformation;
  for (unsigned i = 0; i < node.mNumMeshes; ++i) {
    const aiMesh& mesh = *scene.mMeshes[node.mMeshes[i]];
    for (unsigned k = 0; k < mesh.mNumVertices; ++k) {
      const aiVector3D v = t * mesh.mVertices[k];
      box->Add(Eigen::Vector3d(v.x, v.y, v.z));
    }
  }
  for (unsigned c = 0; c < node.mNumChildren; ++c) AddNode(scene, *node.mChildren[c], t, box);
}

// The mesh's bounding box as OMPL.app loads it: assimp defaults (up axis converted), node
// transforms applied.
Box3 AssimpDefaultBox(const std::string& path) {
  Assimp::Importer importer;
  const aiScene* scene = importer.ReadFile(path, aiProcess_Triangulate);
  EXPECT_NE(scene, nullptr) << importer.GetErrorString();
  Box3 box;
  if (scene != nullptr) AddNode(*scene, *scene->mRootNode, aiMatrix4x4(), &box);
  return box;
}

Box3 PlacedBox(const Shape& shape, const Eigen::Isometry3d& pose) {
  Box3 box;
  for (const Eigen::Vector3d& v : shape.mesh->vertices) box.Add(pose * v);
  return box;
}

void ExpectNear(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const std::string& what) {
  EXPECT_LT((a - b).norm(), 1e-5) << what << ": " << a.transpose() << " vs " << b.transpose();
}

TEST(OmplCfgTest, PlanarProblemFollowsOmplAppConventions) {
  const v1::Scene proto = ReadOmplAppProblem(kCfg);
  EXPECT_EQ(proto.name(), "WallWithGap");
  ASSERT_EQ(proto.space().components_size(), 1);
  const v1::Component& c = proto.space().components(0);
  EXPECT_EQ(c.type(), v1::Component::TYPE_SE2);
  EXPECT_FALSE(c.has_rotation_weight()) << "OMPL's default SE(2) weight 0.5 applies";
  EXPECT_EQ(std::vector<double>(c.lower().begin(), c.lower().end()), (std::vector<double>{-5, -5}));
  EXPECT_EQ(std::vector<double>(c.upper().begin(), c.upper().end()), (std::vector<double>{5, 5}));
  EXPECT_EQ(std::vector<double>(proto.start().values().begin(), proto.start().values().end()),
            (std::vector<double>{-3, 2, 0}));
  EXPECT_NEAR(proto.goal().values(2), M_PI / 2, 1e-12);

  const auto scene = SceneFromProto(proto, kDir, BlobResolver());
  EXPECT_DOUBLE_EQ(scene->space.Distance(*scene->start, *scene->goal),
                   std::hypot(6.0, 4.0) + 0.5 * M_PI / 2);
  // The world is where assimp's default import puts it: the file is Z_UP, its wall lies in the
  // file's XZ plane and ends up in the XY plane.
  const Box3 world = PlacedBox(scene->obstacles[0].shape, scene->obstacles[0].pose);
  const Box3 world_expected = AssimpDefaultBox(kDir + "/wall_env.dae");
  ExpectNear(world.lo, world_expected.lo, "world lo");
  ExpectNear(world.hi, world_expected.hi, "world hi");
  ExpectNear(world.lo, Eigen::Vector3d(-0.25, -5, -0.5), "wall");
  // The robot (node scale 100 applied) is centred on its vertex centroid in x and y; its
  // height is its own, as in OMPL.app's 2D problems.
  const RobotBody& body = scene->robot[0];
  const Box3 robot = PlacedBox(body.shape, body.offset);
  const Box3 robot_file = AssimpDefaultBox(kDir + "/box_robot.dae");
  const Eigen::Vector3d centroid(1.0, 0.45, 0.0);
  ExpectNear(robot.lo, robot_file.lo - centroid, "robot lo");
  ExpectNear(robot.hi, robot_file.hi - centroid, "robot hi");
  ExpectNear(robot.hi - robot.lo, Eigen::Vector3d(0.6, 0.3, 0.2), "robot size");
}

// The car's body has corners shared by faces of different normals (make_car_problem.py): OMPL.app
// keeps each of its 10 outline corners once per normal, top or bottom and two flanks (3 copies),
// and each of its 4 flank-split corners on the right flank twice, 52 vertices; their mean lies
// at (6/65, -2/13) from the outline's origin, not at the mean of the 20 distinct positions,
// (0.06, -0.2). The node moves the car by (0.5, 0.25). The configuration is OMPL.app's point.
TEST(OmplCfgTest, ReferencePointIsOmplAppsWhenCornersHaveSeveralNormals) {
  const std::string dir = std::string(HGRAPH_SOURCE_DIR) + "/tests/data/ompl_app_car";
  const Eigen::Vector3d ompl_app(0.5 + 6.0 / 65, 0.25 - 2.0 / 13, 0);
  const Eigen::Vector3d distinct_positions(0.56, 0.05, 0);
  for (const char* cfg : {"car_planar.cfg", "car_3d.cfg"}) {
    SCOPED_TRACE(cfg);
    const v1::Scene proto = ReadOmplAppProblem(dir + "/" + cfg);
    const auto scene = SceneFromProto(proto, dir, BlobResolver());
    const Eigen::Vector3d shift = -scene->robot[0].offset.translation();
    EXPECT_LT((shift - ompl_app).norm(), 1e-6) << shift.transpose();
    EXPECT_GT((shift - distinct_positions).norm(), 0.05) << "the mean of distinct positions";
  }
}

// Scenes are content-addressed by their serialization: the imported problem and its JSON file
// must be the same message, bit for bit (JSON reads -0 back as 0, for one).
TEST(OmplCfgTest, ImportedSceneSurvivesItsJsonRoundTrip) {
  const v1::Scene proto = ReadOmplAppProblem(kCfg);
  v1::Scene again;
  ParseJson(ToJson(proto), "round trip", &again);
  std::string a, b;
  {
    google::protobuf::io::StringOutputStream out(&a);
    google::protobuf::io::CodedOutputStream coded(&out);
    coded.SetSerializationDeterministic(true);
    proto.SerializeToCodedStream(&coded);
  }
  {
    google::protobuf::io::StringOutputStream out(&b);
    google::protobuf::io::CodedOutputStream coded(&out);
    coded.SetSerializationDeterministic(true);
    again.SerializeToCodedStream(&coded);
  }
  EXPECT_EQ(a, b);
}

TEST(OmplCfgTest, ReadSceneFileAcceptsCfg) {
  const v1::Scene proto = ReadSceneFile(kCfg);
  EXPECT_EQ(proto.robot(0).shape().mesh().path(), "box_robot.dae");
}

class TempDir : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("hgraph_ompl_cfg_" +
            std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    for (const char* mesh : {"wall_env.dae", "box_robot.dae"}) {
      fs::copy_file(kDir + "/" + mesh, dir_ / mesh);
    }
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Write(const std::string& name, const std::string& text) {
    std::ofstream(dir_ / name) << text;
    return (dir_ / name).string();
  }
  fs::path dir_;
};

using OmplCfg3dTest = TempDir;

TEST_F(OmplCfg3dTest, SpatialProblemUsesAngleAxisAndInfersBounds) {
  const std::string cfg =
      Write("p.cfg",
            "[problem]\nrobot = box_robot.dae\nworld = wall_env.dae\n"
            "start.x = -3\nstart.y = 2\nstart.z = 0.1\n"
            "start.axis.x = 0\nstart.axis.y = 0\nstart.axis.z = 2\n"
            "start.theta = 1.0\n"
            "goal.x = 3\ngoal.y = -2\ngoal.z = 0\n"
            "goal.axis.x = 1\ngoal.axis.y = 0\ngoal.axis.z = 0\ngoal.theta = 0\n"
            "volume.min.x = -5\nvolume.max.x = 5\n");
  const v1::Scene proto = ReadOmplAppProblem(cfg);
  EXPECT_EQ(proto.space().components(0).type(), v1::Component::TYPE_SE3);
  ASSERT_EQ(proto.start().values_size(), 7);
  EXPECT_NEAR(proto.start().values(5), std::sin(0.5), 1e-12);  // qz
  EXPECT_NEAR(proto.start().values(6), std::cos(0.5), 1e-12);  // qw
  // No volume for y and z: the world's box widened by 5% of its size on each side.
  EXPECT_NEAR(proto.space().components(0).lower(1), -5 - 0.5, 1e-6);
  EXPECT_NEAR(proto.space().components(0).upper(2), 0.5 + 0.05, 1e-6);
  // In 3D the whole centroid is the reference point.
  const auto scene = SceneFromProto(proto, dir_.string(), BlobResolver());
  const Box3 robot = PlacedBox(scene->robot[0].shape, scene->robot[0].offset);
  ExpectNear((robot.lo + robot.hi) / 2, Eigen::Vector3d::Zero(), "robot centre");
}

TEST_F(OmplCfg3dTest, ErrorsNameTheKey) {
  const std::string missing =
      Write("m.cfg", "[problem]\nrobot = box_robot.dae\nworld = wall_env.dae\nstart.y = 1\n");
  try {
    ReadOmplAppProblem(missing);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), missing + ": [problem].start.x");
  }
  const std::string bad =
      Write("b.cfg", "[problem]\nrobot = box_robot.dae\nworld = wall_env.dae\nstart.x = one\n");
  try {
    ReadOmplAppProblem(bad);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(),
                 (bad + ": [problem].start.x: must be a finite number, got 'one'").c_str());
  }
  const std::string no_mesh = Write("n.cfg", "[problem]\nrobot = nope.dae\nworld = wall_env.dae\n");
  try {
    ReadOmplAppProblem(no_mesh);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kNotFound);
    EXPECT_EQ(e.field(), no_mesh + ": [problem].robot");
  }
  const std::string no_section = Write("s.cfg", "robot = box_robot.dae\n");
  EXPECT_THROW(ReadOmplAppProblem(no_section), InputError);
}

TEST_F(OmplCfg3dTest, RebasedMeshPathsResolveFromTheNewFolder) {
  v1::Scene proto = ReadOmplAppProblem(kCfg);
  fs::create_directories(dir_ / "out");
  RebaseMeshPaths(kDir, (dir_ / "out").string(), &proto);
  EXPECT_TRUE(fs::exists(dir_ / "out" / proto.robot(0).shape().mesh().path()));
  EXPECT_TRUE(fs::exists(dir_ / "out" / proto.obstacles(0).shape().mesh().path()));
}

TEST_F(OmplCfg3dTest, OmplPathFilesReadBack) {
  // OMPL's .path files hold one configuration per line, x y theta (SE(2)) or x y z qx qy qz qw.
  const Space se2 = Space::SE2(Eigen::Vector2d(-5, -5), Eigen::Vector2d(5, 5));
  InputPath path{.name = "p"};
  path.waypoints = {Eigen::Vector3d(-3, 2, 0), Eigen::Vector3d(0, 0, 0.25),
                    Eigen::Vector3d(3, -2, 1.5707963267949)};
  const std::string file = (dir_ / "p.path").string();
  WritePathsFile(file, {path}, se2);
  const auto read = LoadPathsFile(file, se2);
  ASSERT_EQ(read.size(), 1u);
  ASSERT_EQ(read[0].waypoints.size(), 3u);
  for (size_t i = 0; i < 3; ++i) EXPECT_EQ(read[0].waypoints[i], path.waypoints[i]);
  const auto plain = ParsePathsText("1 2 0.5\n1.5 2 0.75\n", "x.path", se2);
  ASSERT_EQ(plain.size(), 1u);
  EXPECT_EQ(plain[0].waypoints.size(), 2u);
}

TEST_F(OmplCfg3dTest, OmplStatePrintReads) {
  // The format of OMPL.app's shipped .path files (PathGeometric::print).
  const std::string se2_text =
      "Geometric path with 2 states\nCompound state [\nRealVectorState [0.01 -0.15]\n"
      "SO2State [0]\n]\nCompound state [\nRealVectorState [41.01 -0.15]\n"
      "SO2State [0.802851]\n]\n";
  const std::string file = Write("maze.path", se2_text);
  const Space se2 = Space::SE2(Eigen::Vector2d(-55, -55), Eigen::Vector2d(55, 55));
  const auto paths = LoadPathsFile(file, se2);
  ASSERT_EQ(paths.size(), 1u);
  EXPECT_EQ(paths[0].name, "maze");
  ASSERT_EQ(paths[0].waypoints.size(), 2u);
  EXPECT_EQ(paths[0].waypoints[1], Eigen::Vector3d(41.01, -0.15, 0.802851));

  const Space se3 = Space::SE3(Eigen::Vector3d::Constant(-9), Eigen::Vector3d::Constant(9));
  const auto spatial = ParseOmplStatePrint(
      "Compound state [\nRealVectorState [1 2 3]\nSO3State [0 0 0 1]\n]\n", "s.path", se3);
  ASSERT_EQ(spatial[0].waypoints.size(), 1u);
  EXPECT_EQ(spatial[0].waypoints[0].size(), 7);
  EXPECT_EQ(spatial[0].waypoints[0][6], 1.0);
  try {
    LoadPathsFile(file, se3);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), file + ":2");
  }
}

}  // namespace
}  // namespace hgraph
