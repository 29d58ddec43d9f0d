// The out-of-process mesh importer with the real hgraph-mesh-import helper, and real programs
// standing in for a helper that hangs or writes garbage.
#include "server/mesh_importer.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "core/common/error.h"

namespace hgraph::server {
namespace {

const std::string kHelper = std::string(HGRAPH_BINARY_DIR) + "/hgraph-mesh-import";
const std::string kTetra =
    "OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 1 3\n3 0 2 3\n3 1 2 3\n";

std::string ErrorOf(const MeshImporter& importer, const std::string& bytes,
                    const std::string& format, const CancelToken& token = CancelToken()) {
  try {
    importer.Import(bytes, format, {}, "scene.obstacles[4].shape.mesh.data", token);
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "scene.obstacles[4].shape.mesh.data");
    return e.what();
  }
  return "";
}

TEST(MeshImporterTest, ImportsInAChildProcess) {
  const MeshImporter importer({.helper_path = kHelper});
  importer.CheckHelper();
  const auto mesh = importer.Import(kTetra, "off", {.scale = Eigen::Vector3d(2, 2, 2)}, "m", {});
  EXPECT_EQ(mesh->vertices.size(), 4u);
  EXPECT_EQ(mesh->triangles.size(), 4u);
  EXPECT_EQ(mesh->vertices[1], Eigen::Vector3d(2, 0, 0));
}

// The OMPL.app reference point comes from the child too, from the same bytes, the same as an
// import in this process computes it.
TEST(MeshImporterTest, ComputesTheOmplAppCenterInTheChild) {
  const std::string car = std::string(HGRAPH_SOURCE_DIR) + "/tests/data/ompl_app_car/car_robot.dae";
  std::ifstream in(car, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const MeshImporter importer({.helper_path = kHelper});
  const MeshLoadOptions options{.ompl_app_center = true};
  const auto child = importer.Import(bytes, "dae", options, "robot", {});
  const auto here = LoadMeshBytes(bytes, "dae", options, "robot");
  ASSERT_TRUE(child->ompl_app_center.has_value());
  EXPECT_EQ(child->ompl_app_center, here->ompl_app_center);
  EXPECT_LT((*child->ompl_app_center - Eigen::Vector3d(0.5 + 6.0 / 65, 0, 0.25 - 2.0 / 13)).norm(),
            1e-6);
  EXPECT_EQ(child->vertices, here->vertices);
  EXPECT_FALSE(importer.Import(bytes, "dae", {}, "robot", {})->ompl_app_center.has_value());
}

TEST(MeshImporterTest, ReportsTheChildsRefusalAndCrash) {
  const MeshImporter importer({.helper_path = kHelper});
  EXPECT_NE(
      ErrorOf(importer, "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n", "off").find("names vertex 7"),
      std::string::npos);
  // assimp 5.2 dereferences past the end of this binary PLY (cut 27 bytes short): the child
  // dies of a signal (or refuses it), this process goes on.
  std::string ply =
      "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float "
      "y\nproperty float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n";
  ply += std::string(4 * 12, '\0');
  for (int f = 0; f < 4; ++f) ply += std::string("\3") + std::string(12, '\0');
  ply.resize(ply.size() - 27);
  EXPECT_FALSE(ErrorOf(importer, ply, "ply").empty());
}

TEST(MeshImporterTest, KillsAHelperThatHangsAndRefusesGarbage) {
  const std::filesystem::path dir = std::filesystem::path(::testing::TempDir()) /
                                    ("hgraph_importer_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string hang = (dir / "hang.sh").string();
  std::ofstream(hang) << "#!/bin/sh\nexec sleep 60\n";
  ::chmod(hang.c_str(), 0755);
  const MeshImporter hanging({.helper_path = hang, .timeout = std::chrono::milliseconds(200)});
  EXPECT_NE(ErrorOf(hanging, kTetra, "off").find("did not finish within 200 ms"),
            std::string::npos);

  // cat echoes the request: not a reply.
  const MeshImporter echo({.helper_path = "/bin/cat"});
  EXPECT_NE(ErrorOf(echo, kTetra, "off").find("no valid reply header"), std::string::npos);

  CancelToken cancelled;
  cancelled.Cancel();
  try {
    hanging.Import(kTetra, "off", {}, "m", cancelled);
    ADD_FAILURE() << "expected cancellation";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kCancelled);
  }
  std::filesystem::remove_all(dir);
}

TEST(MeshImporterTest, MissingHelperIsAConfigurationError) {
  EXPECT_THROW(MeshImporter({.helper_path = "/nonexistent/hgraph-mesh-import"}).CheckHelper(),
               Error);
}

}  // namespace
}  // namespace hgraph::server
