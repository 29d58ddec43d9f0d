// `hgraph solve`: the best certified path for a scene's start and goal within a time budget, from
// a portfolio of OMPL planners whose paths are merged as they arrive; in process or through
// hgraph-server (--server). One request builder (BuildRequest) and one printout serve both runs.
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "client/cli/cli_common.h"
#include "client/cli/command.h"
#include "client/cli/remote.h"
#include "client/cli/request_flags.h"
#include "core/adapter/json_io.h"
#include "core/adapter/merge_proto.h"
#include "core/adapter/path_io.h"
#include "core/adapter/scene_proto.h"
#include "core/solve/solve.h"
#include "hgraph/v1/service.pb.h"

namespace hgraph::cli {
namespace {

struct SolveFlags {
  std::string scene;
  std::string out;
  std::string out_path;
  double budget_s = 3;
  std::vector<std::string> planners;  // NAME or NAME:RUNS
  uint64_t seed = 1;
  int parallel = 0;
  MeasureFlags measure;
  bool quiet = false;
  RequestFlags<v1::SolveRequest> fields;  // --plan-fraction, --resolution
};

// "bitstar:2" -> {bitstar, 2}; "prm" -> {prm, 1}.
v1::PortfolioEntry ParseEntry(const std::string& text) {
  v1::PortfolioEntry entry;
  const size_t colon = text.find(':');
  const std::string name = text.substr(0, colon);
  entry.set_planner(PlannerTypeName(ParsePlannerType(name, "--planner")));
  entry.set_runs(1);
  if (colon != std::string::npos) {
    const std::string runs = text.substr(colon + 1);
    size_t used = 0;
    int n = 0;
    try {
      n = std::stoi(runs, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != runs.size() || n < 1 || n > kMaxSolveRuns) {
      throw InputError("--planner", "runs in '" + text + "' must be a whole number in [1, " +
                                        std::to_string(kMaxSolveRuns) + "]");
    }
    entry.set_runs(n);
  }
  return entry;
}

v1::SolveRequest BuildRequest(const SolveFlags& f, const v1::Scene& scene, double* resolution) {
  if (!scene.has_start() || !scene.has_goal()) {
    throw InputError(f.scene, "the scene has no start and goal to solve between");
  }
  v1::SolveRequest request;
  f.fields.Apply(request);
  for (const std::string& p : f.planners) *request.add_portfolio() = ParseEntry(p);
  request.set_budget_s(f.budget_s);
  request.set_seed(f.seed);
  request.set_parallel(f.parallel);
  try {
    *request.mutable_measure() = f.measure.ToProto();
    *resolution = ResolutionFromProto(request.options(), scene);
  } catch (const Error& e) {
    f.fields.Rethrow(e);
  }
  if (!(f.budget_s >= kMinSolveBudgetS && f.budget_s <= kMaxSolveBudgetS)) {
    char text[64];
    std::snprintf(text, sizeof(text), "must be in [%g, %g] s, got %g", kMinSolveBudgetS,
                  kMaxSolveBudgetS, f.budget_s);
    throw InputError("--budget", text);
  }
  return request;
}

void PrintHeader() {
  std::printf("%-18s %-16s %10s %10s %12s\n", "run", "status", "start (ms)", "time (ms)", "length");
  std::fflush(stdout);
}

void PrintRun(const v1::SolveRun& run) {
  const std::string name = run.planner() + "-" + std::to_string(run.index());
  const char* status = !run.found() ? "not found" : run.certified() ? "certified" : "uncertified";
  std::printf("%-18s %-16s %10.1f %10.1f %12s\n", name.c_str(), status, run.start_ms(),
              run.elapsed_ms(), run.found() ? Cell(run.length(), 12).c_str() : "-");
  std::fflush(stdout);
}

void PrintProgress(const SolveFlags& f, const v1::SolveProgress& p) {
  if (p.has_run()) PrintRun(p.run());
  if (p.has_objective() && !f.quiet) {
    std::fprintf(stderr, "best %.6g at %.0f ms (%d paths merged)\n", p.objective(), p.elapsed_ms(),
                 p.inputs());
  }
}

// The result's table, the files, and the exit code: 1 when no path was found.
int Finish(const SolveFlags& f, const v1::Scene& scene, const v1::SolveResponse& response) {
  const v1::SolveResult& r = response.result();
  if (!f.out.empty()) WriteTextFile(f.out, ToJson(r));
  if (!r.found()) {
    std::printf("no path: %s\n", r.message().c_str());
    std::fprintf(stderr, "error: %s\n", r.message().c_str());
    return kExitCheckFailed;
  }
  const MergeResult result = MergeResultFromProto(r.merge());
  if (!f.out_path.empty()) {
    WritePathsFile(f.out_path, {result.path}, SpaceFromProto(scene.space(), "scene.space"));
  }
  PrintMergeTable(result);
  std::printf("solved in %.0f ms (planning %.0f ms, budget %g s): %s %.6g from %d paths\n",
              r.elapsed_ms(), r.plan_ms(), r.budget_s(), MeasureTypeName(result.measure.type),
              result.objective, static_cast<int>(result.inputs.size()));
  if (!response.hgraph().empty()) std::printf("hgraph %s\n", response.hgraph().c_str());
  return kExitOk;
}

v1::SolveRun RunToProto(const SolveRun& run) {
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

int RunLocal(const SolveFlags& f) {
  v1::Scene scene_proto = ReadSceneFile(f.scene);
  double resolution = 0;
  const v1::SolveRequest proto = BuildRequest(f, scene_proto, &resolution);
  const LoadedScene loaded = [&] {
    try {
      return LoadScene(scene_proto, f.scene, resolution);
    } catch (const Error& e) {
      f.fields.Rethrow(e);
    }
  }();
  SolveRequest request{.start = *loaded.scene->start,
                       .goal = *loaded.scene->goal,
                       .measure = MeasureFromProto(proto.measure()),
                       .budget_s = proto.budget_s(),
                       .plan_fraction = proto.has_plan_fraction() ? proto.plan_fraction() : -1,
                       .parallel = proto.parallel(),
                       .seed = proto.seed(),
                       .resolution = resolution};
  for (const v1::PortfolioEntry& e : proto.portfolio()) {
    request.portfolio.push_back(
        {.planner = ParsePlannerType(e.planner(), "--planner"), .runs = e.runs()});
  }
  request.on_run = [&](const SolveRun& run) {
    v1::SolveProgress p;
    *p.mutable_run() = RunToProto(run);
    PrintProgress(f, p);
  };
  request.on_update = [&](const SolveUpdate& u) {
    v1::SolveProgress p;
    p.set_objective(u.objective);
    p.set_elapsed_ms(u.elapsed_ms);
    p.set_inputs(u.inputs);
    PrintProgress(f, p);
  };
  PrintHeader();
  SolveResult solved;
  try {
    solved = Solve(*loaded.planner, request);
  } catch (const Error& e) {
    f.fields.Rethrow(e);
  }
  // Runs that never started are listed too (the table above shows those that ended).
  for (const SolveRun& run : solved.runs) {
    if (run.status.rfind("not started", 0) == 0) PrintRun(RunToProto(run));
  }
  v1::SolveResponse response;
  v1::SolveResult* r = response.mutable_result();
  r->set_found(solved.found);
  r->set_message(solved.message);
  for (const SolveRun& run : solved.runs) *r->add_runs() = RunToProto(run);
  r->set_plan_ms(solved.plan_ms);
  r->set_most_runs_at_once(solved.most_runs_at_once);
  r->set_runs_on_call_worker(solved.runs_on_caller);
  r->set_elapsed_ms(solved.elapsed_ms);
  r->set_budget_s(proto.budget_s());
  if (solved.found) *r->mutable_merge() = MergeResultToProto(solved.result);
  return Finish(f, scene_proto, response);
}

int RunRemote(const SolveFlags& f, const RemoteOptions& remote) {
  const v1::Scene scene_proto = ReadSceneFile(f.scene);
  double resolution = 0;
  v1::SolveRequest request = BuildRequest(f, scene_proto, &resolution);
  RemoteClient client(remote);
  v1::Scene uploaded;
  request.set_session(OpenSceneFile(client, f.scene, remote, &uploaded));
  PrintHeader();
  const v1::SolveResponse response =
      client.Solve(request, [&](const v1::SolveProgress& p) { PrintProgress(f, p); });
  for (const v1::SolveRun& run : response.result().runs()) {
    if (run.message().rfind("not started", 0) == 0) PrintRun(run);
  }
  return Finish(f, scene_proto, response);
}

}  // namespace

Subcommand AddSolveCommand(CLI::App& parent) {
  auto flags = std::make_shared<SolveFlags>();
  SolveFlags& f = *flags;
  CLI::App* app = parent.add_subcommand(
      "solve",
      "The best certified path between the scene's start and goal within a time budget: a "
      "portfolio of OMPL planners runs, and each path is merged into one H-Graph as it arrives. "
      "Exit 1 if no path was found in time.");
  app->add_option("--scene", f.scene, "Scene JSON (hgraph.v1.Scene) with start and goal")
      ->required();
  app->add_option("--budget", f.budget_s, "Whole time budget, seconds (planning and merging)")
      ->capture_default_str();
  app->add_option("--planner", f.planners,
                  "A planner of the portfolio and its runs, NAME[:RUNS] (repeat the flag): prm, "
                  "prm-cycles, prmstar, rrt, rrtconnect, lazyprm, rrtstar, informed-rrtstar, "
                  "bitstar, aitstar (default: below a 10 s budget one rrtstar run, started "
                  "first, and prm runs in the other --parallel slots, two runs per slot in all, "
                  "or two prm runs with one slot; from a 10 s budget on one prm run per slot, "
                  "then bitstar and rrtstar sharing the time prm leaves)");
  f.fields.Add<double>(
      app, "--plan-fraction",
      "Share of the budget in which planners run once a path is certified, in (0, 1] "
      "(default 0.7); the rest merges",
      "plan_fraction", [](v1::SolveRequest& r, const double& v) { r.set_plan_fraction(v); });
  app->add_option("--parallel", f.parallel, "Planner runs at once (default: all cores)")
      ->capture_default_str();
  app->add_option("--seed", f.seed, "Seed; run i uses a seed derived from (seed, i)")
      ->capture_default_str();
  f.measure.Add(app);
  f.fields.Add<double>(
      app, "--resolution",
      "Collision-check resolution, fraction of the space's extent (default: the scene's)",
      "options.resolution",
      [](v1::SolveRequest& r, const double& v) { r.mutable_options()->set_resolution(v); });
  app->add_option("--out", f.out, "Write the SolveResult JSON here");
  app->add_option("--out-path", f.out_path,
                  "Write the path here (.json: PathSet; .path: OMPL's PathGeometric printout; "
                  "otherwise OMPL text)");
  f.fields.Name("budget_s", "--budget");
  f.fields.Name("parallel", "--parallel");
  f.fields.Name("start", "--scene");
  f.fields.Name("goal", "--scene");
  f.fields.Name("scene.resolution", "--scene");
  return Subcommand{
      .app = app,
      .run = [flags] { return RunLocal(*flags); },
      .run_remote = [flags](const RemoteOptions& remote) { return RunRemote(*flags, remote); },
      .quiet = &f.quiet};
}

}  // namespace hgraph::cli
