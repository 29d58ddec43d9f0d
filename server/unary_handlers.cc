// The unary calls: blob lookup, scenes, sessions, re-queries and path checks. Each runs its body
// on a gRPC thread when it only looks up state, and on the worker pool when it does CPU work.
#include <spdlog/spdlog.h>

#include <functional>
#include <mutex>
#include <string>
#include <utility>

#include "core/adapter/merge_proto.h"
#include "core/adapter/path_io.h"
#include "core/adapter/scene_proto.h"
#include "core/common/client_text.h"
#include "core/common/limits.h"
#include "core/merge/path_check.h"
#include "server/call_support.h"
#include "server/service.h"

namespace hgraph::server {

// A unary call: optionally runs its body on the worker pool, then finishes with the mapped
// status. Deletes itself when gRPC is done with it.
class PathMergerService::UnaryCall final : public grpc::ServerUnaryReactor {
 public:
  UnaryCall(PathMergerService* service, grpc::CallbackServerContext* context, std::string method,
            std::string session)
      : service_(service), method_(std::move(method)), session_(std::move(session)) {
    WireDeadline(context, token_);
    auth_ = service->options().auth.Authenticate(*context, &tenant_);
  }

  // The caller's tenant (server/auth.h), for the session registry.
  const std::string& tenant() const { return tenant_; }

  // `body` may throw hgraph::Error; it must not touch the call after returning. An
  // unauthenticated call finishes with UNAUTHENTICATED and runs no body.
  void Run(std::function<void(const CancelToken&)> body, bool on_worker) {
    if (!auth_.ok()) return Complete(auth_);
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
  Clock::time_point started_ = service_->RecordStart(method_);
  CancelToken token_;
  grpc::Status auth_;
  std::string tenant_;
};

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
        *response = sessions_.Create(request->scene(), request->session_id(), call->tenant());
      },
      /*on_worker=*/true);
  return call;
}

grpc::ServerUnaryReactor* PathMergerService::GetSession(grpc::CallbackServerContext* context,
                                                        const v1::GetSessionRequest* request,
                                                        v1::Session* response) {
  auto* call = new UnaryCall(this, context, "GetSession", request->name());
  call->Run(
      [=, this](const CancelToken&) {
        *response = sessions_.Touch(request->name(), "name", call->tenant());
      },
      /*on_worker=*/false);
  return call;
}

grpc::ServerUnaryReactor* PathMergerService::ListSessions(grpc::CallbackServerContext* context,
                                                          const v1::ListSessionsRequest*,
                                                          v1::ListSessionsResponse* response) {
  auto* call = new UnaryCall(this, context, "ListSessions", "");
  call->Run(
      [=, this](const CancelToken&) {
        for (v1::Session& s : sessions_.List(call->tenant()))
          *response->add_sessions() = std::move(s);
      },
      /*on_worker=*/false);
  return call;
}

grpc::ServerUnaryReactor* PathMergerService::DeleteSession(grpc::CallbackServerContext* context,
                                                           const v1::DeleteSessionRequest* request,
                                                           v1::DeleteSessionResponse*) {
  auto* call = new UnaryCall(this, context, "DeleteSession", request->name());
  call->Run(
      [=, this](const CancelToken&) {
        DropHGraphs(sessions_.Delete(request->name(), "name", call->tenant()));
      },
      /*on_worker=*/false);
  return call;
}

std::shared_ptr<PathMergerService::StoredHGraph> PathMergerService::HeldHGraph(
    const std::string& name, const std::string& tenant) {
  sessions_.Touch(SessionRegistry::SessionOfHGraph(name, "hgraph"), "hgraph", tenant);
  auto stored = cache_.Get<StoredHGraph>(CacheKind::kHGraph, name);
  if (!stored) {
    throw Error(ErrorCode::kNotFound, "hgraph",
                ClientText(name) +
                    " is not held by this server (evicted under the memory budget, or never "
                    "built here); merge the paths again");
  }
  return stored;
}

bool PathMergerService::Reaccount(const std::string& name, StoredHGraph& stored) {
  size_t bytes = 0;
  {
    std::lock_guard lock(stored.mutex);
    bytes = stored.session->memory_bytes();
  }
  if (cache_.Resize(CacheKind::kHGraph, name, bytes)) return true;
  spdlog::warn("{} no longer held: {} bytes after the query (--cache-bytes)", ClientText(name),
               bytes);
  return false;
}

grpc::ServerUnaryReactor* PathMergerService::Requery(grpc::CallbackServerContext* context,
                                                     const v1::RequeryRequest* request,
                                                     v1::RequeryResponse* response) {
  auto* call = new UnaryCall(this, context, "Requery", request->hgraph());
  call->Run(
      [=, this](const CancelToken& token) {
        const auto stored = HeldHGraph(request->hgraph(), call->tenant());
        const MeasureSpec measure = MeasureFromProto(request->measure());
        const MergeResult result =
            QueryStored(*stored, measure, {}, token, ReportClearance(*request));
        *response->mutable_result() = MergeResultToProto(result);
        if (Reaccount(request->hgraph(), *stored)) response->set_hgraph(request->hgraph());
        RecordMerge("Requery", response->result());
      },
      /*on_worker=*/true);
  return call;
}

grpc::ServerUnaryReactor* PathMergerService::AddPaths(grpc::CallbackServerContext* context,
                                                      const v1::AddPathsRequest* request,
                                                      v1::AddPathsResponse* response) {
  auto* call = new UnaryCall(this, context, "AddPaths", request->hgraph());
  call->Run(
      [=, this](const CancelToken& token) {
        const auto stored = HeldHGraph(request->hgraph(), call->tenant());
        CheckBatchLimits(request->paths(), options_);
        const MeasureSpec measure = MeasureFromProto(request->measure());
        int held = 0;
        {
          std::lock_guard lock(stored->mutex);
          held = stored->session->graph().num_paths();
        }
        if (held + request->paths().paths_size() > options_.max_paths) {
          throw Error(ErrorCode::kResourceExhausted, "paths.paths",
                      std::to_string(request->paths().paths_size()) + " more paths would give " +
                          ClientText(request->hgraph()) + " " +
                          std::to_string(held + request->paths().paths_size()) +
                          " inputs, over the limit of " + std::to_string(options_.max_paths) +
                          " (--max-paths)");
        }
        const std::vector<InputPath> paths = PathsFromProto(request->paths());
        int64_t added = 0;
        MergeResult result;
        try {
          result = AddToStored(*stored, paths, measure, token, &added, ReportClearance(*request));
        } catch (const Error& e) {
          // The engine names the batch's own paths ("paths[i]..."), the request nests them.
          if (e.field() != "paths" && e.field().rfind("paths[", 0) != 0) throw;
          throw Error(e.code(), "paths." + e.field(),
                      std::string(e.what()).substr(e.field().size() + 2));
        }
        *response->mutable_result() = MergeResultToProto(result);
        if (Reaccount(request->hgraph(), *stored)) response->set_hgraph(request->hgraph());
        response->set_candidates_added(added);
        RecordMerge("AddPaths", response->result());
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
        const v1::Session session = sessions_.Touch(request->session(), "session", call->tenant());
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
        const LocalPlanner planner(scene.world,
                                   LocalPlannerOptions{.resolution = resolution,
                                                       .clearance_bound = scene.clearance_bound});
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
        families_.collision_checks.Increment(labels, static_cast<double>(result.collision_checks));
        families_.distance_queries.Increment(labels, static_cast<double>(result.distance_queries));
        families_.edges_checked.Increment(labels, static_cast<double>(result.edges_checked));
      },
      /*on_worker=*/true);
  return call;
}

}  // namespace hgraph::server
