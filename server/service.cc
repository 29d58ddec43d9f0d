#include "server/service.h"

#include <spdlog/spdlog.h>

#include <deque>
#include <functional>
#include <mutex>
#include <new>
#include <optional>
#include <utility>

#include "core/adapter/merge_proto.h"
#include "core/adapter/path_io.h"
#include "core/adapter/scene_proto.h"
#include "core/common/error.h"
#include "core/common/limits.h"
#include "core/merge/merge.h"
#include "core/merge/path_check.h"
#include "core/motion/local_planner.h"
#ifdef HGRAPH_HAVE_PLAN
#include "core/plan/plan.h"
#endif

namespace hgraph::server {
namespace {

using Clock = std::chrono::steady_clock;
constexpr char kService[] = "hgraph.v1.PathMerger";

const char* CodeName(grpc::StatusCode code) {
  switch (code) {
    case grpc::StatusCode::OK: return "OK";
    case grpc::StatusCode::CANCELLED: return "CANCELLED";
    case grpc::StatusCode::UNKNOWN: return "UNKNOWN";
    case grpc::StatusCode::INVALID_ARGUMENT: return "INVALID_ARGUMENT";
    case grpc::StatusCode::DEADLINE_EXCEEDED: return "DEADLINE_EXCEEDED";
    case grpc::StatusCode::NOT_FOUND: return "NOT_FOUND";
    case grpc::StatusCode::ALREADY_EXISTS: return "ALREADY_EXISTS";
    case grpc::StatusCode::PERMISSION_DENIED: return "PERMISSION_DENIED";
    case grpc::StatusCode::UNAUTHENTICATED: return "UNAUTHENTICATED";
    case grpc::StatusCode::RESOURCE_EXHAUSTED: return "RESOURCE_EXHAUSTED";
    case grpc::StatusCode::FAILED_PRECONDITION: return "FAILED_PRECONDITION";
    case grpc::StatusCode::ABORTED: return "ABORTED";
    case grpc::StatusCode::OUT_OF_RANGE: return "OUT_OF_RANGE";
    case grpc::StatusCode::UNIMPLEMENTED: return "UNIMPLEMENTED";
    case grpc::StatusCode::INTERNAL: return "INTERNAL";
    case grpc::StatusCode::UNAVAILABLE: return "UNAVAILABLE";
    case grpc::StatusCode::DATA_LOSS: return "DATA_LOSS";
    default: return "UNKNOWN";
  }
}

grpc::StatusCode ToGrpcCode(ErrorCode code) {
  switch (code) {
    case ErrorCode::kInvalidArgument: return grpc::StatusCode::INVALID_ARGUMENT;
    case ErrorCode::kNotFound: return grpc::StatusCode::NOT_FOUND;
    case ErrorCode::kFailedPrecondition: return grpc::StatusCode::FAILED_PRECONDITION;
    case ErrorCode::kCancelled: return grpc::StatusCode::CANCELLED;
    case ErrorCode::kDeadlineExceeded: return grpc::StatusCode::DEADLINE_EXCEEDED;
    case ErrorCode::kResourceExhausted: return grpc::StatusCode::RESOURCE_EXHAUSTED;
    case ErrorCode::kUnauthenticated: return grpc::StatusCode::UNAUTHENTICATED;
    case ErrorCode::kPermissionDenied: return grpc::StatusCode::PERMISSION_DENIED;
  }
  return grpc::StatusCode::UNKNOWN;
}

// Runs `body` and turns whatever it throws into a canonical status. A cancellation that comes
// from the passed deadline (gRPC cancels the call at the deadline too) is DEADLINE_EXCEEDED.
grpc::Status Invoke(const std::function<void()>& body, const CancelToken& token) {
  try {
    body();
    return grpc::Status::OK;
  } catch (const Error& e) {
    grpc::StatusCode code = ToGrpcCode(e.code());
    if (code == grpc::StatusCode::CANCELLED && token.deadline_passed()) {
      return grpc::Status(grpc::StatusCode::DEADLINE_EXCEEDED, "deadline exceeded");
    }
    return grpc::Status(code, e.what());
  } catch (const std::bad_alloc&) {
    return grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED, "out of memory");
  } catch (const std::exception& e) {
    // A broken invariant (InternalError) fails this call only; it is a bug worth a log line.
    spdlog::error("internal error: {}", e.what());
    return grpc::Status(grpc::StatusCode::INTERNAL, e.what());
  }
}

// The call's deadline, if any, on the token (the engine polls it).
void WireDeadline(grpc::CallbackServerContext* context, const CancelToken& token) {
  const auto deadline = context->deadline();
  if (deadline == std::chrono::system_clock::time_point::max()) return;
  const auto remaining = deadline - std::chrono::system_clock::now();
  token.SetDeadline(Clock::now() + std::chrono::duration_cast<Clock::duration>(remaining));
}

grpc::Status Busy(const WorkerPool& pool) {
  return grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED,
                      "the server is busy: " + std::to_string(pool.max_admitted()) +
                          " calls are queued or running (--max-pending); retry later");
}

// Checks the batch against the server's limits before any work is done.
void CheckBatchLimits(const v1::PathSet& paths, const ServerOptions& options) {
  if (paths.paths_size() > options.max_paths) {
    throw Error(ErrorCode::kResourceExhausted, "paths.paths",
                std::to_string(paths.paths_size()) + " paths exceed the limit of " +
                    std::to_string(options.max_paths) + " per batch (--max-paths)");
  }
  for (int i = 0; i < paths.paths_size(); ++i) {
    if (paths.paths(i).waypoints_size() > options.max_waypoints) {
      throw Error(ErrorCode::kResourceExhausted, "paths.paths[" + std::to_string(i) + "].waypoints",
                  std::to_string(paths.paths(i).waypoints_size()) +
                      " waypoints exceed the limit of " + std::to_string(options.max_waypoints) +
                      " per path (--max-waypoints)");
    }
  }
}

}  // namespace

// An H-Graph kept for re-queries, with the local planner its edges were checked with.
// HybridizationSession is not thread safe, so queries on one H-Graph are serialised.
struct PathMergerService::StoredHGraph {
  std::mutex mutex;
  LoadedScene scene;
  std::unique_ptr<LocalPlanner> planner;
  std::unique_ptr<HybridizationSession> session;
};

// A unary call: optionally runs its body on the worker pool, then finishes with the mapped
// status. Deletes itself when gRPC is done with it.
class PathMergerService::UnaryCall final : public grpc::ServerUnaryReactor {
 public:
  UnaryCall(PathMergerService* service, grpc::CallbackServerContext* context, std::string method,
            std::string session)
      : service_(service), method_(std::move(method)), session_(std::move(session)) {
    WireDeadline(context, token_);
  }

  // `body` may throw hgraph::Error; it must not touch the call after returning.
  void Run(std::function<void(const CancelToken&)> body, bool on_worker) {
    if (!on_worker) {
      Complete(Invoke([&] { body(token_); }, token_));
      return;
    }
    const bool admitted =
        service_->pool().TrySubmit([this, body = std::move(body)](WorkerPool::Slot& slot) {
          const grpc::Status status = Invoke([&] { body(token_); }, token_);
          slot.Release();
          Complete(status);
        });
    if (!admitted) Complete(Busy(service_->pool()));
  }

  void OnCancel() override { token_.Cancel(); }
  void OnDone() override { delete this; }

 private:
  void Complete(const grpc::Status& status) {
    service_->RecordCall(method_, session_, started_, status);
    Finish(status);
  }

  PathMergerService* service_;
  std::string method_;
  std::string session_;
  Clock::time_point started_ = Clock::now();
  CancelToken token_;
};

// UploadBlob: collects the chunks on gRPC threads (copies only), then verifies the size and
// SHA-256 on the worker pool.
class PathMergerService::UploadCall final : public grpc::ServerReadReactor<v1::UploadBlobRequest> {
 public:
  UploadCall(PathMergerService* service, v1::UploadBlobResponse* response)
      : service_(service), response_(response) {
    StartRead(&chunk_);
  }

  void OnReadDone(bool ok) override {
    if (!ok) {
      EndOfStream();
      return;
    }
    if (first_) {
      first_ = false;
      digest_ = chunk_.digest();
      grpc::Status status = Invoke([&] { ValidateDigest(digest_, "digest"); }, token_);
      if (!status.ok()) return Complete(status);
      if (digest_.size_bytes() > service_->options().max_blob_bytes) {
        return Complete(grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED,
                                     "digest.size_bytes: " + std::to_string(digest_.size_bytes()) +
                                         " bytes exceed the limit of " +
                                         std::to_string(service_->options().max_blob_bytes) +
                                         " (--max-blob-bytes)"));
      }
      bytes_.reserve(static_cast<size_t>(digest_.size_bytes()));
    }
    if (static_cast<int64_t>(bytes_.size() + chunk_.data().size()) > digest_.size_bytes()) {
      return Complete(grpc::Status(grpc::StatusCode::INVALID_ARGUMENT,
                                   "data: the chunks hold more than digest.size_bytes = " +
                                       std::to_string(digest_.size_bytes()) + " bytes"));
    }
    bytes_ += chunk_.data();
    StartRead(&chunk_);
  }

  void OnCancel() override { token_.Cancel(); }
  void OnDone() override { delete this; }

 private:
  void EndOfStream() {
    if (first_) {
      return Complete(
          grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, "digest: the stream held no message"));
    }
    const bool admitted = service_->pool().TrySubmit([this](WorkerPool::Slot& slot) {
      const grpc::Status status = Invoke(
          [&] {
            response_->set_stored(service_->scenes_.PutBlob(digest_, std::move(bytes_)));
            *response_->mutable_digest() = digest_;
          },
          token_);
      slot.Release();
      Complete(status);
    });
    if (!admitted) Complete(Busy(service_->pool()));
  }

  void Complete(const grpc::Status& status) {
    service_->RecordCall("UploadBlob", "", started_, status);
    Finish(status);
  }

  PathMergerService* service_;
  v1::UploadBlobResponse* response_;
  v1::UploadBlobRequest chunk_;
  v1::Digest digest_;
  std::string bytes_;
  bool first_ = true;
  Clock::time_point started_ = Clock::now();
  CancelToken token_;
};

// MergePaths: progress events at a bounded rate with at most one write in flight (a newer
// report replaces an unsent one rather than queueing), then the result.
class PathMergerService::MergeCall final : public grpc::ServerWriteReactor<v1::MergePathsResponse> {
 public:
  MergeCall(PathMergerService* service, grpc::CallbackServerContext* context,
            const v1::MergePathsRequest* request)
      : service_(service), request_(request) {
    WireDeadline(context, token_);
    if (request->progress_interval_ms() < 0 ||
        request->progress_interval_ms() > limits::kMaxProgressIntervalMs) {
      Complete(grpc::Status(grpc::StatusCode::INVALID_ARGUMENT,
                            "progress_interval_ms: must be in [0, " +
                                std::to_string(limits::kMaxProgressIntervalMs) +
                                "] (0 = the "
                                "server's default), got " +
                                std::to_string(request->progress_interval_ms())),
               false);
      return;
    }
    const int interval = request->progress_interval_ms() > 0
                             ? request->progress_interval_ms()
                             : service->options().progress_interval_ms;
    interval_ = std::chrono::milliseconds(interval);
    const bool admitted =
        service_->pool().TrySubmit([this](WorkerPool::Slot& slot) { Work(slot); });
    if (!admitted) Complete(Busy(service_->pool()), false);
  }

  void OnWriteDone(bool ok) override {
    bool send_final = false;
    {
      std::lock_guard lock(mutex_);
      writing_ = false;
      if (final_pending_ && !final_sent_) send_final = final_sent_ = true;
    }
    // A failed write means the client has gone: stop the work.
    if (!ok) token_.Cancel();
    if (send_final) SendFinal();
  }

  void OnCancel() override { token_.Cancel(); }
  void OnDone() override { delete this; }

 private:
  void Work(WorkerPool::Slot& slot) {
    v1::MergePathsResponse final_message;
    const grpc::Status status = Invoke([&] { Merge(&final_message); }, token_);
    if (status.ok()) final_ = std::move(final_message);
    slot.Release();
    Complete(status, status.ok());
  }

  void Merge(v1::MergePathsResponse* out) {
    const v1::MergePathsRequest& request = *request_;
    const v1::Session session = service_->sessions_.Touch(request.session(), "session");
    CheckBatchLimits(request.paths(), service_->options());
    if (request.paths().paths_size() == 0) throw InputError("paths.paths", "must not be empty");
    LoadedScene scene = service_->scenes_.Get(session.scene(), "session", token_);
    token_.ThrowIfStopped();

    MergeRequest merge{.paths = PathsFromProto(request.paths()),
                       .measure = MeasureFromProto(request.measure()),
                       .options = MergeOptionsFromProto(request.options())};
    const int pool_threads = service_->pool().threads();
    if (merge.options.threads <= 0 || merge.options.threads > pool_threads) {
      merge.options.threads = pool_threads;
    }
    merge.cancel = token_;
    merge.progress = [this](const Progress& progress) { OnProgress(progress); };
    const double resolution = ResolutionFromProto(request.options(), *scene.proto);

    auto stored = std::make_shared<StoredHGraph>();
    stored->scene = scene;
    stored->planner =
        std::make_unique<LocalPlanner>(scene.world, LocalPlannerOptions{.resolution = resolution});
    try {
      stored->session = std::make_unique<HybridizationSession>(*stored->planner, merge);
    } catch (const Error& e) {
      // The engine names the paths as its own list ("paths[1].waypoints[3]"); the client sent
      // them as the request's "paths.paths", as every other message here names them.
      if (e.field().rfind("paths[", 0) != 0) throw;
      throw Error(e.code(), "paths." + e.field(),
                  std::string(e.what()).substr(e.field().size() + 2));
    }
    const MergeResult result = stored->session->Query(merge.measure, merge.progress, token_);
    *out->mutable_result() = MergeResultToProto(result);
    service_->RecordMerge("MergePaths", out->result());

    const std::string name = service_->sessions_.AddHGraph(session.name());
    const size_t bytes = stored->session->memory_bytes();
    if (service_->cache_.Put(CacheKind::kHGraph, name, stored, bytes)) {
      out->set_hgraph(name);
    } else {
      // Larger than the whole budget: the result stands, but there is nothing to re-query.
      service_->sessions_.RemoveHGraph(name);
      spdlog::warn("MergePaths session={} H-Graph of {} bytes exceeds --cache-bytes; not kept",
                   session.name(), bytes);
    }
  }

  // Called from engine worker threads.
  void OnProgress(const Progress& progress) {
    const Clock::time_point now = Clock::now();
    {
      std::lock_guard lock(mutex_);
      if (writing_ || final_pending_) return;
      // The first report goes out at once so that even a short merge shows progress, and so
      // does each improvement of the post-optimization.
      const bool improvement = !std::isnan(progress.objective);
      if (sent_any_ && !improvement && now - last_sent_ < interval_) return;
      writing_ = true;
      sent_any_ = true;
      last_sent_ = now;
      v1::MergeProgress* p = progress_message_.mutable_progress();
      p->set_phase(progress.phase);
      p->set_done(progress.done);
      p->set_total(progress.total);
      p->set_collision_checks(progress.collision_checks);
      p->set_distance_queries(progress.distance_queries);
      p->set_elapsed_ms(std::chrono::duration<double, std::milli>(now - started_).count());
      if (improvement) {
        p->set_objective(progress.objective);
      } else {
        p->clear_objective();
      }
    }
    StartWrite(&progress_message_);
  }

  void Complete(const grpc::Status& status, bool with_result) {
    service_->RecordCall("MergePaths", request_->session(), started_, status);
    bool send_final = false;
    {
      std::lock_guard lock(mutex_);
      status_ = status;
      with_result_ = with_result;
      final_pending_ = true;
      if (!writing_) send_final = final_sent_ = true;
    }
    if (send_final) SendFinal();
  }

  void SendFinal() {
    if (with_result_) {
      StartWriteAndFinish(&final_, grpc::WriteOptions(), grpc::Status::OK);
    } else {
      Finish(status_);
    }
  }

  PathMergerService* service_;
  const v1::MergePathsRequest* request_;
  Clock::time_point started_ = Clock::now();
  CancelToken token_;
  std::chrono::milliseconds interval_{100};

  std::mutex mutex_;
  bool writing_ = false;
  bool sent_any_ = false;
  bool final_pending_ = false;
  bool final_sent_ = false;
  Clock::time_point last_sent_;
  v1::MergePathsResponse progress_message_;
  v1::MergePathsResponse final_;
  grpc::Status status_;
  bool with_result_ = false;
};

PathMergerService::PathMergerService(const ServerOptions& options, Metrics& metrics)
    : options_(options),
      metrics_(metrics),
      cache_(options.cache_bytes),
      scenes_(cache_, metrics, MeshImporter(options.mesh_import)),
      sessions_(options.max_sessions, options.session_ttl),
      pool_(options.threads, options.max_admitted) {
  metrics_.DeclareCounter("grpc_server_started_total", "RPCs started on the server.");
  metrics_.DeclareCounter("grpc_server_handled_total",
                          "RPCs completed on the server, regardless of success or failure.");
  metrics_.DeclareHistogram(
      "grpc_server_handling_seconds", "Response latency of RPCs handled by the server, in seconds.",
      {0.001, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1, 2.5, 5, 10, 30, 60, 300});
  metrics_.DeclareCounter("hgraph_merges_total", "Merges and re-queries that returned a result.");
  metrics_.DeclareCounter(
      "hgraph_merge_collision_checks_total",
      "Collision checks run by merges, re-queries and path checks (by method).");
  metrics_.DeclareCounter(
      "hgraph_merge_distance_queries_total",
      "Distance (clearance) queries run by merges, re-queries and path checks.");
  metrics_.DeclareCounter(
      "hgraph_merge_edges_checked_total",
      "Local-planner runs (input edges, bridges, clearance re-checks, checked paths).");
  metrics_.DeclareCounter("hgraph_merge_edges_reused_total",
                          "Stored edge reports that served a re-query without a new check.");
  metrics_.DeclareHistogram("hgraph_merge_phase_seconds", "Wall time of each merge phase.",
                            {0.001, 0.01, 0.1, 0.5, 1, 5, 10, 60, 300});
  metrics_.DeclareCounter("hgraph_scene_cache_hits_total",
                          "Scene lookups served by an already loaded collision world.");
  metrics_.DeclareCounter("hgraph_scene_cache_misses_total",
                          "Scene lookups that had to load meshes and build BVHs.");
  metrics_.DeclareCounter("hgraph_scene_loads_total", "Scenes loaded and BVH-built.");
  metrics_.DeclareGauge("hgraph_cache_bytes", "Bytes held in the cache, by kind.");
  metrics_.DeclareGauge("hgraph_cache_budget_bytes", "The cache's budget (--cache-bytes).");
  metrics_.DeclareCounter("hgraph_cache_evictions_total", "Cache entries evicted, by kind.");
  metrics_.DeclareGauge("hgraph_sessions", "Live sessions.");
  metrics_.DeclareGauge("hgraph_admitted_calls", "Calls queued or running on the worker pool.");
  metrics_.AddCollector([this] {
    for (CacheKind kind :
         {CacheKind::kBlob, CacheKind::kScene, CacheKind::kWorld, CacheKind::kHGraph}) {
      const Labels labels = {{"kind", CacheKindName(kind)}};
      metrics_.Set("hgraph_cache_bytes", labels, static_cast<double>(cache_.bytes(kind)));
      metrics_.Set("hgraph_cache_evictions_total", labels,
                   static_cast<double>(cache_.evictions(kind)));
    }
    metrics_.Set("hgraph_cache_budget_bytes", {}, static_cast<double>(cache_.budget_bytes()));
    metrics_.Set("hgraph_sessions", {}, sessions_.size());
    metrics_.Set("hgraph_admitted_calls", {}, pool_.admitted());
  });
  // An evicted H-Graph disappears from its session's listing.
  cache_.SetEvictionListener([this](CacheKind kind, const std::string& key) {
    if (kind == CacheKind::kHGraph) sessions_.RemoveHGraph(key);
    spdlog::info("cache evicted {} {}", CacheKindName(kind), key);
  });
}

PathMergerService::~PathMergerService() { pool_.WaitIdle(); }

void PathMergerService::RecordCall(const std::string& method, const std::string& session,
                                   Clock::time_point started, const grpc::Status& status) {
  const double seconds = std::chrono::duration<double>(Clock::now() - started).count();
  const char* code = CodeName(status.error_code());
  const std::string type = method == "MergePaths" || method == "PlanPaths" ? "server_stream"
                           : method == "UploadBlob"                        ? "client_stream"
                                                                           : "unary";
  metrics_.Increment("grpc_server_started_total",
                     {{"grpc_type", type}, {"grpc_service", kService}, {"grpc_method", method}});
  metrics_.Increment("grpc_server_handled_total", {{"grpc_type", type},
                                                   {"grpc_service", kService},
                                                   {"grpc_method", method},
                                                   {"grpc_code", code}});
  metrics_.Observe("grpc_server_handling_seconds",
                   {{"grpc_type", type}, {"grpc_service", kService}, {"grpc_method", method}},
                   seconds);
  if (status.ok()) {
    spdlog::info("{} session={} status={} duration_ms={:.1f}", method,
                 session.empty() ? "-" : session, code, seconds * 1e3);
  } else {
    spdlog::info("{} session={} status={} duration_ms={:.1f} error=\"{}\"", method,
                 session.empty() ? "-" : session, code, seconds * 1e3, status.error_message());
  }
}

void PathMergerService::RecordMerge(const std::string& method, const v1::MergeResult& result) {
  const Labels labels = {{"method", method}};
  metrics_.Increment("hgraph_merges_total", labels);
  const v1::MergeStats& stats = result.stats();
  metrics_.Increment("hgraph_merge_collision_checks_total", labels,
                     static_cast<double>(stats.collision_checks()));
  metrics_.Increment("hgraph_merge_distance_queries_total", labels,
                     static_cast<double>(stats.distance_queries()));
  metrics_.Increment("hgraph_merge_edges_checked_total", labels,
                     static_cast<double>(stats.edges_checked()));
  metrics_.Increment("hgraph_merge_edges_reused_total", labels,
                     static_cast<double>(stats.edges_reused()));
  const v1::Timing& t = result.timing();
  const std::pair<const char*, double> phases[] = {
      {"validate", t.validate_ms()},     {"inputs", t.inputs_ms()}, {"align", t.align_ms()},
      {"candidates", t.candidates_ms()}, {"check", t.check_ms()},   {"search", t.search_ms()},
      {"evaluate", t.evaluate_ms()}};
  for (const auto& [phase, ms] : phases) {
    metrics_.Observe("hgraph_merge_phase_seconds", {{"method", method}, {"phase", phase}},
                     ms / 1e3);
  }
}

void PathMergerService::DropHGraphs(const std::vector<std::string>& names) {
  for (const std::string& name : names) cache_.Erase(CacheKind::kHGraph, name);
}

void PathMergerService::ExpireIdleSessions() {
  const std::vector<std::string> dropped = sessions_.ExpireIdle(SessionRegistry::Clock::now());
  if (!dropped.empty()) spdlog::info("expired sessions dropped {} H-Graphs", dropped.size());
  DropHGraphs(dropped);
}

grpc::ServerUnaryReactor* PathMergerService::FindMissingBlobs(
    grpc::CallbackServerContext* context, const v1::FindMissingBlobsRequest* request,
    v1::FindMissingBlobsResponse* response) {
  auto* call = new UnaryCall(this, context, "FindMissingBlobs", "");
  call->Run(
      [=, this](const CancelToken&) {
        for (int i = 0; i < request->digests_size(); ++i) {
          ValidateDigest(request->digests(i), "digests[" + std::to_string(i) + "]");
          if (!scenes_.HasBlob(request->digests(i))) *response->add_missing() = request->digests(i);
        }
      },
      /*on_worker=*/false);
  return call;
}

grpc::ServerReadReactor<v1::UploadBlobRequest>* PathMergerService::UploadBlob(
    grpc::CallbackServerContext*, v1::UploadBlobResponse* response) {
  return new UploadCall(this, response);
}

grpc::ServerUnaryReactor* PathMergerService::PutScene(grpc::CallbackServerContext* context,
                                                      const v1::PutSceneRequest* request,
                                                      v1::PutSceneResponse* response) {
  auto* call = new UnaryCall(this, context, "PutScene", "");
  call->Run(
      [=, this](const CancelToken& token) {
        if (!request->has_scene()) throw InputError("scene", "must be set");
        *response->mutable_digest() = scenes_.PutScene(request->scene(), token);
      },
      /*on_worker=*/true);
  return call;
}

grpc::ServerUnaryReactor* PathMergerService::CreateSession(grpc::CallbackServerContext* context,
                                                           const v1::CreateSessionRequest* request,
                                                           v1::Session* response) {
  // A client-chosen id names the session in the log line already.
  auto* call = new UnaryCall(
      this, context, "CreateSession",
      request->session_id().empty() ? "" : "sessions/" + request->session_id().substr(0, 32));
  call->Run(
      [=, this](const CancelToken& token) {
        if (!request->has_scene()) throw InputError("scene", "must be set");
        // Loads the scene now (or finds it loaded), so that a missing scene is reported here.
        scenes_.Get(request->scene(), "scene", token);
        *response = sessions_.Create(request->scene(), request->session_id());
      },
      /*on_worker=*/true);
  return call;
}

grpc::ServerUnaryReactor* PathMergerService::GetSession(grpc::CallbackServerContext* context,
                                                        const v1::GetSessionRequest* request,
                                                        v1::Session* response) {
  auto* call = new UnaryCall(this, context, "GetSession", request->name());
  call->Run([=, this](const CancelToken&) { *response = sessions_.Touch(request->name(), "name"); },
            /*on_worker=*/false);
  return call;
}

grpc::ServerUnaryReactor* PathMergerService::ListSessions(grpc::CallbackServerContext* context,
                                                          const v1::ListSessionsRequest*,
                                                          v1::ListSessionsResponse* response) {
  auto* call = new UnaryCall(this, context, "ListSessions", "");
  call->Run(
      [=, this](const CancelToken&) {
        for (v1::Session& s : sessions_.List()) *response->add_sessions() = std::move(s);
      },
      /*on_worker=*/false);
  return call;
}

grpc::ServerUnaryReactor* PathMergerService::DeleteSession(grpc::CallbackServerContext* context,
                                                           const v1::DeleteSessionRequest* request,
                                                           v1::DeleteSessionResponse*) {
  auto* call = new UnaryCall(this, context, "DeleteSession", request->name());
  call->Run(
      [=, this](const CancelToken&) { DropHGraphs(sessions_.Delete(request->name(), "name")); },
      /*on_worker=*/false);
  return call;
}

grpc::ServerWriteReactor<v1::MergePathsResponse>* PathMergerService::MergePaths(
    grpc::CallbackServerContext* context, const v1::MergePathsRequest* request) {
  return new MergeCall(this, context, request);
}

grpc::ServerUnaryReactor* PathMergerService::Requery(grpc::CallbackServerContext* context,
                                                     const v1::RequeryRequest* request,
                                                     v1::RequeryResponse* response) {
  auto* call = new UnaryCall(this, context, "Requery", request->hgraph());
  call->Run(
      [=, this](const CancelToken& token) {
        const std::string session = SessionRegistry::SessionOfHGraph(request->hgraph(), "hgraph");
        sessions_.Touch(session, "hgraph");
        auto stored = cache_.Get<StoredHGraph>(CacheKind::kHGraph, request->hgraph());
        if (!stored) {
          throw Error(ErrorCode::kNotFound, "hgraph",
                      request->hgraph() +
                          " is not held by this server (evicted under the memory budget, or "
                          "never built here); merge the paths again");
        }
        const MeasureSpec measure = MeasureFromProto(request->measure());
        std::lock_guard lock(stored->mutex);
        const MergeResult result = stored->session->Query(measure, {}, token);
        *response->mutable_result() = MergeResultToProto(result);
        response->set_hgraph(request->hgraph());
        RecordMerge("Requery", response->result());
      },
      /*on_worker=*/true);
  return call;
}

grpc::ServerUnaryReactor* PathMergerService::CheckPaths(grpc::CallbackServerContext* context,
                                                        const v1::CheckPathsRequest* request,
                                                        v1::CheckPathsResponse* response) {
  auto* call = new UnaryCall(this, context, "CheckPaths", request->session());
  call->Run(
      [=, this](const CancelToken& token) {
        const v1::Session session = sessions_.Touch(request->session(), "session");
        CheckBatchLimits(request->paths(), options_);
        LoadedScene scene = scenes_.Get(session.scene(), "session", token);
        token.ThrowIfStopped();
        if (request->has_resolution()) {
          limits::RequireRange(request->resolution(), limits::kMinResolution,
                               limits::kMaxResolution, "resolution");
        }
        if (request->has_k()) limits::RequireRange(request->k(), 0, limits::kMaxK, "k");
        const double resolution =
            request->has_resolution() ? request->resolution() : SceneResolution(*scene.proto);
        const LocalPlanner planner(scene.world, LocalPlannerOptions{.resolution = resolution});
        // The same check as a merge's inputs (core/merge/path_check.h), on this call's share of
        // the worker pool.
        const PathCheckResult result = ::hgraph::CheckPaths(
            planner, PathCheckRequest{
                         .paths = PathsFromProto(request->paths()),
                         .mode = request->sampled() ? CheckMode::kSampled : CheckMode::kCertified,
                         .k = request->has_k() ? request->k() : 3.0,
                         .threads = pool_.threads(),
                         .field = "paths.paths",
                         .cancel = token});
        for (const InputReport& report : result.paths) {
          *response->add_paths() = InputReportToProto(report);
        }
        response->set_collision_checks(result.collision_checks);
        response->set_distance_queries(result.distance_queries);
        response->set_resolution(resolution);
        response->set_elapsed_ms(result.elapsed_ms);
        const Labels labels = {{"method", "CheckPaths"}};
        metrics_.Increment("hgraph_merge_collision_checks_total", labels,
                           static_cast<double>(result.collision_checks));
        metrics_.Increment("hgraph_merge_distance_queries_total", labels,
                           static_cast<double>(result.distance_queries));
        metrics_.Increment("hgraph_merge_edges_checked_total", labels,
                           static_cast<double>(result.edges_checked));
      },
      /*on_worker=*/true);
  return call;
}

#ifdef HGRAPH_HAVE_PLAN
// PlanPaths: plans on a worker; each path found is queued and written in order, one write in
// flight, then the status.
class PathMergerService::PlanCall final : public grpc::ServerWriteReactor<v1::PlanPathsResponse> {
 public:
  PlanCall(PathMergerService* service, grpc::CallbackServerContext* context,
           const v1::PlanPathsRequest* request)
      : service_(service), request_(request) {
    WireDeadline(context, token_);
    if (!service_->pool().TrySubmit([this](WorkerPool::Slot& slot) { Work(slot); })) {
      Complete(Busy(service_->pool()));
    }
  }

  void OnWriteDone(bool ok) override {
    if (!ok) token_.Cancel();
    Pump(/*write_done=*/true);
  }
  void OnCancel() override { token_.Cancel(); }
  void OnDone() override { delete this; }

 private:
  void Work(WorkerPool::Slot& slot) {
    const grpc::Status status = Invoke([&] { Plan(); }, token_);
    slot.Release();
    Complete(status);
  }

  void Plan() {
    const v1::PlanPathsRequest& request = *request_;
    const v1::Session session = service_->sessions_.Touch(request.session(), "session");
    if (request.count() < 0) {
      throw InputError("count",
                       "must be >= 0 (0 = one path), got " + std::to_string(request.count()));
    }
    if (request.time_per_path_s() != 0) {
      limits::RequirePositiveUpTo(request.time_per_path_s(), limits::kMaxPlanSeconds,
                                  "time_per_path_s");
    }
    if (request.count() > service_->options().max_paths) {
      throw Error(ErrorCode::kResourceExhausted, "count",
                  std::to_string(request.count()) + " paths exceed the limit of " +
                      std::to_string(service_->options().max_paths) + " (--max-paths)");
    }
    LoadedScene scene = service_->scenes_.Get(session.scene(), "session", token_);
    const Scene& model = scene.world->scene();
    PlanRequest plan{.planner = request.planner().empty()
                                    ? PlanRequest().planner
                                    : ParsePlannerType(request.planner(), "planner"),
                     .count = request.count() == 0 ? 1 : request.count(),
                     .time_s = request.time_per_path_s() > 0 ? request.time_per_path_s() : 1.0,
                     .seed = request.seed(),
                     .simplify = request.simplify(),
                     .resolution = request.has_resolution() ? request.resolution()
                                                            : SceneResolution(*scene.proto)};
    if (request.has_start()) {
      plan.start = ConfigFromProto(request.start());
    } else if (model.start) {
      plan.start = *model.start;
    } else {
      throw InputError("start", "must be set: the scene has no start of its own");
    }
    if (request.has_goal()) {
      plan.goal = ConfigFromProto(request.goal());
    } else if (model.goal) {
      plan.goal = *model.goal;
    } else {
      throw InputError("goal", "must be set: the scene has no goal of its own");
    }
    plan.cancel = token_;
    plan.on_path = [this](int index, const InputPath& path, double elapsed_ms) {
      v1::PlanPathsResponse event;
      *event.mutable_path() = PathToProto(path);
      event.set_index(index);
      event.set_elapsed_ms(elapsed_ms);
      {
        std::lock_guard lock(mutex_);
        queue_.push_back(std::move(event));
      }
      Pump(/*write_done=*/false);
    };
    LocalPlanner checker(scene.world, LocalPlannerOptions{.resolution = plan.resolution});
    ::hgraph::PlanPaths(checker, plan);
  }

  void Complete(const grpc::Status& status) {
    service_->RecordCall("PlanPaths", request_->session(), started_, status);
    {
      std::lock_guard lock(mutex_);
      status_ = status;
      done_ = true;
    }
    Pump(/*write_done=*/false);
  }

  // Starts the next write, or the Finish once the queue is drained after the work is done.
  void Pump(bool write_done) {
    enum { kNothing, kWrite, kFinish } action = kNothing;
    {
      std::lock_guard lock(mutex_);
      if (write_done) {
        writing_ = false;
        queue_.pop_front();
      }
      if (writing_ || finished_) return;
      if (!queue_.empty()) {
        writing_ = true;
        action = kWrite;
      } else if (done_) {
        finished_ = true;
        action = kFinish;
      }
    }
    // The front element stays put until its write is done (deque keeps references stable).
    if (action == kWrite) StartWrite(&queue_.front());
    if (action == kFinish) Finish(status_);
  }

  PathMergerService* service_;
  const v1::PlanPathsRequest* request_;
  Clock::time_point started_ = Clock::now();
  CancelToken token_;
  std::mutex mutex_;
  std::deque<v1::PlanPathsResponse> queue_;
  bool writing_ = false;
  bool done_ = false;
  bool finished_ = false;
  grpc::Status status_;
};

grpc::ServerWriteReactor<v1::PlanPathsResponse>* PathMergerService::PlanPaths(
    grpc::CallbackServerContext* context, const v1::PlanPathsRequest* request) {
  return new PlanCall(this, context, request);
}
#else
grpc::ServerWriteReactor<v1::PlanPathsResponse>* PathMergerService::PlanPaths(
    grpc::CallbackServerContext*, const v1::PlanPathsRequest* request) {
  // Finishes at once: this build has no OMPL planners.
  class Unimplemented final : public grpc::ServerWriteReactor<v1::PlanPathsResponse> {
   public:
    explicit Unimplemented(const grpc::Status& status) { Finish(status); }
    void OnDone() override { delete this; }
  };
  const grpc::Status status(grpc::StatusCode::UNIMPLEMENTED,
                            "PlanPaths: this server was built without core/plan (the OMPL "
                            "input planners); generate paths on the client");
  RecordCall("PlanPaths", request->session(), Clock::now(), status);
  return new Unimplemented(status);
}
#endif

}  // namespace hgraph::server
