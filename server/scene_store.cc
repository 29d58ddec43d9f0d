#include "server/scene_store.h"

#include <google/protobuf/io/coded_stream.h>
#include <google/protobuf/io/zero_copy_stream_impl_lite.h>

#include <utility>

#include "core/adapter/scene_proto.h"
#include "core/common/client_text.h"
#include "core/common/digest.h"
#include "core/common/error.h"
#include "server/status/status.h"

namespace hgraph::server {
namespace {

// What the cache keeps per scene beside its message: the collision world and its clearance
// bound, one entry so that they are counted, kept and evicted together.
struct SceneGeometry {
  std::shared_ptr<const CollisionWorld> world;
  std::shared_ptr<const ClearanceBound> clearance_bound;
};

// Deterministic encoding: the same Scene message always yields the same bytes, hence digest.
std::string CanonicalBytes(const v1::Scene& scene) {
  std::string bytes;
  {
    google::protobuf::io::StringOutputStream stream(&bytes);
    google::protobuf::io::CodedOutputStream coded(&stream);
    coded.SetSerializationDeterministic(true);
    if (!scene.SerializeToCodedStream(&coded) || coded.HadError()) {
      // Only a message past protobuf's 2 GiB limit fails here; gRPC's own limit is far lower.
      throw Error(ErrorCode::kResourceExhausted, "scene",
                  "cannot be serialized (" + std::to_string(scene.ByteSizeLong()) +
                      " bytes); store a smaller scene");
    }
  }
  return bytes;
}

// Meshes must be inline or uploaded: the server never opens a file named by a client.
void CheckMesh(const v1::Shape& shape, const std::string& field, const SceneStore& store) {
  if (!shape.has_mesh()) return;
  const v1::MeshRef& mesh = shape.mesh();
  const std::string mesh_field = field + ".mesh";
  switch (mesh.source_case()) {
    case v1::MeshRef::kPath:
      throw InputError(mesh_field + ".path",
                       "file paths are not accepted by the service; upload the file with "
                       "UploadBlob and refer to it by digest");
    case v1::MeshRef::kDigest:
      ValidateDigest(mesh.digest(), mesh_field + ".digest");
      if (!store.HasBlob(mesh.digest())) {
        throw ServiceError(grpc::StatusCode::NOT_FOUND, "BLOB_NOT_FOUND", mesh_field + ".digest",
                           "blob " + DigestText(mesh.digest()) +
                               " is not held by this server; upload it with UploadBlob first");
      }
      return;
    case v1::MeshRef::kData: return;
    case v1::MeshRef::SOURCE_NOT_SET:
      throw InputError(mesh_field, "one of data or digest must be set");
  }
}

// A digest names its content by hash and size: a right hash with a wrong size is refused.
void CheckSceneSize(const v1::Scene& scene, const v1::Digest& digest, const std::string& field) {
  const int64_t size = static_cast<int64_t>(scene.ByteSizeLong());
  if (size != digest.size_bytes()) {
    throw InputError(field + ".size_bytes", "scene sha256:" + digest.sha256() + " is " +
                                                std::to_string(size) + " bytes, the digest says " +
                                                std::to_string(digest.size_bytes()));
  }
}

}  // namespace

std::string DigestText(const v1::Digest& digest) {
  return "sha256:" + digest.sha256() + "/" + std::to_string(digest.size_bytes());
}

void ValidateDigest(const v1::Digest& digest, const std::string& field) {
  if (!IsSha256Hex(digest.sha256())) {
    throw InputError(field + ".sha256", "must be 64 lower-case hex digits, got \"" +
                                            ClientText(digest.sha256()) + "\"");
  }
  if (digest.size_bytes() < 0) {
    throw InputError(field + ".size_bytes",
                     "must be >= 0, got " + std::to_string(digest.size_bytes()));
  }
}

SceneStore::SceneStore(ResourceCache& cache, ServiceMetrics& metrics, MeshImporter importer,
                       bool clearance_bound, SharedState* shared)
    : cache_(cache),
      metrics_(metrics),
      importer_(std::move(importer)),
      clearance_bound_(clearance_bound),
      shared_(shared) {}

bool SceneStore::HasBlob(const v1::Digest& digest) const {
  auto blob = cache_.Get<const std::string>(CacheKind::kBlob, digest.sha256());
  if (blob != nullptr) return static_cast<int64_t>(blob->size()) == digest.size_bytes();
  return shared_ != nullptr && shared_->HasBlob(digest);
}

std::shared_ptr<const std::string> SceneStore::FindBlob(const v1::Digest& digest) const {
  auto blob = cache_.Get<const std::string>(CacheKind::kBlob, digest.sha256());
  if (blob || shared_ == nullptr) return blob;
  std::optional<std::string> bytes = shared_->GetBlob(digest);
  if (!bytes) return nullptr;
  const size_t size = bytes->size();
  blob = std::make_shared<const std::string>(std::move(*bytes));
  cache_.Put(CacheKind::kBlob, digest.sha256(), blob, size);
  return blob;
}

std::vector<std::string> SceneStore::BlobsOf(const v1::Digest& scene) const {
  std::vector<std::string> out;
  auto proto = cache_.Get<const v1::Scene>(CacheKind::kScene, scene.sha256());
  if (!proto) return out;
  const auto add = [&](const v1::Shape& shape) {
    if (shape.has_mesh() && shape.mesh().has_digest())
      out.push_back(shape.mesh().digest().sha256());
  };
  for (const auto& o : proto->obstacles()) add(o.shape());
  for (const auto& r : proto->robot()) add(r.shape());
  return out;
}

bool SceneStore::PutBlob(const v1::Digest& declared, std::string bytes) {
  ValidateDigest(declared, "digest");
  if (static_cast<int64_t>(bytes.size()) != declared.size_bytes()) {
    throw InputError("digest.size_bytes", "declared " + std::to_string(declared.size_bytes()) +
                                              " bytes, received " + std::to_string(bytes.size()));
  }
  const std::string actual = Sha256Hex(bytes);
  if (actual != declared.sha256()) {
    throw InputError("digest.sha256",
                     "declared " + declared.sha256() + ", the bytes received hash to " + actual);
  }
  if (auto held = cache_.Get<const std::string>(CacheKind::kBlob, declared.sha256());
      held != nullptr && static_cast<int64_t>(held->size()) == declared.size_bytes()) {
    return false;
  }
  const size_t size = bytes.size();
  auto blob = std::make_shared<const std::string>(std::move(bytes));
  if (!cache_.Put(CacheKind::kBlob, declared.sha256(), blob, size)) {
    throw Error(ErrorCode::kResourceExhausted, "digest.size_bytes",
                std::to_string(size) + " bytes exceed the server's cache budget (--cache-bytes=" +
                    std::to_string(cache_.budget_bytes()) + ")");
  }
  if (shared_ != nullptr) shared_->PutBlob(declared.sha256(), *blob);
  return true;
}

v1::Digest SceneStore::PutScene(const v1::Scene& scene, const CancelToken& token) {
  for (int i = 0; i < scene.obstacles_size(); ++i) {
    CheckMesh(scene.obstacles(i).shape(), "scene.obstacles[" + std::to_string(i) + "].shape",
              *this);
  }
  for (int i = 0; i < scene.robot_size(); ++i) {
    CheckMesh(scene.robot(i).shape(), "scene.robot[" + std::to_string(i) + "].shape", *this);
  }
  const std::string bytes = CanonicalBytes(scene);
  v1::Digest digest;
  digest.set_sha256(Sha256Hex(bytes));
  digest.set_size_bytes(static_cast<int64_t>(bytes.size()));
  if (!cache_.Contains(CacheKind::kScene, digest.sha256())) {
    if (!cache_.Put(CacheKind::kScene, digest.sha256(), std::make_shared<const v1::Scene>(scene),
                    bytes.size())) {
      throw Error(ErrorCode::kResourceExhausted, "scene",
                  "the scene's " + std::to_string(bytes.size()) +
                      " bytes exceed the server's cache budget");
    }
  }
  try {
    Get(digest, "scene", token);
  } catch (...) {
    // A scene that does not load must not be found by a later CreateSession.
    cache_.Erase(CacheKind::kScene, digest.sha256());
    throw;
  }
  if (shared_ != nullptr) shared_->PutScene(digest, bytes);
  return digest;
}

bool SceneStore::HasScene(const v1::Digest& digest) const {
  return cache_.Contains(CacheKind::kScene, digest.sha256());
}

LoadedScene SceneStore::Get(const v1::Digest& digest, const std::string& field,
                            const CancelToken& token) {
  ValidateDigest(digest, field);
  const std::string& sha = digest.sha256();
  std::shared_future<LoadedScene> pending;
  std::promise<LoadedScene> promise;
  {
    std::lock_guard lock(loading_mutex_);
    if (auto geometry = cache_.Get<const SceneGeometry>(CacheKind::kWorld, sha)) {
      auto proto = cache_.Get<const v1::Scene>(CacheKind::kScene, sha);
      if (proto) {
        CheckSceneSize(*proto, digest, field);
        metrics_.scene_cache_hits.Increment();
        return LoadedScene{proto, geometry->world, geometry->clearance_bound};
      }
    }
    if (auto it = loading_.find(sha); it != loading_.end()) {
      pending = it->second;
    } else {
      loading_[sha] = promise.get_future().share();
    }
  }
  if (pending.valid()) {
    // Another call is loading the same scene: this one shares its result.
    metrics_.scene_cache_hits.Increment();
    return pending.get();
  }
  metrics_.scene_cache_misses.Increment();
  try {
    LoadedScene loaded = Load(digest, field, token);
    promise.set_value(loaded);
    std::lock_guard lock(loading_mutex_);
    loading_.erase(sha);
    return loaded;
  } catch (...) {
    promise.set_exception(std::current_exception());
    std::lock_guard lock(loading_mutex_);
    loading_.erase(sha);
    throw;
  }
}

LoadedScene SceneStore::Load(const v1::Digest& digest, const std::string& field,
                             const CancelToken& token) {
  const std::string& sha = digest.sha256();
  auto proto = cache_.Get<const v1::Scene>(CacheKind::kScene, sha);
  if (!proto && shared_ != nullptr) {
    if (std::optional<v1::Scene> stored = shared_->GetScene(digest)) {
      const size_t size = stored->ByteSizeLong();
      proto = std::make_shared<const v1::Scene>(std::move(*stored));
      cache_.Put(CacheKind::kScene, sha, proto, size);
    }
  }
  if (!proto) {
    throw ServiceError(grpc::StatusCode::NOT_FOUND, "SCENE_NOT_FOUND", field,
                       "scene sha256:" + sha +
                           " is not held by this server (never stored, or evicted under the "
                           "memory budget); store it again with PutScene");
  }
  CheckSceneSize(*proto, digest, field);
  BlobResolver resolver = [this](const v1::Digest& blob_digest) -> std::optional<std::string> {
    auto blob = FindBlob(blob_digest);
    if (!blob) return std::nullopt;
    return *blob;
  };
  std::shared_ptr<const Scene> scene;
  try {
    // Client bytes are parsed only out of process.
    const MeshBytesLoader load_bytes = [&](const std::string& bytes, const std::string& format,
                                           const MeshLoadOptions& options,
                                           const std::string& mesh_field) {
      return importer_.Import(bytes, format, options, mesh_field, token);
    };
    scene = SceneFromProto(*proto, "", resolver, load_bytes);
  } catch (const Error& e) {
    // A blob evicted since PutScene: the client uploads it again.
    if (e.code() == ErrorCode::kNotFound) {
      throw ServiceError(grpc::StatusCode::NOT_FOUND, "BLOB_NOT_FOUND", field, e.what());
    }
    throw;
  }
  auto geometry = std::make_shared<SceneGeometry>();
  geometry->world = std::make_shared<const CollisionWorld>(scene);
  if (clearance_bound_) geometry->clearance_bound = BuildClearanceBound(geometry->world);
  const size_t bytes =
      geometry->world->memory_bytes() +
      (geometry->clearance_bound ? ClearanceBoundBytes(*geometry->clearance_bound) : 0);
  metrics_.scene_loads.Increment();
  // A world that cannot be kept would be loaded again by every call that names the scene.
  if (!cache_.Put(CacheKind::kWorld, sha, geometry, bytes)) {
    throw Error(ErrorCode::kResourceExhausted, field,
                "scene sha256:" + sha + " needs " + std::to_string(bytes) +
                    " bytes of collision geometry and clearance bound, more than the server's "
                    "cache budget (--cache-bytes=" +
                    std::to_string(cache_.budget_bytes()) + ")");
  }
  return LoadedScene{proto, geometry->world, geometry->clearance_bound};
}

}  // namespace hgraph::server
