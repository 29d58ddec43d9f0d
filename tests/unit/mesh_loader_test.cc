#include "core/scene/mesh_loader.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <array>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "core/common/error.h"
#include "core/scene/mesh_wire.h"

namespace hgraph {
namespace {

namespace fs = std::filesystem;

// Unit cube [0,1]^3: vertex i has coordinates (bit 0, bit 1, bit 2) of i; faces wound outwards.
Eigen::Vector3d CubeVertex(int i) { return Eigen::Vector3d(i & 1, (i >> 1) & 1, (i >> 2) & 1); }
constexpr std::array<std::array<int, 4>, 6> kCubeQuads = {
    {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}}};

std::vector<std::array<int, 3>> CubeTriangles() {
  std::vector<std::array<int, 3>> out;
  for (const auto& q : kCubeQuads) {
    out.push_back({q[0], q[1], q[2]});
    out.push_back({q[0], q[2], q[3]});
  }
  return out;
}

// Quads on purpose: the loader must triangulate.
std::string CubeObj() {
  std::ostringstream s;
  s << "# unit cube\n";
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3d v = CubeVertex(i);
    s << "v " << v.x() << " " << v.y() << " " << v.z() << "\n";
  }
  for (const auto& q : kCubeQuads) {
    s << "f " << q[0] + 1 << " " << q[1] + 1 << " " << q[2] + 1 << " " << q[3] + 1 << "\n";
  }
  return s.str();
}

std::string CubeStl() {
  std::ostringstream s;
  s << "solid cube\n";
  for (const auto& t : CubeTriangles()) {
    const Eigen::Vector3d a = CubeVertex(t[0]), b = CubeVertex(t[1]), c = CubeVertex(t[2]);
    const Eigen::Vector3d n = (b - a).cross(c - a).normalized();
    s << " facet normal " << n.x() << " " << n.y() << " " << n.z() << "\n  outer loop\n";
    for (const Eigen::Vector3d& v : {a, b, c}) {
      s << "   vertex " << v.x() << " " << v.y() << " " << v.z() << "\n";
    }
    s << "  endloop\n endfacet\n";
  }
  s << "endsolid cube\n";
  return s.str();
}

std::string CubePly() {
  std::ostringstream s;
  s << "ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\n"
       "property float z\nelement face 6\nproperty list uchar int vertex_indices\nend_header\n";
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3d v = CubeVertex(i);
    s << v.x() << " " << v.y() << " " << v.z() << "\n";
  }
  for (const auto& q : kCubeQuads)
    s << "4 " << q[0] << " " << q[1] << " " << q[2] << " " << q[3] << "\n";
  return s.str();
}

// Z-up on purpose: the loader must keep the file's coordinates rather than turning them Y-up.
std::string CubeDae(const std::string& node_transform) {
  std::ostringstream pos, idx;
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3d v = CubeVertex(i);
    pos << v.x() << " " << v.y() << " " << v.z() << " ";
  }
  for (const auto& t : CubeTriangles()) idx << t[0] << " " << t[1] << " " << t[2] << " ";
  std::ostringstream s;
  s << R"(<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset><unit name="meter" meter="1"/><up_axis>Z_UP</up_axis></asset>
  <library_geometries>
    <geometry id="cube" name="cube">
      <mesh>
        <source id="cube-pos">
          <float_array id="cube-pos-array" count="24">)"
    << pos.str() << R"(</float_array>
          <technique_common>
            <accessor source="#cube-pos-array" count="8" stride="3">
              <param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/>
            </accessor>
          </technique_common>
        </source>
        <vertices id="cube-verts"><input semantic="POSITION" source="#cube-pos"/></vertices>
        <triangles count="12"><input semantic="VERTEX" source="#cube-verts" offset="0"/><p>)"
    << idx.str() << R"(</p></triangles>
      </mesh>
    </geometry>
  </library_geometries>
  <library_visual_scenes>
    <visual_scene id="Scene" name="Scene">
      <node id="cube-node" name="cube">)"
    << node_transform << R"(<instance_geometry url="#cube"/></node>
    </visual_scene>
  </library_visual_scenes>
  <scene><instance_visual_scene url="#Scene"/></scene>
</COLLADA>
)";
  return s.str();
}

std::string Base64(const std::string& in) {
  static constexpr char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  size_t i = 0;
  for (; i + 2 < in.size(); i += 3) {
    const uint32_t n = (uint8_t(in[i]) << 16) | (uint8_t(in[i + 1]) << 8) | uint8_t(in[i + 2]);
    for (int k = 3; k >= 0; --k) out += kAlphabet[(n >> (6 * k)) & 63];
  }
  if (i + 1 == in.size()) {
    const uint32_t n = uint8_t(in[i]) << 16;
    out += kAlphabet[(n >> 18) & 63];
    out += kAlphabet[(n >> 12) & 63];
    out += "==";
  } else if (i + 2 == in.size()) {
    const uint32_t n = (uint8_t(in[i]) << 16) | (uint8_t(in[i + 1]) << 8);
    out += kAlphabet[(n >> 18) & 63];
    out += kAlphabet[(n >> 12) & 63];
    out += kAlphabet[(n >> 6) & 63];
    out += "=";
  }
  return out;
}

// glTF 2.0 with the binary buffer embedded as a base64 data URI (float positions, uint16 indices).
std::string CubeGltf() {
  std::string buffer;
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3d v = CubeVertex(i);
    for (int k = 0; k < 3; ++k) {
      const float f = static_cast<float>(v[k]);
      char bytes[4];
      std::memcpy(bytes, &f, 4);
      buffer.append(bytes, 4);
    }
  }
  const size_t index_offset = buffer.size();
  for (const auto& t : CubeTriangles()) {
    for (int k = 0; k < 3; ++k) {
      const uint16_t u = static_cast<uint16_t>(t[k]);
      char bytes[2];
      std::memcpy(bytes, &u, 2);
      buffer.append(bytes, 2);
    }
  }
  std::ostringstream s;
  s << R"({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
  "nodes": [{"mesh": 0}],
  "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "mode": 4}]}],
  "buffers": [{"byteLength": )"
    << buffer.size() << R"(, "uri": "data:application/octet-stream;base64,)" << Base64(buffer)
    << R"("}],
  "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": )"
    << index_offset << R"(, "target": 34962},
                  {"buffer": 0, "byteOffset": )"
    << index_offset << R"(, "byteLength": )" << buffer.size() - index_offset
    << R"(, "target": 34963}],
  "accessors": [{"bufferView": 0, "componentType": 5126, "count": 8, "type": "VEC3",
                 "min": [0, 0, 0], "max": [1, 1, 1]},
                {"bufferView": 1, "componentType": 5123, "count": 36, "type": "SCALAR"}]})";
  return s.str();
}

struct Bounds {
  Eigen::Vector3d lo, hi;
};

Bounds BoundsOf(const Mesh& mesh) {
  Bounds b{Eigen::Vector3d::Constant(1e300), Eigen::Vector3d::Constant(-1e300)};
  for (const Eigen::Vector3d& v : mesh.vertices) {
    b.lo = b.lo.cwiseMin(v);
    b.hi = b.hi.cwiseMax(v);
  }
  return b;
}

void ExpectBounds(const Mesh& mesh, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  const Bounds b = BoundsOf(mesh);
  EXPECT_TRUE(b.lo.isApprox(lo, 1e-6) || (b.lo - lo).norm() < 1e-6) << b.lo.transpose();
  EXPECT_TRUE((b.hi - hi).norm() < 1e-6) << b.hi.transpose();
}

void ExpectUnitCube(const Mesh& mesh) {
  EXPECT_EQ(mesh.triangles.size(), 12u);
  EXPECT_EQ(mesh.vertices.size(), 8u);  // identical vertices joined
  ExpectBounds(mesh, Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones());
  for (const Eigen::Vector3i& t : mesh.triangles) {
    EXPECT_GE(t.minCoeff(), 0);
    EXPECT_LT(t.maxCoeff(), static_cast<int>(mesh.vertices.size()));
  }
}

class MeshLoaderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) /
           ("hgraph_mesh_loader_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string Write(const std::string& name, const std::string& content) {
    const fs::path p = dir_ / name;
    std::ofstream(p, std::ios::binary) << content;
    return p.string();
  }

  fs::path dir_;
};

TEST_F(MeshLoaderTest, LoadsObjWithQuads) {
  ExpectUnitCube(*LoadMeshFile(Write("cube.obj", CubeObj()), {}, "mesh"));
}

TEST_F(MeshLoaderTest, LoadsAsciiStl) {
  ExpectUnitCube(*LoadMeshFile(Write("cube.stl", CubeStl()), {}, "mesh"));
}

TEST_F(MeshLoaderTest, LoadsAsciiPly) {
  ExpectUnitCube(*LoadMeshFile(Write("cube.ply", CubePly()), {}, "mesh"));
}

TEST_F(MeshLoaderTest, LoadsGltfWithEmbeddedBuffer) {
  ExpectUnitCube(*LoadMeshFile(Write("cube.gltf", CubeGltf()), {}, "mesh"));
}

TEST_F(MeshLoaderTest, LoadsColladaAndKeepsZUpCoordinates) {
  ExpectUnitCube(*LoadMeshFile(Write("cube.dae", CubeDae("")), {}, "mesh"));
}

TEST_F(MeshLoaderTest, AppliesColladaNodeTransformWhenAsked) {
  const std::string path =
      Write("cube.dae", CubeDae("<translate>1 0 -1</translate><scale>2 3 4</scale>"));
  const auto placed = LoadMeshFile(path, {}, "mesh");
  EXPECT_EQ(placed->triangles.size(), 12u);
  ExpectBounds(*placed, Eigen::Vector3d(1, 0, -1), Eigen::Vector3d(3, 3, 3));

  const auto own_frame = LoadMeshFile(path, {.apply_node_transforms = false}, "mesh");
  EXPECT_EQ(own_frame->triangles.size(), 12u);
  ExpectBounds(*own_frame, Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones());
}

TEST_F(MeshLoaderTest, AppliesScaleAfterNodeTransform) {
  const std::string path = Write("cube.dae", CubeDae("<scale>2 2 2</scale>"));
  const auto mesh = LoadMeshFile(path, {.scale = Eigen::Vector3d(0.5, 1, 3)}, "mesh");
  ExpectBounds(*mesh, Eigen::Vector3d::Zero(), Eigen::Vector3d(1, 2, 6));
}

TEST_F(MeshLoaderTest, LoadsFromBytes) {
  ExpectUnitCube(*LoadMeshBytes(CubeObj(), "obj", {}, "scene.mesh_bytes"));
  ExpectUnitCube(*LoadMeshBytes(CubeStl(), ".stl", {}, "scene.mesh_bytes"));
  ExpectUnitCube(*LoadMeshBytes(CubeGltf(), "gltf", {}, "scene.mesh_bytes"));
  const auto scaled = LoadMeshBytes(CubePly(), "ply", {.scale = Eigen::Vector3d(2, 2, 2)}, "m");
  ExpectBounds(*scaled, Eigen::Vector3d::Zero(), Eigen::Vector3d(2, 2, 2));
}

// tests/data/ompl_app_car/car_robot.dae writes a normal per face (make_car_problem.py): OMPL.app's
// import keeps 52 (position, normal) vertices, ours 20 positions, and the means differ. In the
// file's own frame (Z_UP kept) the car lies in XZ and the node moves it by (0.5, 0, 0.25).
TEST_F(MeshLoaderTest, OmplAppCenterCountsCornersOncePerNormal) {
  const std::string car = std::string(HGRAPH_SOURCE_DIR) + "/tests/data/ompl_app_car/car_robot.dae";
  const Eigen::Vector3d ompl_app(0.5 + 6.0 / 65, 0, 0.25 - 2.0 / 13);
  const auto plain = LoadMeshFile(car, {}, "robot");
  EXPECT_FALSE(plain->ompl_app_center.has_value()) << "only computed when asked for";
  ASSERT_EQ(plain->vertices.size(), 20u);
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& v : plain->vertices) mean += v / 20;
  EXPECT_LT((mean - Eigen::Vector3d(0.56, 0, 0.05)).norm(), 1e-6) << mean.transpose();

  const auto mesh = LoadMeshFile(car, {.ompl_app_center = true}, "robot");
  ASSERT_TRUE(mesh->ompl_app_center.has_value());
  EXPECT_LT((*mesh->ompl_app_center - ompl_app).norm(), 1e-6) << mesh->ompl_app_center->transpose();
  EXPECT_EQ(mesh->vertices, plain->vertices) << "the collision model stays ours";

  std::ifstream in(car, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto scaled = LoadMeshBytes(
      bytes, "dae", {.scale = Eigen::Vector3d(2, 1, 3), .ompl_app_center = true}, "m");
  ASSERT_TRUE(scaled->ompl_app_center.has_value());
  EXPECT_LT((*scaled->ompl_app_center - Eigen::Vector3d(2, 1, 3).cwiseProduct(ompl_app)).norm(),
            1e-6);
  // A box written with per-face normals keeps every corner three times: the same mean.
  const auto cube = LoadMeshFile(Write("cube.dae", CubeDae("")), {.ompl_app_center = true}, "m");
  EXPECT_LT((*cube->ompl_app_center - Eigen::Vector3d::Constant(0.5)).norm(), 1e-6);
}

TEST_F(MeshLoaderTest, MissingFileIsNotFoundAndNamesTheField) {
  const std::string path = (dir_ / "absent.obj").string();
  try {
    LoadMeshFile(path, {}, "obstacles[3].mesh_path");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kNotFound);
    EXPECT_EQ(e.field(), "obstacles[3].mesh_path");
    EXPECT_NE(std::string(e.what()).find("obstacles[3].mesh_path"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("absent.obj"), std::string::npos);
  }
}

TEST_F(MeshLoaderTest, CorruptOrEmptyInputIsInputError) {
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"broken.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nend_header\n1\n"},
      {"garbage.stl", std::string("\x01\x02\x03 not a mesh at all", 22)},
      {"empty.obj", "# nothing here\n"},
      {"lines.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2\nl 2 3\n"},
      {"broken.gltf", "{\"asset\": {\"version\": \"2.0\"}, \"meshes\": [ oops"},
  };
  for (const auto& [name, content] : bad) {
    try {
      LoadMeshFile(Write(name, content), {}, "robot[0].mesh");
      ADD_FAILURE() << name << ": expected an error";
    } catch (const InputError& e) {
      EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument) << name;
      EXPECT_EQ(e.field(), "robot[0].mesh") << name;
    }
  }
  EXPECT_THROW(LoadMeshBytes("", "obj", {}, "m"), InputError);
  EXPECT_THROW(LoadMeshBytes("this is not a mesh", "dae", {}, "m"), InputError);
}

TEST_F(MeshLoaderTest, RejectsNonPositiveScale) {
  EXPECT_THROW(LoadMeshBytes(CubeObj(), "obj", {.scale = Eigen::Vector3d(1, 0, 1)}, "m"),
               InputError);
}

// A glTF whose buffer is the file `uri`: the buffer holds three float vertices when read.
std::string TriangleGltf(const std::string& uri) {
  return R"({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
  "nodes": [{"mesh": 0}], "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
  "buffers": [{"byteLength": 36, "uri": ")" +
         uri + R"("}],
  "bufferViews": [{"buffer": 0, "byteLength": 36}],
  "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                 "min": [0, 0, 0], "max": [1, 1, 0]}]})";
}

std::string Floats(const std::vector<float>& values) {
  std::string out(values.size() * 4, '\0');
  std::memcpy(out.data(), values.data(), out.size());
  return out;
}

TEST_F(MeshLoaderTest, NeverOpensFilesNamedInsideAMesh) {
  // The buffer exists beside the glTF and would load as a triangle if it were opened.
  Write("buffer.bin", Floats({0, 0, 0, 1, 0, 0, 0, 1, 0}));
  for (const std::string& uri : {std::string("buffer.bin"), (dir_ / "buffer.bin").string(),
                                 std::string("../") + dir_.filename().string() + "/buffer.bin"}) {
    std::string existing, missing;
    try {
      LoadMeshFile(Write("tri.gltf", TriangleGltf(uri)), {}, "m");
      ADD_FAILURE() << uri << ": a referenced file was read";
    } catch (const InputError& e) {
      existing = e.what();
    }
    const std::string absent = uri.substr(0, uri.size() - 10) + "nothing.bi";
    try {
      LoadMeshBytes(TriangleGltf(absent), "gltf", {}, "m");
    } catch (const InputError& e) {
      missing = e.what();
    }
    // Whether the name exists does not show.
    EXPECT_NE(existing.find("could not open referenced file"), std::string::npos) << existing;
    EXPECT_NE(missing.find("could not open referenced file"), std::string::npos) << missing;
  }
}

TEST_F(MeshLoaderTest, RefusesDeclaredCountsTheBytesCannotHold) {
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"off", "OFF\n1000000000 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"},  // 45 bytes
      {"off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n"},           // index past vertices
      {"off", "OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0"},                 // cut short
      {"ply", "ply\nformat ascii 1.0\n"},                              // header never ends
      {"ply",
       "ply\nformat binary_little_endian 1.0\nelement vertex 20000000\nproperty float x\n"
       "property float y\nproperty float z\nend_header\n" +
           std::string(64, '\0')},
      {"obj", "OFF\n99999999 0 0\n"},  // the content decides, not the hint
  };
  for (const auto& [format, bytes] : bad) {
    try {
      LoadMeshBytes(bytes, format, {}, "scene.obstacles[2].shape.mesh.data");
      ADD_FAILURE() << bytes << ": expected an error";
    } catch (const InputError& e) {
      EXPECT_EQ(e.field(), "scene.obstacles[2].shape.mesh.data");
    }
  }
}

TEST_F(MeshLoaderTest, RefusesMeshesOverTheLimits) {
  EXPECT_THROW(LoadMeshBytes(CubeObj(), "obj", {.max_triangles = 11}, "m"), InputError);
  EXPECT_EQ(LoadMeshBytes(CubeObj(), "obj", {.max_triangles = 12}, "m")->triangles.size(), 12u);
  EXPECT_THROW(LoadMeshBytes(CubeObj(), "../obj", {}, "m"), InputError);
}

TEST(MeshWireTest, RoundTripsAndRefusesMalformedReplies) {
  Mesh mesh;
  mesh.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  mesh.triangles = {{0, 1, 2}};
  const MeshLoadOptions limits;
  const std::string good = EncodeMeshReply(mesh);
  const MeshReply ok = DecodeMeshReply(good, limits);
  ASSERT_NE(ok.mesh, nullptr);
  EXPECT_EQ(ok.mesh->vertices, mesh.vertices);
  EXPECT_EQ(ok.mesh->triangles, mesh.triangles);
  EXPECT_EQ(DecodeMeshReply(EncodeMeshRefusal("no"), limits).refused, "no");

  Mesh past = mesh;
  past.triangles = {{0, 1, 3}};
  Mesh nan = mesh;
  nan.vertices[1].x() = std::numeric_limits<double>::quiet_NaN();
  for (const std::string& bad :
       {std::string("garbage"), good.substr(0, good.size() - 1), good + "x", EncodeMeshReply(past),
        EncodeMeshReply(nan), std::string("HGMR\1\0\0\0\7\0\0\0")}) {
    const MeshReply reply = DecodeMeshReply(bad, limits);
    EXPECT_EQ(reply.mesh, nullptr);
    EXPECT_FALSE(reply.malformed.empty());
  }
  EXPECT_EQ(DecodeMeshReply(good, {.max_vertices = 2}).mesh, nullptr);

  // The OMPL.app center travels with the mesh exactly when the request asked for it.
  Mesh centered = mesh;
  centered.ompl_app_center = Eigen::Vector3d(0.25, -1, 3);
  const MeshLoadOptions with_center{.ompl_app_center = true};
  const MeshReply c = DecodeMeshReply(EncodeMeshReply(centered), with_center);
  ASSERT_NE(c.mesh, nullptr) << c.malformed;
  EXPECT_EQ(c.mesh->ompl_app_center, centered.ompl_app_center);
  EXPECT_FALSE(ok.mesh->ompl_app_center.has_value());
  EXPECT_EQ(DecodeMeshReply(good, with_center).mesh, nullptr) << "asked for, missing";
  EXPECT_EQ(DecodeMeshReply(EncodeMeshReply(centered), limits).mesh, nullptr) << "not asked for";
  Mesh nan_center = centered;
  nan_center.ompl_app_center->y() = std::numeric_limits<double>::infinity();
  EXPECT_EQ(DecodeMeshReply(EncodeMeshReply(nan_center), with_center).mesh, nullptr);
  EXPECT_TRUE(
      DecodeMeshRequest(EncodeMeshRequest({.format = "dae", .options = with_center, .bytes = "x"}))
          .options.ompl_app_center);

  const MeshImportRequest request{.format = "obj", .options = {}, .bytes = "v 0 0 0"};
  const MeshImportRequest back = DecodeMeshRequest(EncodeMeshRequest(request));
  EXPECT_EQ(back.format, "obj");
  EXPECT_EQ(back.bytes, "v 0 0 0");
  EXPECT_THROW(DecodeMeshRequest(EncodeMeshRequest(request) + "x"), InputError);
}

}  // namespace
}  // namespace hgraph
