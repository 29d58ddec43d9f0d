// The hgraph.v1.PathMerger service on the gRPC callback API. gRPC threads only parse, look up
// and start writes; every CPU-bound step runs as a job on the WorkerPool, whose admission queue
// answers RESOURCE_EXHAUSTED when full. Deadlines and client cancellation reach the engine
// through a CancelToken per call.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>

#include "core/common/progress.h"
#include "hgraph/v1/service.grpc.pb.h"
#include "server/arena_allocator.h"
#include "server/auth.h"
#include "server/mesh_importer.h"
#include "server/metrics.h"
#include "server/resource_cache.h"
#include "server/scene_store.h"
#include "server/session_registry.h"
#include "server/shared_state.h"
#include "server/store.h"
#include "server/worker_pool.h"

namespace hgraph::server {

// Limits and sizes, all set from flags (server/main.cc documents each).
struct ServerOptions {
  int threads = 1;
  int max_admitted = 64;
  int max_paths = 256;
  int max_waypoints = 100000;
  int max_sessions = 1000;
  size_t cache_bytes = size_t{2} << 30;
  int64_t max_blob_bytes = int64_t{256} << 20;
  std::chrono::milliseconds session_ttl{std::chrono::hours(1)};
  int progress_interval_ms = 100;
  MeshImportLimits mesh_import;  // how client mesh bytes are parsed (out of process)
  // Build each scene's clearance bound (core/distance: a distance field, 1-4 MB and up to a few
  // seconds per mesh scene, once) and let certificates ask it before FCL's exact distance. Off:
  // on the bench's problems it saves 6-36% of the distance queries but at most 14% of a merge's
  // time (docs/performance.md).
  bool clearance_bound = false;
  Authenticator auth;  // --auth-tokens: who a call comes from (open without it)
  // An UploadBlob stream that sends nothing for this long is aborted (ExpireIdleUploads).
  std::chrono::milliseconds upload_idle_timeout{std::chrono::seconds(30)};
  // Per-tenant quotas (0 = none): live sessions, and bytes of kept H-Graphs in the cache.
  int tenant_max_sessions = 0;
  size_t tenant_cache_bytes = 0;
  // --store: what the replicas share (server/shared_state.h); null shares nothing (memory).
  std::shared_ptr<Store> store;
};

// Thread safe. Not copyable or movable (reactors point into it).
class PathMergerService final : public v1::PathMerger::CallbackService {
 public:
  PathMergerService(const ServerOptions& options, Metrics& metrics);
  ~PathMergerService() override;

  grpc::ServerUnaryReactor* FindMissingBlobs(grpc::CallbackServerContext* context,
                                             const v1::FindMissingBlobsRequest* request,
                                             v1::FindMissingBlobsResponse* response) override;
  grpc::ServerReadReactor<v1::UploadBlobRequest>* UploadBlob(
      grpc::CallbackServerContext* context, v1::UploadBlobResponse* response) override;
  grpc::ServerUnaryReactor* PutScene(grpc::CallbackServerContext* context,
                                     const v1::PutSceneRequest* request,
                                     v1::PutSceneResponse* response) override;
  grpc::ServerUnaryReactor* CreateSession(grpc::CallbackServerContext* context,
                                          const v1::CreateSessionRequest* request,
                                          v1::Session* response) override;
  grpc::ServerUnaryReactor* GetSession(grpc::CallbackServerContext* context,
                                       const v1::GetSessionRequest* request,
                                       v1::Session* response) override;
  grpc::ServerUnaryReactor* ListSessions(grpc::CallbackServerContext* context,
                                         const v1::ListSessionsRequest* request,
                                         v1::ListSessionsResponse* response) override;
  grpc::ServerUnaryReactor* DeleteSession(grpc::CallbackServerContext* context,
                                          const v1::DeleteSessionRequest* request,
                                          v1::DeleteSessionResponse* response) override;
  grpc::ServerWriteReactor<v1::MergePathsResponse>* MergePaths(
      grpc::CallbackServerContext* context, const v1::MergePathsRequest* request) override;
  grpc::ServerUnaryReactor* Requery(grpc::CallbackServerContext* context,
                                    const v1::RequeryRequest* request,
                                    v1::RequeryResponse* response) override;
  grpc::ServerUnaryReactor* AddPaths(grpc::CallbackServerContext* context,
                                     const v1::AddPathsRequest* request,
                                     v1::AddPathsResponse* response) override;
  grpc::ServerWriteReactor<v1::PlanPathsResponse>* PlanPaths(
      grpc::CallbackServerContext* context, const v1::PlanPathsRequest* request) override;
  grpc::ServerWriteReactor<v1::SolveResponse>* Solve(grpc::CallbackServerContext* context,
                                                     const v1::SolveRequest* request) override;
  grpc::ServerUnaryReactor* CheckPaths(grpc::CallbackServerContext* context,
                                       const v1::CheckPathsRequest* request,
                                       v1::CheckPathsResponse* response) override;
  grpc::ServerUnaryReactor* GetHGraph(grpc::CallbackServerContext* context,
                                      const v1::GetHGraphRequest* request,
                                      v1::HGraph* response) override;
  grpc::ServerUnaryReactor* DeleteHGraph(grpc::CallbackServerContext* context,
                                         const v1::DeleteHGraphRequest* request,
                                         v1::DeleteHGraphResponse* response) override;

  // Drops sessions idle past their time-to-live and their H-Graphs; called periodically.
  void ExpireIdleSessions();
  // With a shared store: writes the check reports requeries added since the last call (one
  // snapshot per H-Graph changed), and extends the store's expiry of the sessions used since;
  // called periodically, off the gRPC and worker threads.
  void SyncStore();
  // Aborts UploadBlob streams idle past options().upload_idle_timeout (ABORTED), releasing
  // their reserved bytes and admission slots; called periodically.
  void ExpireIdleUploads();
  // Cancels the merges that outlived their clients (MergePathsRequest.hgraph_id), and makes
  // every other one stop with its call: called before the gRPC server shuts down, whose
  // cancellation of the calls at the end of the grace period then stops them.
  void BeginShutdown();
  // Waits for every admitted job (after the gRPC server has shut down).
  void WaitIdle() { pool_.WaitIdle(); }

  // Call bookkeeping shared by the reactors: one log line and the gRPC metrics per call.
  void RecordCall(const std::string& method, const std::string& session,
                  std::chrono::steady_clock::time_point started, const grpc::Status& status);
  WorkerPool& pool() { return pool_; }
  const ServerOptions& options() const { return options_; }
  Metrics& metrics() { return metrics_; }

  struct StoredHGraph;
  class CallBase;
  template <typename Response>
  class StreamingCall;
  // Counts the call as started (grpc_server_started_total) and returns its start time.
  std::chrono::steady_clock::time_point RecordStart(const std::string& method);

 private:
  class UnaryCall;
  class UploadCall;
  class MergeCall;
  class PlanCall;
  class SolveCall;

  void DropHGraphs(const std::vector<std::string>& names);
  // The stored H-Graph `name` ("sessions/<id>/hgraphs/<hgraph id>", named `field` in errors)
  // for `tenant`: its session touched (NOT_FOUND / PERMISSION_DENIED as SessionRegistry::Touch),
  // NOT_FOUND (HGRAPH_NOT_FOUND) if the cache no longer holds it.
  // With a shared store, one not held here is loaded from it, and one held here that another
  // replica has changed since is loaded again.
  // `first_use`: LoadHGraph's, when this call loads it (`*used` then says it ran).
  std::shared_ptr<StoredHGraph> HeldHGraph(const std::string& name, const std::string& tenant,
                                           const std::string& field = "hgraph",
                                           const std::function<void(StoredHGraph&)>& first_use = {},
                                           bool* used = nullptr);
  // Throws ServiceError RESOURCE_EXHAUSTED TENANT_QUOTA when the tenant's kept H-Graphs hold
  // --tenant-cache-bytes or more (before a merge or an addition grows them).
  void CheckTenantCache(const std::string& tenant);
  // SessionRegistry::Touch, except that with a shared store a session this replica does not
  // hold is read from it (and adopted) before NOT_FOUND.
  v1::Session TouchSession(const std::string& name, const std::string& field,
                           const std::string& tenant);
  // ListSessions with a shared store: the tenant's sessions held here or listed in the store,
  // in name order after `after`, at most `page_size` (`more` set when others follow), each with
  // the H-Graphs any replica wrote to the store. Neither loads nor extends a session.
  void ListSharedSessions(const std::string& tenant, const std::string& after, size_t page_size,
                          bool* more, v1::ListSessionsResponse* response);
  // The H-Graph as the shared store holds it, loaded, cached and adopted by its session; null
  // when there is no store, it holds no such H-Graph, or what it holds is unsound (logged).
  // Its session must be held here (the caller has touched it).
  // `first_use`, if given, runs on the loaded H-Graph before any other call can reach it (a
  // requery's search, on the H-Graph itself rather than on a copy); when it throws, nothing is
  // kept and the exception propagates.
  std::shared_ptr<StoredHGraph> LoadHGraph(
      const std::string& name, const std::string& tenant, const std::string& field,
      const std::function<void(StoredHGraph&)>& first_use = {});
  // Writes the H-Graph's snapshot to the shared store as its next version: over whatever is
  // there (a merge), or only over the version this replica last wrote or loaded (`cas`).
  // Returns kStored with no store.
  SharedState::Write SaveHGraph(const std::string& name, StoredHGraph& stored, bool cas);
  // Counts a stored H-Graph that a query or an addition grew at its size now
  // (ResourceCache::Resize), so that the cache's budget bounds what the stored H-Graphs hold.
  // Returns whether the cache still holds it: KEPT, TOO_LARGE (grown past the whole budget,
  // now dropped) or DROPPED (evicted or deleted before this call counted it).
  v1::Retention Reaccount(const std::string& name, StoredHGraph& stored);
  void AddUpload(UploadCall* call);
  void RemoveUpload(UploadCall* call);
  void RecordMerge(const std::string& method, const v1::MergeResult& result);
  // A merge whose client went away but that goes on (hgraph_id) registers its token, so that
  // BeginShutdown can cancel it; false when the server is shutting down (the caller cancels it).
  bool AddDurable(const CancelToken& token, uint64_t* id);
  void RemoveDurable(uint64_t id);

  ServerOptions options_;
  Metrics& metrics_;
  ServiceMetrics families_;  // declared in metrics_; before scenes_, which counts into them
  ResourceCache cache_;
  std::unique_ptr<SharedState> shared_;  // null without a shared store; before scenes_
  SceneStore scenes_;
  SessionRegistry sessions_;
  WorkerPool pool_;
  std::mutex uploads_mutex_;
  std::set<UploadCall*> uploads_;  // unfinished UploadBlob streams
  std::mutex durable_mutex_;
  bool shutting_down_ = false;
  uint64_t next_durable_ = 0;
  std::map<uint64_t, CancelToken> durable_;  // merges that outlive their clients
  std::mutex store_mutex_;
  std::set<std::string> unsynced_;  // H-Graphs whose requeries added checks not yet stored
  SessionRegistry::Clock::time_point last_refresh_{};
  std::mutex hgraph_loading_mutex_;  // one load from the shared store at a time
  // The responses that carry a merged path (arena_allocator.h).
  ArenaMessageAllocator<v1::GetHGraphRequest, v1::HGraph> get_hgraph_messages_;
  ArenaMessageAllocator<v1::RequeryRequest, v1::RequeryResponse> requery_messages_;
  ArenaMessageAllocator<v1::AddPathsRequest, v1::AddPathsResponse> add_paths_messages_;
};

}  // namespace hgraph::server
