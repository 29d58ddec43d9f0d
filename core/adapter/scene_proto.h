// Conversions between hgraph.v1 scene messages (scene.proto, space.proto) and the core scene
// model. Every error is an InputError (or Error(kNotFound) for a missing mesh) whose field is the
// dotted path of the offending proto field, e.g. "scene.obstacles[3].shape.mesh.path".
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "core/scene/mesh_loader.h"
#include "core/scene/scene.h"
#include "core/space/space.h"
#include "hgraph/v1/scene.pb.h"
#include "hgraph/v1/space.pb.h"

namespace hgraph {

// Returns the bytes of a blob uploaded earlier, or nullopt if this process does not hold it
// (the service answers NOT_FOUND and the client re-uploads). Must be thread safe if the caller
// converts scenes from several threads.
using BlobResolver = std::function<std::optional<std::string>(const v1::Digest&)>;

// Parses mesh bytes (inline data or a blob) for SceneFromProto. The default parses them in this
// process (LoadMeshBytes); a server parses them in a child process (server/mesh_importer.h).
// Must throw InputError naming `field` for bad bytes.
using MeshBytesLoader = std::function<std::shared_ptr<const Mesh>(
    const std::string& bytes, const std::string& format, const MeshLoadOptions& options,
    const std::string& field)>;

// `field` prefixes every error ("scene.space").
Space SpaceFromProto(const v1::Space& proto, const std::string& field);
v1::Space SpaceToProto(const Space& space);

// Copies the values without validating them; validation against a Space is the caller's (so
// that the error names the caller's field).
Config ConfigFromProto(const v1::Configuration& proto);
v1::Configuration ConfigToProto(const Config& q);

// Position (0 or 3 values, default origin) and orientation (0 or 4 values, x y z w, default
// identity; a norm farther than 1e-3 from 1 is rejected, the rest is renormalised).
Eigen::Isometry3d PoseFromProto(const v1::Pose& proto, const std::string& field);

// Builds and validates a scene. Mesh paths are relative to base_dir unless absolute (an empty
// base_dir means the working directory). Digest meshes are looked up with `resolver`; an empty
// resolver rejects them. Start and goal are validated against the space and normalised. Mesh
// bytes go through `load_bytes` (empty: in process).
std::shared_ptr<const Scene> SceneFromProto(const v1::Scene& proto, const std::string& base_dir,
                                            const BlobResolver& resolver,
                                            const MeshBytesLoader& load_bytes = {});

// Reads a proto3 JSON scene file (snake_case names; unknown fields rejected, naming the file),
// or an OMPL.app problem if the name ends in .cfg (see ompl_cfg.h).
v1::Scene ReadSceneFile(const std::string& path);
// ReadSceneFile + SceneFromProto with meshes relative to the file's folder and no blob store.
std::shared_ptr<const Scene> LoadSceneFile(const std::string& path);

// The scene's default local-planner resolution: its `resolution` field if set (> 0), else the
// engine default 0.01. Throws InputError("scene.resolution") if negative or not finite.
double SceneResolution(const v1::Scene& proto);

}  // namespace hgraph
