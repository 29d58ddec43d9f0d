// What the replicas share through the store (server/store.h), and how it is laid out:
//
//   hgraph:1:blob:<sha256>          the blob's bytes (content-addressed: checked on read)
//   hgraph:1:scene:<sha256>         the scene's canonical bytes (checked on read)
//   hgraph:1:session:<id>           a session record: tenant, scene digest, create time
//   hgraph:1:hgraph:<id>:<hgraph>   an H-Graph record: a versioned snapshot (compare-and-set)
//   hgraph:1:tenant:<sha256>:sessions  a set: the names of a tenant's sessions (ListSessions;
//                                   <sha256> of the tenant's name)
//   hgraph:1:session-hgraphs:<id>   a set: the names of a session's H-Graphs (DeleteSession)
//
// Every entry expires: a session's record and its H-Graphs after the session's time-to-live
// (extended while the session is used), blobs and scenes with the sessions that use them.
//
// The store is a cache shared by replicas, not the source of truth for one call: every
// operation here catches the store's errors, counts them (hgraph_store_errors_total), logs them
// at most once per interval, and answers "not there" or "not stored", so that a store that is
// down or slow leaves each replica serving from its memory. An entry that is corrupt, truncated,
// of another format or of another name than its key is refused the same way
// (hgraph_store_refused_total), never trusted.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "hgraph/v1/scene.pb.h"
#include "hgraph/v1/service.pb.h"
#include "server/metrics.h"
#include "server/store.h"

namespace hgraph {
class HybridizationSession;
}  // namespace hgraph

namespace hgraph::server {

struct SessionRecord {
  std::string tenant;
  v1::Digest scene;
  int64_t create_time_ns = 0;  // since the Unix epoch
};

// A kept H-Graph, as a replica that did not build it needs it to answer as the builder would.
struct HGraphRecord {
  std::string name;  // "sessions/<id>/hgraphs/<hgraph id>"
  std::string tenant;
  v1::Digest scene;
  double resolution = 0;  // the local planner's
  int64_t generation = 1;
  v1::Measure measure;
  v1::MergeOptions options;
  std::string fingerprint;  // of the MergePathsRequest (a repeat of its hgraph_id)
  v1::MergePathsResponse answer;
  std::vector<std::string> input_names;
  // AddPaths' request ids, oldest first, each with the fingerprint of its request and its
  // answer, so that a repeat on any replica answers as the first (StoredHGraph::requests).
  struct Request {
    std::string id;
    std::string fingerprint;
    v1::AddPathsResponse answer;
  };
  std::vector<Request> requests;
  std::string session;  // core/merge/snapshot.h's bytes
};

// Thread safe. Not copyable.
class SharedState {
 public:
  // Entries expire `ttl` (the session time-to-live) after their last write or refresh, plus a
  // margin so that a replica's own expiry of a session comes first.
  SharedState(std::shared_ptr<Store> store, std::chrono::milliseconds ttl, ServiceMetrics& metrics);
  SharedState(const SharedState&) = delete;
  SharedState& operator=(const SharedState&) = delete;

  std::string Describe() const { return store_->Describe(); }

  void PutBlob(const std::string& sha256, const std::string& bytes);
  bool HasBlob(const v1::Digest& digest);
  // The blob's bytes if held and matching the digest.
  std::optional<std::string> GetBlob(const v1::Digest& digest);
  void PutScene(const v1::Digest& digest, const std::string& canonical_bytes);
  std::optional<v1::Scene> GetScene(const v1::Digest& digest);

  // Writes the session's record and lists it among its tenant's sessions.
  void PutSession(const std::string& name, const SessionRecord& record);
  std::optional<SessionRecord> GetSession(const std::string& name);
  // The tenant's sessions the store holds, by name (nullopt when the store failed). Names whose
  // record has expired are dropped from the tenant's list.
  std::optional<std::map<std::string, SessionRecord>> ListSessions(const std::string& tenant);
  // The names of the session's H-Graphs that any replica wrote, in name order (none on failure).
  std::vector<std::string> HGraphsOf(const std::string& session);
  // How long the session's record lives yet, less the margin the store adds to it (nullopt:
  // absent, or the store failed).
  std::optional<std::chrono::milliseconds> SessionTimeToLive(const std::string& session);
  // Removes the session's record, its records of H-Graphs (the named ones, and every one any
  // replica wrote), and its name from the tenant's list.
  void DeleteSession(const std::string& name, const std::string& tenant,
                     const std::vector<std::string>& hgraphs);
  void DeleteHGraph(const std::string& hgraph);
  // Extends the expiry of a session's entries: its record, its H-Graphs and their list, its
  // tenant's list of sessions, its scene and the scene's blobs (mesh digests).
  void Refresh(const std::string& session, const std::string& tenant,
               const std::vector<std::string>& hgraphs, const v1::Digest& scene,
               const std::vector<std::string>& blob_sha256s);

  enum class Write {
    kStored,    // the record holds what was written
    kConflict,  // another replica wrote a newer version first (compare-and-set): nothing written
    kFailed,    // the store failed (counted and logged): nothing written
  };
  // Writes the record as `version`: over whatever is there when `expected_version` is 0 (a new
  // merge), else only over version `expected_version` (an addition, a requery's new checks).
  Write PutHGraph(const HGraphRecord& record, uint64_t expected_version, uint64_t version);
  // The same in two steps: the record's value as `version` (the snapshot of `session` if given,
  // written in place, else record.session), built while the caller holds the session still;
  // then its checksum and the write, the caller's lock released. `value` is EncodeHGraph's.
  static std::string EncodeHGraph(const HGraphRecord& record, uint64_t version,
                                  const HybridizationSession* session = nullptr);
  Write PutHGraph(const std::string& name, std::string& value, uint64_t expected_version);
  // The record and its version, if held and sound.
  std::optional<std::pair<uint64_t, HGraphRecord>> GetHGraph(const std::string& name);
  // The version of the record held (0 when none is, or on failure), read without the snapshot.
  uint64_t HGraphVersion(const std::string& name);

  // Whether the last operation failed (a metric and the health of the store, not of the server).
  bool healthy() const { return healthy_; }

  static std::string BlobKey(const std::string& sha256);
  static std::string SceneKey(const std::string& sha256);
  static std::string SessionKey(const std::string& session);
  static std::string HGraphKey(const std::string& hgraph);
  static std::string TenantSessionsKey(const std::string& tenant);
  static std::string SessionHGraphsKey(const std::string& session);

 private:
  // Counts a failed operation and logs it, at most once per interval (with the number of
  // failures not logged).
  void Failed(const char* op, const std::string& what);
  void Succeeded();
  // Counts and logs an entry refused as unsound.
  void Refused(const char* kind, const std::string& key, const std::string& why);
  // A session record read under `key`, or nullopt (refused) when it does not parse.
  std::optional<SessionRecord> ParseSession(const std::string& key, std::string_view value);

  std::shared_ptr<Store> store_;
  const std::chrono::milliseconds ttl_;
  ServiceMetrics& metrics_;
  std::atomic<bool> healthy_{true};
  std::mutex log_mutex_;
  std::chrono::steady_clock::time_point last_log_{};
  int64_t unlogged_ = 0;
};

}  // namespace hgraph::server
