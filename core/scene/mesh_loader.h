// Loads triangle meshes with assimp (OBJ, STL, PLY, DAE, glTF, and every other format assimp
// reads). Thread safe: each call uses its own importer.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <string>

#include "core/scene/scene.h"

namespace hgraph {

struct MeshLoadOptions {
  Eigen::Vector3d scale = Eigen::Vector3d::Ones();  // applied to every vertex after loading
  // Apply the scene graph's node transforms (as OMPL.app does). When false, the meshes of all
  // nodes are merged in their own frames.
  bool apply_node_transforms = true;
};

// Reads a mesh file. Throws Error(kNotFound) naming `field` if the file is missing, and
// InputError naming `field` if assimp cannot parse it or it has no triangles.
std::shared_ptr<const Mesh> LoadMeshFile(const std::string& path, const MeshLoadOptions& options,
                                         const std::string& field);

// Parses a mesh from bytes; `format_hint` is the file extension without the dot ("obj").
std::shared_ptr<const Mesh> LoadMeshBytes(const std::string& bytes, const std::string& format_hint,
                                          const MeshLoadOptions& options, const std::string& field);

}  // namespace hgraph
