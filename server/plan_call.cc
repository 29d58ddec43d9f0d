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
class PathMergerService::PlanCall final : public StreamingCall<v1::PlanPathsResponse> {
 public:
  PlanCall(PathMergerService* service, grpc::CallbackServerContext* context,
           const v1::PlanPathsRequest* request)
      : StreamingCall(service, context, "PlanPaths", request->session(), /*drop_on_error=*/false),
        request_(request) {
    if (!Authenticated()) return;
    Submit([this] { Plan(); });
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
    plan.start = EndpointOf(request.has_start(), request.start(), model.start, "start");
    plan.goal = EndpointOf(request.has_goal(), request.goal(), model.goal, "goal");
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

  const v1::PlanPathsRequest* request_;
};

grpc::ServerWriteReactor<v1::PlanPathsResponse>* PathMergerService::PlanPaths(
    grpc::CallbackServerContext* context, const v1::PlanPathsRequest* request) {
  return new PlanCall(this, context, request);
}
#else
grpc::ServerWriteReactor<v1::PlanPathsResponse>* PathMergerService::PlanPaths(
    grpc::CallbackServerContext*, const v1::PlanPathsRequest* request) {
  // Finishes at once: this build has no OMPL planners.
  return FinishedStream<v1::PlanPathsResponse>(
      this, "PlanPaths", request->session(),
      DetailedStatus(grpc::StatusCode::UNIMPLEMENTED,
                     "PlanPaths: this server was built without core/plan (the OMPL input "
                     "planners); generate paths on the client",
                     "", "UNIMPLEMENTED"));
}
#endif

}  // namespace hgraph::server
