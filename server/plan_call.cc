#include <condition_variable>
#include <deque>
#include <mutex>
#include <string>
#include <utility>

#include "core/adapter/path_io.h"
#include "core/adapter/scene_proto.h"
#include "core/common/limits.h"
#include "server/call_support.h"
#include "server/service.h"
#ifdef HGRAPH_HAVE_PLAN
#include "core/plan/plan.h"
#endif

namespace hgraph::server {

#ifdef HGRAPH_HAVE_PLAN
// PlanPaths: plans on a worker; each path found (and, with report_failures, each attempt that
// found none) is queued and written in order, one write in flight, then the status.
class PathMergerService::PlanCall final : public grpc::ServerWriteReactor<v1::PlanPathsResponse>,
                                          public CallBase {
 public:
  PlanCall(PathMergerService* service, grpc::CallbackServerContext* context,
           const v1::PlanPathsRequest* request)
      : CallBase(service, context, "PlanPaths", request->session()), request_(request) {
    if (!Authenticated()) return;
    Submit([this] { Plan(); });
  }

  void OnWriteDone(bool ok) override {
    if (!ok) token_.Cancel();
    Pump(/*write_done=*/true);
  }
  void OnCancel() override { token_.Cancel(); }
  // The Finish may come from OnWriteDone's Pump while Complete's own Pump is still to run on the
  // worker: the call is freed only once Complete has returned.
  void OnDone() override {
    {
      std::unique_lock lock(mutex_);
      completed_.wait(lock, [this] { return complete_returned_; });
    }
    delete this;
  }

 private:
  void Plan() {
    const v1::PlanPathsRequest& request = *request_;
    const v1::Session session = service_->TouchSession(request.session(), "session", tenant_);
    if (request.count() < 0) {
      throw InputError("count",
                       "must be >= 0 (0 = one path), got " + std::to_string(request.count()));
    }
    if (request.time_per_path_s() != 0) {
      limits::RequirePositiveUpTo(request.time_per_path_s(), limits::kMaxPlanSeconds,
                                  "time_per_path_s");
    }
    CheckPathCount(request.count(), "count", "paths", service_->options());
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
    plan.keep_uncertified = request.keep_uncertified();
    if (request.sampled_motions()) plan.motion_check = OmplMotionCheck::kDiscrete;
    plan.on_path = [this](const PlanAttempt& attempt, const InputPath& path) {
      v1::PlanPathsResponse event;
      *event.mutable_path() = PathToProto(path);
      event.set_index(attempt.index);
      event.set_elapsed_ms(attempt.elapsed_ms);
      if (!attempt.certified) event.set_uncertified_edge(attempt.invalid_edge);
      Send(std::move(event));
    };
    if (request.report_failures()) {
      plan.on_failure = [this, planner = plan.planner](const PlanAttempt& attempt) {
        v1::PlanPathsResponse event;
        event.set_index(attempt.index);
        event.set_elapsed_ms(attempt.elapsed_ms);
        *event.mutable_failure() = FailureToProto(attempt, planner);
        Send(std::move(event));
      };
    }
    LocalPlanner checker(scene.world,
                         LocalPlannerOptions{.resolution = plan.resolution,
                                             .clearance_bound = scene.clearance_bound});
    ::hgraph::PlanPaths(checker, plan);
  }

  static v1::PlanAttemptFailure FailureToProto(const PlanAttempt& attempt, PlannerType planner) {
    v1::PlanAttemptFailure failure;
    switch (attempt.failure) {
      case PlanFailure::kNone: break;
      case PlanFailure::kNoSolution:
        failure.set_reason(v1::PlanAttemptFailure::REASON_NO_SOLUTION);
        break;
      case PlanFailure::kOtherEndpoints:
        failure.set_reason(v1::PlanAttemptFailure::REASON_OTHER_ENDPOINTS);
        break;
      case PlanFailure::kInvalidEdge:
        failure.set_reason(v1::PlanAttemptFailure::REASON_INVALID_EDGE);
        failure.set_invalid_edge(attempt.invalid_edge);
        break;
    }
    failure.set_planner(PlannerTypeName(planner));
    failure.set_seed(attempt.seed);
    failure.set_message(attempt.status);
    return failure;
  }

  // Queues one event; events go out in the order they were queued.
  void Send(v1::PlanPathsResponse event) {
    {
      std::lock_guard lock(mutex_);
      queue_.push_back(std::move(event));
    }
    Pump(/*write_done=*/false);
  }

  void Complete(const grpc::Status& status) override {
    {
      std::lock_guard lock(mutex_);
      status_ = Final(status);
      done_ = true;
    }
    Pump(/*write_done=*/false);
    std::lock_guard lock(mutex_);
    complete_returned_ = true;
    completed_.notify_all();
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

  const v1::PlanPathsRequest* request_;
  std::mutex mutex_;
  std::deque<v1::PlanPathsResponse> queue_;
  bool writing_ = false;
  bool done_ = false;
  bool finished_ = false;
  bool complete_returned_ = false;  // OnDone waits for it
  std::condition_variable completed_;
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
  const grpc::Status status = DetailedStatus(
      grpc::StatusCode::UNIMPLEMENTED,
      "PlanPaths: this server was built without core/plan (the OMPL input planners); generate "
      "paths on the client",
      "", "UNIMPLEMENTED");
  RecordCall("PlanPaths", request->session(), RecordStart("PlanPaths"), status);
  return new Unimplemented(status);
}
#endif

}  // namespace hgraph::server
