// Loads triangle meshes with assimp (OBJ, STL, PLY, DAE, glTF, and every other format assimp
// reads). Thread safe: each call uses its own importer.
//
// assimp only ever sees the mesh's own bytes, through a MemoryIOSystem: a file name written inside
// a mesh (OBJ mtllib, glTF buffer uri, ...) is never opened, whether it exists or not. Declared
// OFF/PLY counts are checked against the bytes first (mesh_prescan.h). This is still assimp in
// the calling process: a server parses untrusted bytes through MeshImporter (server/), which runs
// this code in a child process with memory, CPU and time limits.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>

#include "core/scene/scene.h"

namespace hgraph {

struct MeshLoadOptions {
  Eigen::Vector3d scale = Eigen::Vector3d::Ones();  // applied to every vertex after loading
  // Apply the scene graph's node transforms (as OMPL.app does). When false, the meshes of all
  // nodes are merged in their own frames.
  bool apply_node_transforms = true;
  // Larger meshes are refused (after node instancing, before copying them out of assimp).
  int64_t max_vertices = int64_t{1} << 23;
  int64_t max_triangles = int64_t{1} << 23;
};

// Throws InputError(field) unless every scale factor is positive and finite.
void CheckMeshScale(const MeshLoadOptions& options, const std::string& field);

// Reads a mesh file (only that file: names inside it are not opened). Throws Error(kNotFound)
// naming `field` if the file is missing, and InputError naming `field` if assimp cannot parse it or
// it has no triangles.
std::shared_ptr<const Mesh> LoadMeshFile(const std::string& path, const MeshLoadOptions& options,
                                         const std::string& field);

// Parses a mesh from bytes; `format_hint` is the file extension without the dot ("obj"), letters
// and digits only. Throws InputError naming `field` for anything wrong with the bytes.
std::shared_ptr<const Mesh> LoadMeshBytes(const std::string& bytes, const std::string& format_hint,
                                          const MeshLoadOptions& options, const std::string& field);

}  // namespace hgraph
