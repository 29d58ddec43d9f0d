#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <condition_variable>
#include <mutex>
#include <optional>
#include <string>
#include <utility>

#include "core/adapter/merge_proto.h"
#include "core/adapter/path_io.h"
#include "core/adapter/scene_proto.h"
#include "core/common/limits.h"
#include "server/call_support.h"
#include "server/service.h"

namespace hgraph::server {

// MergePaths: progress events at a bounded rate with at most one write in flight, then the
// result. A report that comes while a write is in flight is dropped, unless it is one of the
// post-optimization's (an objective, maybe a path: the best so far): that one waits, a newer one
// replacing it, and goes out when the write is done, before the result.
class PathMergerService::MergeCall final : public grpc::ServerWriteReactor<v1::MergePathsResponse>,
                                           public CallBase {
 public:
  MergeCall(PathMergerService* service, grpc::CallbackServerContext* context,
            const v1::MergePathsRequest* request)
      // A merge with an hgraph_id outlives its client: its deadline does not stop it.
      : CallBase(service, context, "MergePaths", request->session(),
                 /*wire_deadline=*/request->hgraph_id().empty()),
        request_(request),
        durable_(!request->hgraph_id().empty()) {
    if (!Authenticated()) return;
    if (request->progress_interval_ms() < 0 ||
        request->progress_interval_ms() > limits::kMaxProgressIntervalMs) {
      const std::string message =
          "progress_interval_ms: must be in [0, " + std::to_string(limits::kMaxProgressIntervalMs) +
          "] (0 = the server's default), got " + std::to_string(request->progress_interval_ms());
      Complete(DetailedStatus(grpc::StatusCode::INVALID_ARGUMENT, message, "progress_interval_ms",
                              "INVALID_ARGUMENT"));
      return;
    }
    const int interval = request->progress_interval_ms() > 0
                             ? request->progress_interval_ms()
                             : service->options().progress_interval_ms;
    interval_ = std::chrono::milliseconds(interval);
    try {
      optimize_until_ = OptimizeUntil(*context, request->options());
    } catch (const InputError& e) {
      Complete(DetailedStatus(grpc::StatusCode::INVALID_ARGUMENT, e.what(), e.field(),
                              "INVALID_ARGUMENT"));
      return;
    }
    Submit([this] { Merge(&final_); });
  }

  void OnWriteDone(bool ok) override {
    bool send_final = false;
    bool send_waiting = false;
    {
      std::lock_guard lock(mutex_);
      writing_ = false;
      if (ok && improvement_waiting_) {
        // Before the result too: a client sees the last improvement whatever comes next.
        progress_message_.Swap(&waiting_message_);
        improvement_waiting_ = false;
        send_waiting = writing_ = true;
      } else if (final_pending_ && !final_sent_) {
        send_final = final_sent_ = true;
      }
    }
    // A failed write means the client has gone: stop the work.
    if (!ok) ClientGone();
    if (send_final) SendFinal();
    if (send_waiting) StartWrite(&progress_message_);
  }

  void OnCancel() override { ClientGone(); }
  // gRPC may run OnDone on its own thread before SendFinal has returned: it waits for that, so
  // that the result is freed after its serialization in a way ThreadSanitizer sees (gRPC's own
  // ordering is in uninstrumented code, and a result of 150,000 waypoints otherwise makes one
  // report per waypoint, which keeps a sanitized server busy for minutes).
  void OnDone() override {
    {
      std::unique_lock lock(mutex_);
      handed_over_.wait(lock, [this] { return final_returned_; });
    }
    delete this;
  }

 private:
  // The client went away (a cancel, a failed write, or its deadline): the merge stops, unless it
  // has an hgraph_id, which keeps it going until it is done (or the server shuts down).
  void ClientGone() {
    if (!durable_) return token_.Cancel();
    std::lock_guard lock(mutex_);
    if (final_pending_ || durable_registered_) return;
    durable_registered_ = service_->AddDurable(token_, &durable_id_);
    if (!durable_registered_) token_.Cancel();
  }

  // With options.optimize_to_deadline: when the post-optimization's budget ends, the call's
  // deadline less the margin kept for the answer (MergeOptions.deadline_margin_ms).
  static std::optional<Clock::time_point> OptimizeUntil(const grpc::CallbackServerContext& context,
                                                        const v1::MergeOptions& options) {
    if (options.has_deadline_margin_ms()) {
      limits::RequireRange(options.deadline_margin_ms(), 0, limits::kMaxDeadlineMarginMs,
                           "options.deadline_margin_ms");
    }
    if (!options.optimize_to_deadline()) return std::nullopt;
    if (options.has_optimize_ms()) {
      throw InputError("options.optimize_ms",
                       "must be unset with options.optimize_to_deadline (the deadline sets the "
                       "post-optimization's budget)");
    }
    const auto deadline = context.deadline();
    if (deadline == std::chrono::system_clock::time_point::max()) {
      throw InputError("options.optimize_to_deadline",
                       "needs a deadline on the call (the post-optimization spends what is left "
                       "of it)");
    }
    const double left_ms =
        std::chrono::duration<double, std::milli>(deadline - std::chrono::system_clock::now())
            .count();
    const double margin_ms = options.has_deadline_margin_ms()
                                 ? options.deadline_margin_ms()
                                 : std::max(limits::kMinDefaultDeadlineMarginMs, left_ms / 10);
    return Clock::now() + std::chrono::duration_cast<Clock::duration>(
                              std::chrono::duration<double, std::milli>(left_ms - margin_ms));
  }

  void Merge(v1::MergePathsResponse* out) {
    const v1::MergePathsRequest& request = *request_;
    const v1::Session session = service_->TouchSession(request.session(), "session", tenant_);
    CheckBatchLimits(request.paths(), service_->options());
    service_->CheckTenantCache(tenant_);
    if (request.paths().paths_size() == 0) throw InputError("paths.paths", "must not be empty");
    // A repeat under the same hgraph_id matches on everything but the progress rate.
    const std::string fingerprint =
        RequestFingerprint(request, v1::MergePathsRequest::kProgressIntervalMsFieldNumber);
    // A repeat of a merge another replica kept: its H-Graph, loaded, answers it.
    if (service_->shared_ && !request.hgraph_id().empty()) {
      const std::string kept = session.name() + "/hgraphs/" + request.hgraph_id();
      if (service_->sessions_.StateOf(kept) == SessionRegistry::HGraphState::kUnknown) {
        service_->LoadHGraph(kept, tenant_, "hgraph_id");
      }
    }
    bool repeat = false;
    const std::string name = service_->sessions_.ReserveHGraph(session.name(), request.hgraph_id(),
                                                               fingerprint, tenant_, &repeat);
    if (repeat) {
      const auto stored = service_->cache_.Get<StoredHGraph>(CacheKind::kHGraph, name);
      if (!stored) {
        throw ServiceError(grpc::StatusCode::NOT_FOUND, "HGRAPH_NOT_FOUND", "hgraph_id",
                           name +
                               " is no longer held by this server; merge again under a new "
                               "hgraph_id");
      }
      *out = stored->answer;
      return;
    }
    try {
      Build(session, name, fingerprint, out);
    } catch (...) {
      // Nothing kept under the name: a retry may merge again.
      service_->sessions_.AbandonHGraph(name);
      throw;
    }
  }

  void Build(const v1::Session& session, const std::string& name, const std::string& fingerprint,
             v1::MergePathsResponse* out) {
    const v1::MergePathsRequest& request = *request_;
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
    stored->planner = std::make_unique<LocalPlanner>(
        scene.world,
        LocalPlannerOptions{.resolution = resolution, .clearance_bound = scene.clearance_bound});
    WithRequestPaths(
        [&] { stored->session = std::make_unique<HybridizationSession>(*stored->planner, merge); });
    const MergeResult result = stored->session->Query(merge.measure, merge.progress, token_,
                                                      std::nullopt, optimize_until_);
    *out->mutable_result() = MergeResultToProto(result);
    EchoEvaluation(request.options(), out->mutable_result());
    service_->RecordMerge("MergePaths", out->result());
    stored->measure = request.measure();
    stored->options = request.options();
    stored->fingerprint = fingerprint;
    stored->resolution = resolution;
    stored->tenant = tenant_;
    stored->scene_digest = session.scene();
    for (const v1::Path& path : request.paths().paths()) stored->input_names.push_back(path.name());

    Keep(session.name(), name, std::move(stored), out);
  }

  // Called from engine worker threads.
  void OnProgress(const Progress& progress) {
    const Clock::time_point now = Clock::now();
    // The first report goes out at once so that even a short merge shows progress, and so
    // does each report of the post-optimization.
    const bool improvement = !std::isnan(progress.objective);
    {
      std::lock_guard lock(mutex_);
      if (final_pending_) return;
      if (writing_) {
        if (!improvement) return;
        Fill(progress, now, &waiting_message_);
        improvement_waiting_ = true;
        return;
      }
      if (sent_any_ && !improvement && now - last_sent_ < interval_) return;
      writing_ = true;
      sent_any_ = true;
      last_sent_ = now;
      Fill(progress, now, &progress_message_);
    }
    StartWrite(&progress_message_);
  }

  void Fill(const Progress& progress, Clock::time_point now, v1::MergePathsResponse* out) const {
    v1::MergeProgress* p = out->mutable_progress();
    p->set_phase(progress.phase);
    p->set_done(progress.done);
    p->set_total(progress.total);
    p->set_collision_checks(progress.collision_checks);
    p->set_distance_queries(progress.distance_queries);
    p->set_elapsed_ms(std::chrono::duration<double, std::milli>(now - started_).count());
    if (!std::isnan(progress.objective)) {
      p->set_objective(progress.objective);
    } else {
      p->clear_objective();
    }
    if (progress.path) {
      *p->mutable_path() = PathToProto(*progress.path);
    } else {
      p->clear_path();
    }
  }

  void Complete(const grpc::Status& status) override {
    bool send_final = false;
    {
      std::lock_guard lock(mutex_);
      status_ = Final(status);
      with_result_ = status.ok();
      final_pending_ = true;
      if (durable_registered_) service_->RemoveDurable(durable_id_);
      durable_registered_ = false;
      if (!writing_) send_final = final_sent_ = true;
    }
    if (send_final) SendFinal();
  }

  // Called once, by the thread that set final_sent_.
  void SendFinal() {
    if (with_result_) {
      StartWriteAndFinish(&final_, grpc::WriteOptions(), grpc::Status::OK);
    } else {
      Finish(status_);
    }
    std::lock_guard lock(mutex_);
    final_returned_ = true;
    handed_over_.notify_all();
  }

  const v1::MergePathsRequest* request_;
  const bool durable_;                               // has an hgraph_id: outlives its client
  std::optional<Clock::time_point> optimize_until_;  // options.optimize_to_deadline
  std::chrono::milliseconds interval_{100};

  std::mutex mutex_;
  bool writing_ = false;
  bool sent_any_ = false;
  bool final_pending_ = false;
  bool final_sent_ = false;
  bool final_returned_ = false;  // SendFinal has returned (OnDone waits for it)
  std::condition_variable handed_over_;
  Clock::time_point last_sent_;
  v1::MergePathsResponse progress_message_;
  // A report of the post-optimization that came while a write was in flight.
  v1::MergePathsResponse waiting_message_;
  bool improvement_waiting_ = false;
  bool durable_registered_ = false;  // with the service, after the client went away
  uint64_t durable_id_ = 0;
  v1::MergePathsResponse final_;
  grpc::Status status_;
  bool with_result_ = false;
};

grpc::ServerWriteReactor<v1::MergePathsResponse>* PathMergerService::MergePaths(
    grpc::CallbackServerContext* context, const v1::MergePathsRequest* request) {
  return new MergeCall(this, context, request);
}

}  // namespace hgraph::server
