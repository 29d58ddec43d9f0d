// The byte format between a mesh importer process (hgraph-mesh-import) and its parent. Both
// directions are length-prefixed, little-endian and checked field by field: the parent trusts
// nothing the child writes (it may have parsed hostile bytes), so DecodeMeshReply validates
// counts against the byte length, vertex indices against the vertex count, and finiteness.
//
//   request: "HGMQ" u32:version  u32:hint_len hint  f64[3]:scale  u8:node_transforms
//            u8:ompl_app_center  i64:max_vertices  i64:max_triangles  u64:mesh_len mesh
//   reply:   "HGMR" u32:version  u32:status (0 ok, 1 refused)
//            ok:      u64:vertices u64:triangles f64[3*vertices] u32[3*triangles]
//                     u8:has_center [f64[3]:center]  (a center exactly when one was asked for)
//            refused: u32:message_len message
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "core/scene/mesh_loader.h"
#include "core/scene/scene.h"

namespace hgraph {

struct MeshImportRequest {
  std::string format;  // extension without the dot
  MeshLoadOptions options;
  std::string bytes;
};

std::string EncodeMeshRequest(const MeshImportRequest& request);
// Throws InputError("") if `bytes` is not exactly one well-formed request.
MeshImportRequest DecodeMeshRequest(const std::string& bytes);

std::string EncodeMeshReply(const Mesh& mesh);
// A refusal; the message is cut to 1000 bytes.
std::string EncodeMeshRefusal(const std::string& message);

// The largest reply a request with these limits can answer with.
uint64_t MaxMeshReplyBytes(const MeshLoadOptions& limits);

// `limits` are the request's options: their counts bound the reply, and ompl_app_center says
// whether it must carry a center.
// Result of decoding a reply: a mesh, or the child's refusal, or (mesh null, refused empty) a
// malformed reply described in `malformed`.
struct MeshReply {
  std::shared_ptr<const Mesh> mesh;
  std::string refused;
  std::string malformed;
};
MeshReply DecodeMeshReply(const std::string& bytes, const MeshLoadOptions& limits);

}  // namespace hgraph
