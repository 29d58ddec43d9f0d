#include "core/scene/mesh_loader.h"

#include <assimp/config.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <assimp/Importer.hpp>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <system_error>

#include "core/common/error.h"
#include "core/scene/memory_io.h"
#include "core/scene/mesh_prescan.h"

namespace hgraph {
namespace {

// Triangles are all the collision checker understands; points and lines are dropped rather than
// rejected so that a mesh with stray edges (common in exported CAD) still loads. Normals, texture
// coordinates and colours are removed before joining, so that vertices are joined by position
// alone (an STL cube otherwise keeps 24 vertices, one per face normal).
constexpr unsigned kPostProcess = aiProcess_RemoveComponent | aiProcess_Triangulate |
                                  aiProcess_JoinIdenticalVertices | aiProcess_SortByPType;

// OMPL.app's RigidBodyGeometry reads robot and environment meshes with these steps and default
// importer settings; only its vertex mean is taken from such an import (ompl_app_center).
constexpr unsigned kOmplAppPostProcess = aiProcess_GenNormals | aiProcess_Triangulate |
                                         aiProcess_JoinIdenticalVertices | aiProcess_SortByPType |
                                         aiProcess_OptimizeGraph;

void ConfigureImporter(Assimp::Importer& importer) {
  importer.SetPropertyInteger(AI_CONFIG_PP_SBP_REMOVE,
                              aiPrimitiveType_POINT | aiPrimitiveType_LINE);
  importer.SetPropertyInteger(
      AI_CONFIG_PP_RVC_FLAGS,
      aiComponent_NORMALS | aiComponent_TANGENTS_AND_BITANGENTS | aiComponent_COLORS |
          aiComponent_TEXCOORDS | aiComponent_BONEWEIGHTS | aiComponent_ANIMATIONS |
          aiComponent_TEXTURES | aiComponent_LIGHTS | aiComponent_CAMERAS | aiComponent_MATERIALS);
  // Robotics scenes are Z-up; assimp would otherwise rotate Z-up COLLADA files into Y-up and the
  // obstacles would no longer match the coordinates written in the file.
  importer.SetPropertyBool(AI_CONFIG_IMPORT_COLLADA_IGNORE_UP_DIRECTION, true);
}

// Counts what AppendNode would copy, stopping as soon as a limit is passed: node instancing lets
// a small file name one large mesh many times.
bool WithinLimits(const aiScene& scene, const aiNode& node, int depth,
                  const MeshLoadOptions& limits, int64_t& vertices, int64_t& triangles) {
  if (depth > 1000) return false;
  for (unsigned i = 0; i < node.mNumMeshes; ++i) {
    if (node.mMeshes[i] >= scene.mNumMeshes) return false;
    const aiMesh& mesh = *scene.mMeshes[node.mMeshes[i]];
    vertices += mesh.mNumVertices;
    triangles += mesh.mNumFaces;
    if (vertices > limits.max_vertices || triangles > limits.max_triangles) return false;
  }
  for (unsigned c = 0; c < node.mNumChildren; ++c) {
    if (!WithinLimits(scene, *node.mChildren[c], depth + 1, limits, vertices, triangles)) {
      return false;
    }
  }
  return true;
}

// Sums the vertices under `node` as OMPL.app's scene::extractVertices and sceneCenter do: each
// in single precision, transformed by the product of the node transforms from the root, added
// to a single-precision sum. Copying that arithmetic makes the mean bit-identical to OMPL.app's.
void SumVerticesAsOmplApp(const aiScene& scene, const aiNode& node, aiMatrix4x4 transform,
                          aiVector3D& sum, uint64_t& count) {
  transform *= node.mTransformation;
  for (unsigned i = 0; i < node.mNumMeshes; ++i) {
    const aiMesh& mesh = *scene.mMeshes[node.mMeshes[i]];
    for (unsigned k = 0; k < mesh.mNumVertices; ++k) sum += transform * mesh.mVertices[k];
    count += mesh.mNumVertices;
  }
  for (unsigned c = 0; c < node.mNumChildren; ++c) {
    SumVerticesAsOmplApp(scene, *node.mChildren[c], transform, sum, count);
  }
}

}  // namespace

void CheckMeshScale(const MeshLoadOptions& options, const std::string& field) {
  for (int k = 0; k < 3; ++k) {
    if (!std::isfinite(options.scale[k]) || options.scale[k] <= 0) {
      throw InputError(field, "mesh scale[" + std::to_string(k) +
                                  "] must be positive and finite, got " +
                                  std::to_string(options.scale[k]));
    }
  }
}

namespace {

void AppendMesh(const aiMesh& in, const aiMatrix4x4& transform, const Eigen::Vector3d& scale,
                Mesh& out) {
  const size_t base = out.vertices.size();
  for (unsigned k = 0; k < in.mNumVertices; ++k) {
    const aiVector3D v = transform * in.mVertices[k];
    out.vertices.emplace_back(scale.x() * v.x, scale.y() * v.y, scale.z() * v.z);
  }
  for (unsigned f = 0; f < in.mNumFaces; ++f) {
    const aiFace& face = in.mFaces[f];
    if (face.mNumIndices != 3) continue;
    if (face.mIndices[0] >= in.mNumVertices || face.mIndices[1] >= in.mNumVertices ||
        face.mIndices[2] >= in.mNumVertices) {
      throw InputError("", "a face names a vertex the mesh does not have");
    }
    out.triangles.emplace_back(static_cast<int>(base + face.mIndices[0]),
                               static_cast<int>(base + face.mIndices[1]),
                               static_cast<int>(base + face.mIndices[2]));
  }
}

void AppendNode(const aiScene& scene, const aiNode& node, const aiMatrix4x4& parent,
                const Eigen::Vector3d& scale, Mesh& out) {
  const aiMatrix4x4 transform = parent * node.mTransformation;
  for (unsigned i = 0; i < node.mNumMeshes; ++i) {
    AppendMesh(*scene.mMeshes[node.mMeshes[i]], transform, scale, out);
  }
  for (unsigned c = 0; c < node.mNumChildren; ++c) {
    AppendNode(scene, *node.mChildren[c], transform, scale, out);
  }
}

std::shared_ptr<Mesh> Convert(const aiScene* scene, const Assimp::Importer& importer,
                              const std::string& what, const MeshLoadOptions& options,
                              const std::string& field) {
  if (scene == nullptr) {
    throw InputError(field, "cannot parse mesh " + what + ": " + importer.GetErrorString());
  }
  int64_t vertices = 0;
  int64_t triangles = 0;
  bool within = true;
  if (options.apply_node_transforms && scene->mRootNode != nullptr) {
    within = WithinLimits(*scene, *scene->mRootNode, 0, options, vertices, triangles);
  } else {
    for (unsigned i = 0; i < scene->mNumMeshes && within; ++i) {
      vertices += scene->mMeshes[i]->mNumVertices;
      triangles += scene->mMeshes[i]->mNumFaces;
      within = vertices <= options.max_vertices && triangles <= options.max_triangles;
    }
  }
  if (!within) {
    throw InputError(field, "mesh " + what + " is too large or malformed: more than " +
                                std::to_string(options.max_vertices) + " vertices or " +
                                std::to_string(options.max_triangles) +
                                " triangles after instancing, or a broken node tree");
  }
  auto mesh = std::make_shared<Mesh>();
  mesh->vertices.reserve(static_cast<size_t>(vertices));
  mesh->triangles.reserve(static_cast<size_t>(triangles));
  if (options.apply_node_transforms && scene->mRootNode != nullptr) {
    AppendNode(*scene, *scene->mRootNode, aiMatrix4x4(), options.scale, *mesh);
  } else {
    for (unsigned i = 0; i < scene->mNumMeshes; ++i) {
      AppendMesh(*scene->mMeshes[i], aiMatrix4x4(), options.scale, *mesh);
    }
  }
  if (mesh->triangles.empty()) throw InputError(field, "mesh " + what + " has no triangles");
  if (mesh->vertices.size() > static_cast<size_t>(std::numeric_limits<int>::max())) {
    throw InputError(field, "mesh " + what + " has too many vertices");
  }
  for (const Eigen::Vector3d& v : mesh->vertices) {
    if (!v.allFinite()) throw InputError(field, "mesh " + what + " has a non-finite vertex");
  }
  return mesh;
}

// Mesh::ompl_app_center from a second import of `bytes` with OMPL.app's steps. The COLLADA up
// axis is ignored as in the first import, so that the point is in the frame of the mesh's
// vertices; OMPL.app's frame differs from it by that rotation alone, which callers apply to both
// (ompl_cfg.cc). GenNormals and the per-normal copies can multiply the vertices, so the limits
// are checked again on this import.
Eigen::Vector3d OmplAppCenter(const std::string& bytes, const std::string& name,
                              const std::string& what, const MeshLoadOptions& options,
                              const std::string& field) {
  Assimp::Importer importer;
  importer.SetPropertyBool(AI_CONFIG_IMPORT_COLLADA_IGNORE_UP_DIRECTION, true);
  importer.SetIOHandler(new MemoryIOSystem({{name, &bytes}}));  // the importer owns it
  const aiScene* scene = importer.ReadFile(name, kOmplAppPostProcess);
  if (scene == nullptr || scene->mRootNode == nullptr || scene->mNumMeshes == 0) {
    throw InputError(field, "cannot parse mesh " + what + " as OMPL.app does: " +
                                (scene == nullptr ? std::string(importer.GetErrorString())
                                                  : std::string("no meshes")));
  }
  int64_t vertices = 0;
  int64_t triangles = 0;
  bool within = true;
  if (options.apply_node_transforms) {
    within = WithinLimits(*scene, *scene->mRootNode, 0, options, vertices, triangles);
  } else {
    for (unsigned i = 0; i < scene->mNumMeshes && within; ++i) {
      vertices += scene->mMeshes[i]->mNumVertices;
      within = vertices <= options.max_vertices;
    }
  }
  if (!within) {
    throw InputError(field, "mesh " + what + " is too large as OMPL.app imports it: more than " +
                                std::to_string(options.max_vertices) + " vertices or " +
                                std::to_string(options.max_triangles) + " faces");
  }
  aiVector3D sum(0, 0, 0);
  uint64_t count = 0;
  if (options.apply_node_transforms) {
    SumVerticesAsOmplApp(*scene, *scene->mRootNode, aiMatrix4x4(), sum, count);
  } else {
    for (unsigned i = 0; i < scene->mNumMeshes; ++i) {
      const aiMesh& mesh = *scene->mMeshes[i];
      for (unsigned k = 0; k < mesh.mNumVertices; ++k) sum += mesh.mVertices[k];
      count += mesh.mNumVertices;
    }
  }
  if (count == 0)
    throw InputError(field, "mesh " + what + " has no vertices as OMPL.app imports it");
  sum /= static_cast<float>(count);
  const Eigen::Vector3d center = options.scale.cwiseProduct(Eigen::Vector3d(sum.x, sum.y, sum.z));
  if (!center.allFinite()) {
    throw InputError(field,
                     "mesh " + what + " has a non-finite vertex mean as OMPL.app imports it");
  }
  return center;
}

// Imports `bytes` as the file `name` through a MemoryIOSystem that serves nothing else.
std::shared_ptr<const Mesh> Import(const std::string& bytes, const std::string& name,
                                   const std::string& what, const MeshLoadOptions& options,
                                   const std::string& field) {
  PrescanMeshBytes(bytes, field);
  std::shared_ptr<Mesh> mesh;
  {
    Assimp::Importer importer;
    ConfigureImporter(importer);
    importer.SetIOHandler(new MemoryIOSystem({{name, &bytes}}));  // the importer owns it
    const aiScene* scene = importer.ReadFile(name, kPostProcess);
    try {
      mesh = Convert(scene, importer, what, options, field);
    } catch (const Error& e) {
      if (!e.field().empty()) throw;
      throw InputError(field, "mesh " + what + ": " + e.what());
    }
  }
  if (options.ompl_app_center)
    mesh->ompl_app_center = OmplAppCenter(bytes, name, what, options, field);
  return mesh;
}

}  // namespace

std::shared_ptr<const Mesh> LoadMeshFile(const std::string& path, const MeshLoadOptions& options,
                                         const std::string& field) {
  CheckMeshScale(options, field);
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    throw Error(ErrorCode::kNotFound, field, "mesh file '" + path + "' does not exist");
  }
  if (!std::filesystem::is_regular_file(path, ec)) {
    throw InputError(field, "mesh path '" + path + "' is not a regular file");
  }
  std::ifstream in(path, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (!in && !in.eof()) throw InputError(field, "cannot read mesh file '" + path + "'");
  if (bytes.empty()) throw InputError(field, "mesh file '" + path + "' is empty");
  std::string extension = std::filesystem::path(path).extension().string();
  if (!extension.empty()) extension.erase(0, 1);
  for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return Import(bytes, "mesh." + extension, "'" + path + "'", options, field);
}

std::shared_ptr<const Mesh> LoadMeshBytes(const std::string& bytes, const std::string& format_hint,
                                          const MeshLoadOptions& options,
                                          const std::string& field) {
  CheckMeshScale(options, field);
  if (bytes.empty()) throw InputError(field, "mesh data is empty");
  const std::string hint =
      !format_hint.empty() && format_hint.front() == '.' ? format_hint.substr(1) : format_hint;
  if (hint.empty() || hint.size() > 16) {
    throw InputError(field, "the format hint must be a file extension of 1 to 16 characters");
  }
  for (char c : hint) {
    if (!std::isalnum(static_cast<unsigned char>(c))) {
      throw InputError(field, "the format hint must hold only letters and digits");
    }
  }
  return Import(bytes, "mesh." + hint,
                "(" + std::to_string(bytes.size()) + " bytes, format '" + hint + "')", options,
                field);
}

}  // namespace hgraph
