#include <cmath>
#include <functional>
#include <memory>
#include <string>
#include <utility>

#include "core/adapter/merge_proto.h"
#include "core/adapter/path_io.h"
#include "core/adapter/scene_proto.h"
#include "core/common/limits.h"
#include "server/call_support.h"
#include "server/service.h"
#ifdef HGRAPH_HAVE_SOLVE
#include "core/solve/solve.h"
#endif

namespace hgraph::server {

#ifdef HGRAPH_HAVE_SOLVE
// Solve: runs the portfolio and the merge on a worker, the planner runs on idle workers beside it;
// each ended run and each improvement is queued and written in order, one write in flight, then
// the result and the status.
class PathMergerService::SolveCall final : public StreamingCall<v1::SolveResponse> {
 public:
  // A failed call ends with its status alone: no result follows its progress events.
  SolveCall(PathMergerService* service, grpc::CallbackServerContext* context,
            const v1::SolveRequest* request)
      : StreamingCall(service, context, "Solve", request->session(), /*drop_on_error=*/true),
        request_(request) {
    if (!Authenticated()) return;
    Submit([this] { Run(); });
  }

 private:
  static constexpr double kDefaultBudgetS = 3;

  // The engine's request from the proto one, every field range-checked (errors name it).
  SolveRequest Build(const v1::SolveRequest& request, const Scene& model, double resolution) {
    SolveRequest solve{.measure = MeasureFromProto(request.measure()),
                       .merge = MergeOptionsFromProto(request.options()),
                       .budget_s = request.budget_s() == 0 ? kDefaultBudgetS : request.budget_s(),
                       .plan_fraction = request.has_plan_fraction() ? request.plan_fraction() : -1,
                       .parallel = request.parallel(),
                       .seed = request.seed(),
                       .resolution = resolution};
    if (request.options().has_optimize_ms() && request.options().optimize_ms() != 0) {
      throw InputError("options.optimize_ms",
                       "must be unset (the budget sets the post-optimization's time) or 0 "
                       "(off), got " +
                           std::to_string(request.options().optimize_ms()));
    }
    if (request.options().optimize_to_deadline()) {
      throw InputError("options.optimize_to_deadline",
                       "is not taken by Solve: the budget sets the post-optimization's time");
    }
    if (request.has_plan_fraction() &&
        !(request.plan_fraction() > 0 && request.plan_fraction() <= 1)) {
      throw InputError("plan_fraction",
                       "must be in (0, 1], got " + std::to_string(request.plan_fraction()));
    }
    if (request.parallel() < 0 || request.parallel() > kMaxSolveRuns) {
      throw InputError("parallel", "must be in [0, " + std::to_string(kMaxSolveRuns) +
                                       "] (0 = the server's threads), got " +
                                       std::to_string(request.parallel()));
    }
    const int threads = service_->pool().threads();
    if (solve.merge.threads <= 0 || solve.merge.threads > threads) solve.merge.threads = threads;
    // 0: the pool's threads. More than the pool has free never run at once: the planner runs go
    // to idle workers only (the call's own worker plans the rest).
    if (solve.parallel == 0) solve.parallel = threads;
    int runs = 0;
    for (int i = 0; i < request.portfolio_size(); ++i) {
      const v1::PortfolioEntry& entry = request.portfolio(i);
      const std::string field = "portfolio[" + std::to_string(i) + "]";
      const PlannerType planner = ParsePlannerType(entry.planner(), field + ".planner");
      if (entry.runs() < 0 || entry.runs() > kMaxSolveRuns) {
        throw InputError(field + ".runs", "must be in [0, " + std::to_string(kMaxSolveRuns) +
                                              "] (0 = 1), got " + std::to_string(entry.runs()));
      }
      solve.portfolio.push_back({.planner = planner, .runs = std::max(1, entry.runs())});
      runs += std::max(1, entry.runs());
    }
    if (solve.portfolio.empty()) {
      for (const PortfolioEntry& e :
           DefaultPortfolio(solve.parallel > 0 ? solve.parallel : threads, solve.budget_s)) {
        runs += e.runs;
      }
    }
    CheckPathCount(runs, "portfolio", "planner runs (one path each)", service_->options());
    solve.start = EndpointOf(request.has_start(), request.start(), model.start, "start");
    solve.goal = EndpointOf(request.has_goal(), request.goal(), model.goal, "goal");
    return solve;
  }

  void Run() {
    const v1::SolveRequest& request = *request_;
    const v1::Session session = service_->sessions_.Touch(request.session(), "session", tenant_);
    LoadedScene scene = service_->scenes_.Get(session.scene(), "session", token_);
    const double resolution = ResolutionFromProto(request.options(), *scene.proto);
    SolveRequest solve = Build(request, scene.world->scene(), resolution);
    solve.cancel = token_;
    // The planner runs go on the worker pool, beside this job, while it has an idle worker and
    // a free admission slot.
    solve.start_beside = [pool = &service_->pool()](std::function<void()> task) {
      return pool->TryRunOnIdleWorker(std::move(task));
    };
    solve.on_run = [this](const SolveRun& run) {
      v1::SolveResponse event;
      v1::SolveProgress* p = event.mutable_progress();
      p->set_elapsed_ms(run.start_ms + run.elapsed_ms);
      *p->mutable_run() = RunToProto(run);
      Send(std::move(event));
    };
    solve.on_update = [this](const SolveUpdate& update) {
      v1::SolveResponse event;
      v1::SolveProgress* p = event.mutable_progress();
      p->set_elapsed_ms(update.elapsed_ms);
      p->set_objective(update.objective);
      p->set_inputs(update.inputs);
      if (update.path) *p->mutable_path() = PathToProto(*update.path);
      Send(std::move(event));
    };

    auto stored = std::make_shared<StoredHGraph>();
    stored->scene = scene;
    stored->planner = std::make_unique<LocalPlanner>(
        scene.world,
        LocalPlannerOptions{.resolution = resolution, .clearance_bound = scene.clearance_bound});
    SolveResult solved = ::hgraph::Solve(*stored->planner, solve);

    v1::SolveResponse final_event;
    v1::SolveResult* out = final_event.mutable_result();
    out->set_found(solved.found);
    out->set_message(solved.message);
    for (const SolveRun& run : solved.runs) *out->add_runs() = RunToProto(run);
    out->set_plan_ms(solved.plan_ms);
    out->set_most_runs_at_once(solved.most_runs_at_once);
    out->set_runs_on_call_worker(solved.runs_on_caller);
    out->set_budget_s(solve.budget_s);
    if (solved.found) {
      *out->mutable_merge() = MergeResultToProto(solved.result);
      EchoEvaluation(request.options(), out->mutable_merge());
      service_->RecordMerge("Solve", out->merge());
      // Kept as a merge's H-Graph: Requery, AddPaths and GetHGraph take its name.
      const std::string name = service_->sessions_.ReserveHGraph(
          session.name(), "", RequestFingerprint(request), tenant_, /*repeat=*/&repeat_);
      stored->session = std::move(solved.session);
      stored->measure = request.measure();
      stored->options = request.options();
      stored->fingerprint = RequestFingerprint(request);
      for (const InputPath& path : solved.inputs) stored->input_names.push_back(path.name);
      v1::MergePathsResponse answer;
      *answer.mutable_result() = out->merge();
      Keep(session.name(), name, std::move(stored), &answer);
      final_event.set_hgraph(answer.hgraph());
      final_event.set_generation(answer.generation());
      final_event.set_retention(answer.retention());
    }
    out->set_elapsed_ms(MsSince(started_));
    Send(std::move(final_event));
  }

  static v1::SolveRun RunToProto(const SolveRun& run) {
    v1::SolveRun out;
    out.set_planner(PlannerTypeName(run.planner));
    out.set_index(run.index);
    out.set_seed(run.seed);
    out.set_time_s(run.time_s);
    out.set_start_ms(run.start_ms);
    out.set_elapsed_ms(run.elapsed_ms);
    out.set_found(run.found);
    out.set_certified(run.certified);
    out.set_length(run.length);
    out.set_message(run.status);
    out.set_path_name(run.path_name);
    return out;
  }

  const v1::SolveRequest* request_;
  bool repeat_ = false;  // ReserveHGraph's: never set without an hgraph_id
};

grpc::ServerWriteReactor<v1::SolveResponse>* PathMergerService::Solve(
    grpc::CallbackServerContext* context, const v1::SolveRequest* request) {
  return new SolveCall(this, context, request);
}
#else
grpc::ServerWriteReactor<v1::SolveResponse>* PathMergerService::Solve(
    grpc::CallbackServerContext*, const v1::SolveRequest* request) {
  // Finishes at once: this build has no OMPL planners.
  return FinishedStream<v1::SolveResponse>(
      this, "Solve", request->session(),
      DetailedStatus(grpc::StatusCode::UNIMPLEMENTED,
                     "Solve: this server was built without core/solve (the OMPL planners); plan "
                     "paths on the client and call MergePaths",
                     "", "UNIMPLEMENTED"));
}
#endif

}  // namespace hgraph::server
