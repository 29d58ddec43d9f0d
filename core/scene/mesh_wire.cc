#include "core/scene/mesh_wire.h"

#include <cmath>
#include <cstring>

#include "core/common/error.h"

namespace hgraph {
namespace {

constexpr uint32_t kVersion = 2;
constexpr size_t kMaxRefusalBytes = 1000;
constexpr uint32_t kMaxHintBytes = 64;

template <typename T>
void Put(std::string& out, T value) {
  char raw[sizeof(T)];
  std::memcpy(raw, &value, sizeof(T));  // the build targets little-endian hosts only
  out.append(raw, sizeof(T));
}

class Reader {
 public:
  explicit Reader(const std::string& bytes) : bytes_(bytes) {}
  template <typename T>
  bool Get(T* value) {
    if (bytes_.size() - position_ < sizeof(T)) return false;
    std::memcpy(value, bytes_.data() + position_, sizeof(T));
    position_ += sizeof(T);
    return true;
  }
  bool Bytes(uint64_t n, std::string* out) {
    if (bytes_.size() - position_ < n) return false;
    out->assign(bytes_, position_, n);
    position_ += n;
    return true;
  }
  bool Magic(const char* magic) {
    if (bytes_.size() - position_ < 4 || bytes_.compare(position_, 4, magic) != 0) return false;
    position_ += 4;
    return true;
  }
  uint64_t left() const { return bytes_.size() - position_; }
  const char* here() const { return bytes_.data() + position_; }
  void Skip(uint64_t n) { position_ += n; }

 private:
  const std::string& bytes_;
  size_t position_ = 0;
};

}  // namespace

std::string EncodeMeshRequest(const MeshImportRequest& request) {
  std::string out = "HGMQ";
  Put<uint32_t>(out, kVersion);
  Put<uint32_t>(out, static_cast<uint32_t>(request.format.size()));
  out += request.format;
  for (int k = 0; k < 3; ++k) Put<double>(out, request.options.scale[k]);
  Put<uint8_t>(out, request.options.apply_node_transforms ? 1 : 0);
  Put<uint8_t>(out, request.options.ompl_app_center ? 1 : 0);
  Put<int64_t>(out, request.options.max_vertices);
  Put<int64_t>(out, request.options.max_triangles);
  Put<uint64_t>(out, request.bytes.size());
  out += request.bytes;
  return out;
}

MeshImportRequest DecodeMeshRequest(const std::string& bytes) {
  Reader in(bytes);
  MeshImportRequest request;
  uint32_t version = 0;
  uint32_t hint_len = 0;
  uint8_t transforms = 0;
  uint8_t center = 0;
  uint64_t mesh_len = 0;
  if (!in.Magic("HGMQ") || !in.Get(&version) || version != kVersion || !in.Get(&hint_len) ||
      hint_len > kMaxHintBytes || !in.Bytes(hint_len, &request.format)) {
    throw InputError("", "malformed import request header");
  }
  for (int k = 0; k < 3; ++k) {
    if (!in.Get(&request.options.scale[k])) throw InputError("", "malformed import request");
  }
  if (!in.Get(&transforms) || !in.Get(&center) || !in.Get(&request.options.max_vertices) ||
      !in.Get(&request.options.max_triangles) || !in.Get(&mesh_len) ||
      !in.Bytes(mesh_len, &request.bytes) || in.left() != 0) {
    throw InputError("", "malformed import request");
  }
  request.options.apply_node_transforms = transforms != 0;
  request.options.ompl_app_center = center != 0;
  return request;
}

std::string EncodeMeshReply(const Mesh& mesh) {
  std::string out = "HGMR";
  Put<uint32_t>(out, kVersion);
  Put<uint32_t>(out, 0);
  Put<uint64_t>(out, mesh.vertices.size());
  Put<uint64_t>(out, mesh.triangles.size());
  out.reserve(out.size() + mesh.vertices.size() * 24 + mesh.triangles.size() * 12);
  for (const Eigen::Vector3d& v : mesh.vertices) {
    for (int k = 0; k < 3; ++k) Put<double>(out, v[k]);
  }
  for (const Eigen::Vector3i& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) Put<uint32_t>(out, static_cast<uint32_t>(t[k]));
  }
  Put<uint8_t>(out, mesh.ompl_app_center ? 1 : 0);
  if (mesh.ompl_app_center) {
    for (int k = 0; k < 3; ++k) Put<double>(out, (*mesh.ompl_app_center)[k]);
  }
  return out;
}

std::string EncodeMeshRefusal(const std::string& message) {
  std::string out = "HGMR";
  Put<uint32_t>(out, kVersion);
  Put<uint32_t>(out, 1);
  const std::string cut = message.substr(0, kMaxRefusalBytes);
  Put<uint32_t>(out, static_cast<uint32_t>(cut.size()));
  out += cut;
  return out;
}

uint64_t MaxMeshReplyBytes(const MeshLoadOptions& limits) {
  return 32 + 25 + static_cast<uint64_t>(limits.max_vertices) * 24 +
         static_cast<uint64_t>(limits.max_triangles) * 12 + kMaxRefusalBytes;
}

MeshReply DecodeMeshReply(const std::string& bytes, const MeshLoadOptions& limits) {
  MeshReply reply;
  Reader in(bytes);
  uint32_t version = 0;
  uint32_t status = 0;
  if (!in.Magic("HGMR") || !in.Get(&version) || version != kVersion || !in.Get(&status)) {
    reply.malformed = "no valid reply header (" + std::to_string(bytes.size()) + " bytes)";
    return reply;
  }
  if (status == 1) {
    uint32_t len = 0;
    std::string message;
    if (!in.Get(&len) || len > kMaxRefusalBytes || !in.Bytes(len, &message) || in.left() != 0) {
      reply.malformed = "a malformed refusal";
      return reply;
    }
    reply.refused = message.empty() ? "refused" : message;
    return reply;
  }
  uint64_t vertices = 0;
  uint64_t triangles = 0;
  if (status != 0 || !in.Get(&vertices) || !in.Get(&triangles)) {
    reply.malformed = "an unknown reply status";
    return reply;
  }
  if (vertices > static_cast<uint64_t>(limits.max_vertices) ||
      triangles > static_cast<uint64_t>(limits.max_triangles) || triangles == 0) {
    reply.malformed = "counts outside the limits (" + std::to_string(vertices) + " vertices, " +
                      std::to_string(triangles) + " triangles)";
    return reply;
  }
  const uint64_t center_bytes = limits.ompl_app_center ? 25 : 1;
  if (in.left() != vertices * 24 + triangles * 12 + center_bytes) {
    reply.malformed = "a length that does not match its counts";
    return reply;
  }
  auto mesh = std::make_shared<Mesh>();
  mesh->vertices.resize(vertices);
  mesh->triangles.resize(triangles);
  for (uint64_t i = 0; i < vertices; ++i) {
    for (int k = 0; k < 3; ++k) in.Get(&mesh->vertices[i][k]);
    if (!mesh->vertices[i].allFinite()) {
      reply.malformed = "a non-finite vertex";
      return reply;
    }
  }
  for (uint64_t i = 0; i < triangles; ++i) {
    for (int k = 0; k < 3; ++k) {
      uint32_t index = 0;
      in.Get(&index);
      if (index >= vertices) {
        reply.malformed = "a triangle index past the vertices";
        return reply;
      }
      mesh->triangles[i][k] = static_cast<int>(index);
    }
  }
  // A center is in the reply exactly when the request asked for one.
  uint8_t has_center = 0;
  in.Get(&has_center);
  if (has_center != (limits.ompl_app_center ? 1 : 0)) {
    reply.malformed = limits.ompl_app_center ? "no OMPL.app center" : "an unasked-for center";
    return reply;
  }
  if (has_center) {
    Eigen::Vector3d center;
    for (int k = 0; k < 3; ++k) in.Get(&center[k]);
    if (!center.allFinite()) {
      reply.malformed = "a non-finite OMPL.app center";
      return reply;
    }
    mesh->ompl_app_center = center;
  }
  reply.mesh = std::move(mesh);
  return reply;
}

}  // namespace hgraph
