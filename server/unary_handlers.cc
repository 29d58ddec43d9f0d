// The unary calls: blob lookup, scenes, sessions, re-queries and path checks. Each runs its body
// on a gRPC thread when it only looks up state, and on the worker pool when it does CPU work.
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <set>
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

// A unary call: runs its body here or on the worker pool, then finishes with the mapped status.
// Deletes itself when gRPC is done with it.
class PathMergerService::UnaryCall final : public grpc::ServerUnaryReactor, public CallBase {
 public:
  UnaryCall(PathMergerService* service, grpc::CallbackServerContext* context, std::string method,
            std::string session)
      : CallBase(service, context, std::move(method), std::move(session)) {}

  // `body` may throw hgraph::Error; it must not touch the call after returning. An
  // unauthenticated call finishes with UNAUTHENTICATED and runs no body.
  void Run(std::function<void(const CancelToken&)> body, bool on_worker) {
    if (!Authenticated()) return;
    if (!on_worker) return RunHere([&] { body(token_); });
    Submit([this, body = std::move(body)] { body(token_); });
  }

  void OnCancel() override { token_.Cancel(); }
  void OnDone() override { delete this; }

 private:
  void Complete(const grpc::Status& status) override { Finish(Final(status)); }
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
      /*on_worker=*/shared_ != nullptr);
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
        if (shared_) {
          const auto& created = response->create_time();
          shared_->PutSession(
              response->name(),
              SessionRecord{.tenant = call->tenant(),
                            .scene = response->scene(),
                            .create_time_ns = created.seconds() * 1'000'000'000 + created.nanos()});
        }
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
        *response = TouchSession(request->name(), "name", call->tenant());
      },
      /*on_worker=*/shared_ != nullptr);
  return call;
}

grpc::ServerUnaryReactor* PathMergerService::ListSessions(grpc::CallbackServerContext* context,
                                                          const v1::ListSessionsRequest* request,
                                                          v1::ListSessionsResponse* response) {
  auto* call = new UnaryCall(this, context, "ListSessions", "");
  call->Run(
      [=, this](const CancelToken&) {
        constexpr int kMaxPageSize = 1000;
        constexpr int kDefaultPageSize = 100;
        if (request->page_size() < 0 || request->page_size() > kMaxPageSize) {
          throw InputError("page_size", "must be in [0, " + std::to_string(kMaxPageSize) +
                                            "] (0 = " + std::to_string(kDefaultPageSize) +
                                            "), got " + std::to_string(request->page_size()));
        }
        // The token is the last session name of the previous page (the registry's order).
        if (!request->page_token().empty() && request->page_token().rfind("sessions/", 0) != 0) {
          throw InputError("page_token", "is not a token this server issued");
        }
        const size_t page_size =
            static_cast<size_t>(request->page_size() > 0 ? request->page_size() : kDefaultPageSize);
        bool more = false;
        if (!shared_) {
          for (v1::Session& s :
               sessions_.List(call->tenant(), request->page_token(), page_size, &more)) {
            *response->add_sessions() = std::move(s);
          }
        } else {
          ListSharedSessions(call->tenant(), request->page_token(), page_size, &more, response);
        }
        if (more) {
          response->set_next_page_token(response->sessions(response->sessions_size() - 1).name());
        }
      },
      /*on_worker=*/shared_ != nullptr);
  return call;
}

void PathMergerService::ListSharedSessions(const std::string& tenant, const std::string& after,
                                           size_t page_size, bool* more,
                                           v1::ListSessionsResponse* response) {
  // The tenant's sessions this replica holds, and those the store lists (created or loaded by
  // any replica); the store down: this replica's alone.
  std::map<std::string, std::optional<v1::Session>> all;
  for (v1::Session& s : sessions_.List(tenant, after)) {
    std::string name = s.name();
    all.emplace(std::move(name), std::move(s));
  }
  std::optional<std::map<std::string, SessionRecord>> stored = shared_->ListSessions(tenant);
  if (stored) {
    for (const auto& [name, record] : *stored) {
      if (name > after) all.emplace(name, std::nullopt);
    }
  }
  for (auto& [name, held] : all) {
    if (static_cast<size_t>(response->sessions_size()) == page_size) {
      *more = true;
      break;
    }
    v1::Session* out = response->add_sessions();
    if (held) {
      *out = std::move(*held);
    } else {
      const SessionRecord& record = stored->at(name);
      out->set_name(name);
      *out->mutable_scene() = record.scene;
      out->mutable_create_time()->set_seconds(record.create_time_ns / 1'000'000'000);
      out->mutable_create_time()->set_nanos(
          static_cast<int32_t>(record.create_time_ns % 1'000'000'000));
      if (const auto left = shared_->SessionTimeToLive(name)) {
        const int64_t expire_ms = std::chrono::duration_cast<std::chrono::milliseconds>(
                                      SessionRegistry::Clock::now().time_since_epoch() + *left)
                                      .count();
        out->mutable_expire_time()->set_seconds(expire_ms / 1000);
        out->mutable_expire_time()->set_nanos(static_cast<int32_t>(expire_ms % 1000) * 1'000'000);
      }
    }
    // Every replica's H-Graphs of the session, after those this replica holds.
    const std::set<std::string> listed(out->hgraphs().begin(), out->hgraphs().end());
    for (std::string& h : shared_->HGraphsOf(name)) {
      if (!listed.contains(h)) out->add_hgraphs(std::move(h));
    }
  }
}

grpc::ServerUnaryReactor* PathMergerService::DeleteSession(grpc::CallbackServerContext* context,
                                                           const v1::DeleteSessionRequest* request,
                                                           v1::DeleteSessionResponse*) {
  auto* call = new UnaryCall(this, context, "DeleteSession", request->name());
  call->Run(
      [=, this](const CancelToken&) {
        // Loads a session only the store holds (the tenant checked there, as here).
        if (shared_) TouchSession(request->name(), "name", call->tenant());
        const std::vector<std::string> hgraphs =
            sessions_.Delete(request->name(), "name", call->tenant());
        if (shared_) shared_->DeleteSession(request->name(), call->tenant(), hgraphs);
        DropHGraphs(hgraphs);
      },
      /*on_worker=*/shared_ != nullptr);
  return call;
}

std::shared_ptr<PathMergerService::StoredHGraph> PathMergerService::HeldHGraph(
    const std::string& name, const std::string& tenant, const std::string& field,
    const std::function<void(StoredHGraph&)>& first_use, bool* used) {
  if (used != nullptr) *used = false;
  const auto use = [&](StoredHGraph& fresh) {
    first_use(fresh);
    if (used != nullptr) *used = true;
  };
  const std::function<void(StoredHGraph&)> on_load =
      first_use ? std::function<void(StoredHGraph&)>(use) : nullptr;
  TouchSession(SessionRegistry::SessionOfHGraph(name, field), field, tenant);
  auto stored = cache_.Get<StoredHGraph>(CacheKind::kHGraph, name);
  if (shared_ && stored) {
    uint64_t held = 0;
    {
      std::lock_guard lock(stored->mutex);
      held = stored->store_version;
    }
    // Another replica changed it since (AddPaths there): this copy is stale.
    if (held != 0 && shared_->HGraphVersion(name) > held) {
      spdlog::info("{} changed in the store since this replica held it; loading it again",
                   ClientText(name));
      if (auto fresh = LoadHGraph(name, tenant, field, on_load)) {
        stored = fresh;
      } else if (used != nullptr) {
        *used = false;  // not kept: the answer comes from the copy held here
      }
    }
  } else if (shared_ && sessions_.StateOf(name) == SessionRegistry::HGraphState::kUnknown) {
    stored = LoadHGraph(name, tenant, field, on_load);
  }
  if (!stored) {
    throw ServiceError(grpc::StatusCode::NOT_FOUND, "HGRAPH_NOT_FOUND", field,
                       ClientText(name) +
                           " is not held by this server (evicted under the memory budget, "
                           "deleted, or never built here); merge the paths again");
  }
  return stored;
}

v1::Retention PathMergerService::Reaccount(const std::string& name, StoredHGraph& stored) {
  size_t bytes = 0;
  {
    std::lock_guard lock(stored.mutex);
    bytes = stored.session->memory_bytes();
  }
  if (cache_.Resize(CacheKind::kHGraph, name, bytes)) return v1::RETENTION_KEPT;
  if (bytes > cache_.budget_bytes()) {
    spdlog::warn("{} no longer held: {} bytes after the query (--cache-bytes)", ClientText(name),
                 bytes);
    return v1::RETENTION_TOO_LARGE;
  }
  spdlog::info("{} was evicted or deleted while a query ran on it", ClientText(name));
  return v1::RETENTION_DROPPED;
}

grpc::ServerUnaryReactor* PathMergerService::Requery(grpc::CallbackServerContext* context,
                                                     const v1::RequeryRequest* request,
                                                     v1::RequeryResponse* response) {
  auto* call = new UnaryCall(this, context, "Requery", request->hgraph());
  call->Run(
      [=, this](const CancelToken& token) {
        // An H-Graph this call loads is searched as loaded, before any other call can reach
        // it; one held here on a copy (QueryStored).
        std::optional<MergeResult> first;
        bool loaded = false;
        const auto stored = HeldHGraph(
            request->hgraph(), call->tenant(), "hgraph",
            [&](StoredHGraph& fresh) {
              first = fresh.session->Query(MeasureFromProto(request->measure()), {}, token,
                                           ReportClearance(*request));
            },
            &loaded);
        const MergeResult result = loaded
                                       ? std::move(*first)
                                       : QueryStored(*stored, MeasureFromProto(request->measure()),
                                                     {}, token, ReportClearance(*request));
        *response->mutable_result() = MergeResultToProto(result);
        EchoEvaluation(stored->options, response->mutable_result());
        {
          std::lock_guard lock(stored->mutex);
          response->set_generation(stored->generation);
        }
        response->set_retention(Reaccount(request->hgraph(), *stored));
        if (response->retention() == v1::RETENTION_KEPT) {
          response->set_hgraph(request->hgraph());
        }
        RecordMerge("Requery", response->result());
        if (shared_ && result.stats.edges_checked > 0) {
          // Its checks are written with the next SyncStore, not before this answer.
          std::lock_guard lock(store_mutex_);
          unsynced_.insert(request->hgraph());
        }
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
        // With a shared store, the addition is written with compare-and-set on the version this
        // replica holds: when another replica wrote first, this copy is dropped and the addition
        // runs again on the stored H-Graph, once.
        for (int attempt = 0;; ++attempt) {
          if (attempt == 2) {
            throw ServiceError(grpc::StatusCode::ABORTED, "STORE_CONFLICT", "hgraph",
                               ClientText(request->hgraph()) +
                                   " was changed by another replica at the same time, twice; "
                                   "nothing was added; retry",
                               std::chrono::milliseconds(100));
          }
          const auto stored = HeldHGraph(request->hgraph(), call->tenant());
          CheckBatchLimits(request->paths(), options_);
          CheckTenantCache(call->tenant());
          if (request->request_id().size() > 63 ||
              std::any_of(request->request_id().begin(), request->request_id().end(),
                          [](char c) { return c < '!' || c > '~'; })) {
            throw InputError("request_id", "must be at most 63 printable ASCII characters");
          }
          const MeasureSpec measure = MeasureFromProto(request->measure());
          // One addition at a time from the look-up of its request id to its answer's record, so
          // that a repeat that comes while the first runs waits for its answer.
          std::lock_guard requests(stored->requests_mutex);
          const std::string fingerprint = RequestFingerprint(*request);
          if (!request->request_id().empty()) {
            for (const auto& [id, first] : stored->requests) {
              if (id != request->request_id()) continue;
              if (first.first != fingerprint) {
                throw ServiceError(grpc::StatusCode::ALREADY_EXISTS, "ALREADY_EXISTS", "request_id",
                                   "request_id " + ClientText(id) +
                                       " was used by another AddPaths request on " +
                                       ClientText(request->hgraph()));
              }
              *response = first.second;
              return;
            }
          }
          int held = 0;
          int64_t generation = 0;
          {
            std::lock_guard lock(stored->mutex);
            held = stored->session->graph().num_paths();
            generation = stored->generation;
          }
          if (request->has_expected_generation() && request->expected_generation() != generation) {
            throw ServiceError(
                grpc::StatusCode::ABORTED, "GENERATION_MISMATCH", "expected_generation",
                ClientText(request->hgraph()) + " is at generation " + std::to_string(generation) +
                    ", not " + std::to_string(request->expected_generation()) +
                    "; nothing was added");
          }
          CheckPathCount(held + request->paths().paths_size(), "paths.paths",
                         "inputs (" + std::to_string(held) + " held in " +
                             ClientText(request->hgraph()) + " and " +
                             std::to_string(request->paths().paths_size()) + " more)",
                         options_);
          const std::vector<InputPath> paths = PathsFromProto(request->paths());
          int64_t added = 0;
          MergeResult result;
          WithRequestPaths([&] {
            result = AddToStored(*stored, paths, measure, token, &added, ReportClearance(*request));
          });
          {
            std::lock_guard lock(stored->mutex);
            generation = ++stored->generation;
            for (const InputPath& path : paths) stored->input_names.push_back(path.name);
          }
          *response->mutable_result() = MergeResultToProto(result);
          EchoEvaluation(stored->options, response->mutable_result());
          response->set_hgraph(request->hgraph());
          response->set_candidates_added(added);
          response->set_generation(generation);
          // The request id goes into the record with the addition, so that a repeat on any
          // replica answers as this one (with what a replica that loads the record holds: the
          // H-Graph kept and shared).
          if (!request->request_id().empty()) {
            v1::AddPathsResponse first = *response;
            first.set_shared(true);
            first.set_retention(v1::RETENTION_KEPT);
            stored->requests.emplace_back(request->request_id(),
                                          std::make_pair(fingerprint, std::move(first)));
            if (stored->requests.size() > StoredHGraph::kMaxRequestIds)
              stored->requests.pop_front();
          }
          const SharedState::Write write = SaveHGraph(request->hgraph(), *stored, /*cas=*/true);
          if (write == SharedState::Write::kConflict) {
            spdlog::info("{}: another replica stored a newer version; adding again on it",
                         ClientText(request->hgraph()));
            cache_.Erase(CacheKind::kHGraph, request->hgraph());
            sessions_.ForgetHGraph(request->hgraph());
            response->Clear();
            continue;
          }
          response->set_shared(shared_ != nullptr && write == SharedState::Write::kStored);
          response->set_retention(Reaccount(request->hgraph(), *stored));
          if (response->retention() != v1::RETENTION_KEPT) response->clear_hgraph();
          RecordMerge("AddPaths", response->result());
          // This replica's repeat answers exactly this.
          if (!request->request_id().empty()) stored->requests.back().second.second = *response;
          return;
        }
      },
      /*on_worker=*/true);
  return call;
}

grpc::ServerUnaryReactor* PathMergerService::GetHGraph(grpc::CallbackServerContext* context,
                                                       const v1::GetHGraphRequest* request,
                                                       v1::HGraph* response) {
  auto* call = new UnaryCall(this, context, "GetHGraph", request->name());
  call->Run(
      [=, this](const CancelToken&) {
        const std::string session = SessionRegistry::SessionOfHGraph(request->name(), "name");
        TouchSession(session, "name", call->tenant());
        if (sessions_.StateOf(request->name()) == SessionRegistry::HGraphState::kRunning) {
          response->set_name(request->name());
          response->set_state(v1::HGraph::STATE_RUNNING);
          return;
        }
        const auto stored = HeldHGraph(request->name(), call->tenant(), "name");
        response->set_name(request->name());
        response->set_state(v1::HGraph::STATE_READY);
        *response->mutable_measure() = stored->measure;
        *response->mutable_options() = stored->options;
        *response->mutable_result() = stored->answer.result();
        std::lock_guard lock(stored->mutex);
        response->set_generation(stored->generation);
        for (const std::string& name : stored->input_names) response->add_inputs(name);
        response->set_nodes(stored->session->graph().num_nodes());
        response->set_edges(stored->session->graph().num_edges());
        response->set_memory_bytes(static_cast<int64_t>(stored->session->memory_bytes()));
      },
      /*on_worker=*/shared_ != nullptr);
  return call;
}

grpc::ServerUnaryReactor* PathMergerService::DeleteHGraph(grpc::CallbackServerContext* context,
                                                          const v1::DeleteHGraphRequest* request,
                                                          v1::DeleteHGraphResponse*) {
  auto* call = new UnaryCall(this, context, "DeleteHGraph", request->name());
  call->Run(
      [=, this](const CancelToken&) {
        const std::string session = SessionRegistry::SessionOfHGraph(request->name(), "name");
        TouchSession(session, "name", call->tenant());
        // One the store holds but this replica does not: loaded, so that it can be deleted.
        if (shared_ &&
            sessions_.StateOf(request->name()) == SessionRegistry::HGraphState::kUnknown) {
          LoadHGraph(request->name(), call->tenant(), "name");
        }
        switch (sessions_.StateOf(request->name())) {
          case SessionRegistry::HGraphState::kRunning:
            throw ServiceError(grpc::StatusCode::ABORTED, "MERGE_RUNNING", "name",
                               ClientText(request->name()) +
                                   " is still being merged; delete it once its merge is done",
                               std::chrono::milliseconds(1000));
          case SessionRegistry::HGraphState::kKept: break;
          default:
            throw ServiceError(grpc::StatusCode::NOT_FOUND, "HGRAPH_NOT_FOUND", "name",
                               ClientText(request->name()) + " is not held by this server");
        }
        sessions_.RemoveHGraph(request->name());
        cache_.Erase(CacheKind::kHGraph, request->name());
        if (shared_) shared_->DeleteHGraph(request->name());
      },
      /*on_worker=*/shared_ != nullptr);
  return call;
}

grpc::ServerUnaryReactor* PathMergerService::CheckPaths(grpc::CallbackServerContext* context,
                                                        const v1::CheckPathsRequest* request,
                                                        v1::CheckPathsResponse* response) {
  auto* call = new UnaryCall(this, context, "CheckPaths", request->session());
  call->Run(
      [=, this](const CancelToken& token) {
        const v1::Session session = TouchSession(request->session(), "session", call->tenant());
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
