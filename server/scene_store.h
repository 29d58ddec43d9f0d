// Content-addressed blobs and scenes, and the collision worlds loaded from them. Everything is
// kept in the shared ResourceCache, so a scene evicted under the memory budget is loaded again
// from its stored message if that is still held, and otherwise reported as NOT_FOUND.
#pragma once

#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "core/collision/collision_world.h"
#include "core/common/progress.h"
#include "core/motion/local_planner.h"
#include "hgraph/v1/scene.pb.h"
#include "server/mesh_importer.h"
#include "server/metrics.h"
#include "server/resource_cache.h"
#include "server/shared_state.h"

namespace hgraph::server {

// A stored scene ready to check motions in. Copyable (shared, immutable parts).
struct LoadedScene {
  std::shared_ptr<const v1::Scene> proto;
  std::shared_ptr<const CollisionWorld> world;
  // The world's cheap lower bound on clearance (BuildClearanceBound), for every local planner
  // of the scene; null where none pays or the server runs without it.
  std::shared_ptr<const ClearanceBound> clearance_bound;
};

// Thread safe. Not copyable.
class SceneStore {
 public:
  // Mesh bytes are parsed by `importer`, in a child process per mesh.
  // With clearance_bound, every scene loaded gets its clearance bound too (built once, cached
  // with its collision world and counted with it in the cache's budget).
  // With `shared` (may be null; outlives this), blobs and scenes are written to the shared
  // store as they are stored here, and one not held here is looked up there before NOT_FOUND.
  SceneStore(ResourceCache& cache, ServiceMetrics& metrics, MeshImporter importer,
             bool clearance_bound = false, SharedState* shared = nullptr);
  SceneStore(const SceneStore&) = delete;
  SceneStore& operator=(const SceneStore&) = delete;

  bool HasBlob(const v1::Digest& digest) const;
  // The mesh digests (SHA-256) of a scene held here; empty when it is not.
  std::vector<std::string> BlobsOf(const v1::Digest& scene) const;
  // Verifies the bytes against `declared` (size, then SHA-256) and stores them. Returns false if
  // the blob was already held. Throws InputError naming "digest.size_bytes" or
  // "digest.sha256" on a mismatch, Error(kResourceExhausted) if it exceeds the cache budget.
  bool PutBlob(const v1::Digest& declared, std::string bytes);

  // Checks that every mesh is inline or an uploaded blob, stores the scene under the digest of
  // its canonical serialization, and loads it (so that errors in it are reported now, naming
  // the field). Returns the digest.
  // `token` bounds the mesh imports (deadline, cancellation).
  v1::Digest PutScene(const v1::Scene& scene, const CancelToken& token = CancelToken());

  // The scene and its collision world, built on first use and shared by every session that
  // names the same digest; concurrent first uses wait for one load. Throws Error(kNotFound,
  // field) if the scene (or a blob it needs) is not held, InputError(field + ".size_bytes") if
  // the digest's size is not the scene's.
  LoadedScene Get(const v1::Digest& digest, const std::string& field,
                  const CancelToken& token = CancelToken());
  bool HasScene(const v1::Digest& digest) const;

 private:
  LoadedScene Load(const v1::Digest& digest, const std::string& field, const CancelToken& token);
  // The blob from the cache, or from the shared store (then cached); null if neither holds it.
  std::shared_ptr<const std::string> FindBlob(const v1::Digest& digest) const;

  ResourceCache& cache_;
  ServiceMetrics& metrics_;
  MeshImporter importer_;
  bool clearance_bound_;
  SharedState* shared_;
  std::mutex loading_mutex_;
  std::map<std::string, std::shared_future<LoadedScene>> loading_;
};

// "sha256:<hex>/<size>" for messages and logs.
std::string DigestText(const v1::Digest& digest);
// Throws InputError(field + ".sha256" / ".size_bytes") unless the digest is well formed.
void ValidateDigest(const v1::Digest& digest, const std::string& field);

}  // namespace hgraph::server
