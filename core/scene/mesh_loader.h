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
  // Also compute Mesh::ompl_app_center: the mean of the vertices as OMPL.app's own import leaves
  // them (RigidBodyGeometry: aiProcess_GenNormals | Triangulate | JoinIdenticalVertices |
  // SortByPType | OptimizeGraph, default importer settings, every mesh of every node). Normals
  // are kept there, so a corner shared by faces of different normals counts once per normal,
  // and points and lines count too; the mean therefore differs from that of `vertices` (joined
  // by position alone) for most meshes that are not symmetric. It is the point OMPL.app puts at
  // a configuration's position. A second assimp import of the same bytes, under the same
  // limits, in the same process as the first (for a server: the importer child).
  bool ompl_app_center = false;
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
