// `hgraph plan`: input paths for a scene from OMPL's planners, each checked with the scene's
// local planner, written as a PathSet; in process or through hgraph-server (--server). One
// request builder (BuildRequest) and one printout (PrintPlan) serve both runs.
#include <chrono>
#include <cstdio>
#include <functional>
#include <string>

#include "client/cli/cli_common.h"
#include "client/cli/command.h"
#include "client/cli/remote.h"
#include "client/cli/request_flags.h"
#include "core/adapter/path_io.h"
#include "core/adapter/scene_proto.h"
#include "core/plan/plan.h"
#include "hgraph/v1/service.pb.h"

namespace hgraph::cli {
namespace {

struct PlanFlags {
  std::string scene;
  std::string out;
  std::string planner = PlannerTypeName(PlanRequest().planner);
  int count = 1;
  double time_s = 1.0;
  uint64_t seed = 1;
  bool simplify = false;
  bool quiet = false;
  // --resolution, and the names of the fields the other flags fill.
  RequestFlags<v1::PlanPathsRequest> fields;
};

// The request the service receives (without its session). *resolution gets the resolution the
// paths are checked at: the flag, else the scene's.
v1::PlanPathsRequest BuildRequest(const PlanFlags& f, const v1::Scene& scene, double* resolution) {
  v1::PlanPathsRequest request;
  f.fields.Apply(request);
  try {
    request.set_planner(PlannerTypeName(ParsePlannerType(f.planner, "planner")));
    *resolution = request.has_resolution() ? request.resolution() : SceneResolution(scene);
  } catch (const Error& e) {
    f.fields.Rethrow(e);
  }
  if (!scene.has_start() || !scene.has_goal()) {
    throw InputError(f.scene, "the scene has no start and goal to plan between");
  }
  request.set_count(f.count);
  request.set_time_per_path_s(f.time_s);
  request.set_seed(f.seed);
  request.set_simplify(f.simplify);
  return request;
}

// One line per requested path (found or not), the summary, and the exit code: 1 if fewer than
// --count were found. The status column says only "found" or "not found", which both runs know.
int PrintPlan(const PlanFlags& f, const v1::PlanPathsRequest& request, const Space& space,
              double straight, const std::vector<PlanAttempt>& attempts,
              const std::vector<InputPath>& paths) {
  int found = 0;
  std::string missing;
  for (const PlanAttempt& a : attempts) {
    const std::string name = request.planner() + "-" + std::to_string(a.index);
    if (a.found) {
      ++found;
      std::printf("%-16s %-10s %10.1f %9d %12s %9s\n", name.c_str(), "found", a.elapsed_ms,
                  a.waypoints, Cell(a.length, 12).c_str(),
                  Cell(straight > 0 ? a.length / straight : 0, 9, 3).c_str());
    } else {
      std::printf("%-16s %-10s %10.1f %9s %12s %9s\n", name.c_str(), "not found", a.elapsed_ms, "-",
                  "-", "-");
      missing += (missing.empty() ? "" : ", ") + std::to_string(a.index);
    }
  }
  // Nothing found, nothing written: a stale file from an earlier run would read as success.
  const bool write = !f.out.empty() && found > 0;
  if (write) WritePathsFile(f.out, paths, space);
  std::printf("found %d of %d paths with %s in %g s each (seed %llu)%s%s\n", found, f.count,
              request.planner().c_str(), f.time_s, static_cast<unsigned long long>(f.seed),
              write ? "; wrote " : "", write ? f.out.c_str() : "");
  if (found < f.count) {
    std::fprintf(stderr, "error: %s found no path within %g s in %d of %d runs (index %s); %s\n",
                 request.planner().c_str(), f.time_s, f.count - found, f.count, missing.c_str(),
                 found > 0 ? "the paths found were written" : "no path was written");
    return kExitCheckFailed;
  }
  return kExitOk;
}

void PrintHeader() {
  std::printf("%-16s %-10s %10s %9s %12s %9s\n", "path", "status", "time (ms)", "waypoints",
              "length", "/ direct");
  std::fflush(stdout);
}

int RunLocal(const PlanFlags& f) {
  v1::Scene scene_proto = ReadSceneFile(f.scene);
  double resolution = 0;
  const v1::PlanPathsRequest proto = BuildRequest(f, scene_proto, &resolution);
  // The local planner checks the resolution the flag gave.
  const LoadedScene loaded = [&] {
    try {
      return LoadScene(std::move(scene_proto), f.scene, resolution);
    } catch (const Error& e) {
      f.fields.Rethrow(e);
    }
  }();
  const Space& space = loaded.scene->space;
  PlanRequest request{.planner = ParsePlannerType(proto.planner(), "planner"),
                      .start = *loaded.scene->start,
                      .goal = *loaded.scene->goal,
                      .count = proto.count(),
                      .time_s = proto.time_per_path_s(),
                      .seed = proto.seed(),
                      .simplify = proto.simplify(),
                      .resolution = resolution};
  PrintHeader();
  PlanResult result;
  try {
    result = PlanPaths(*loaded.planner, request);
  } catch (const Error& e) {
    f.fields.Rethrow(e);
  }
  // OMPL's own word on the runs that found nothing (the table says only "not found").
  for (const PlanAttempt& a : result.attempts) {
    if (!a.found) std::fprintf(stderr, "run %d: %s\n", a.index, a.status.c_str());
  }
  return PrintPlan(f, proto, space, space.Distance(request.start, request.goal), result.attempts,
                   result.paths);
}

int RunRemote(const PlanFlags& f, const RemoteOptions& remote) {
  const v1::Scene scene_proto = ReadSceneFile(f.scene);
  double resolution = 0;
  v1::PlanPathsRequest request = BuildRequest(f, scene_proto, &resolution);
  const Space space = SpaceFromProto(scene_proto.space(), "scene.space");
  RemoteClient client(remote);
  v1::Scene uploaded;
  request.set_session(OpenSceneFile(client, f.scene, remote, &uploaded));
  PrintHeader();
  // Progress: a bar on a terminal, a line per path otherwise (stderr), as for a merge.
  ProgressPrinter printer(!f.quiet);
  const ProgressCallback report = printer.callback();
  const auto started = std::chrono::steady_clock::now();
  const auto progress = [&](int64_t done) {
    if (!report) return;
    report(Progress{.phase = "plan",
                    .done = done,
                    .total = request.count(),
                    .elapsed_ms = std::chrono::duration<double, std::milli>(
                                      std::chrono::steady_clock::now() - started)
                                      .count()});
  };
  progress(0);
  std::vector<PlanAttempt> attempts(request.count());
  for (int i = 0; i < request.count(); ++i) attempts[i].index = i;
  std::vector<InputPath> paths;
  request.set_report_failures(true);
  client.Plan(request, [&](const v1::PlanPathsResponse& event) {
    if (event.has_failure()) {
      // The server's word on a run that found nothing, as a local run prints OMPL's.
      std::fprintf(stderr, "run %d: %s\n", event.index(), event.failure().message().c_str());
      if (event.index() >= 0 && event.index() < request.count()) {
        attempts[event.index()].elapsed_ms = event.elapsed_ms();
      }
      return;
    }
    v1::PathSet one;
    *one.add_paths() = event.path();
    paths.push_back(PathsFromProto(one).front());
    if (event.index() >= 0 && event.index() < request.count()) {
      PlanAttempt& a = attempts[event.index()];
      a.found = true;
      a.elapsed_ms = event.elapsed_ms();
      a.waypoints = event.path().waypoints_size();
      a.length = PathLength(space, paths.back());
    }
    progress(static_cast<int64_t>(paths.size()));
  });
  printer.Finish();
  const double straight =
      space.Distance(ConfigFromProto(scene_proto.start()), ConfigFromProto(scene_proto.goal()));
  return PrintPlan(f, request, space, straight, attempts, paths);
}

}  // namespace

Subcommand AddPlanCommand(CLI::App& parent) {
  auto flags = std::make_shared<PlanFlags>();
  PlanFlags& f = *flags;
  CLI::App* app = parent.add_subcommand(
      "plan",
      "Plan input paths for the scene's start and goal with an OMPL planner; every path "
      "is checked with the scene's local planner. Exit 1 if fewer than --count were "
      "found in time (those found are still written).");
  app->add_option("--scene", f.scene, "Scene JSON (hgraph.v1.Scene) with start and goal")
      ->required();
  app->add_option(
      "--out", f.out,
      "Write the paths here (.json: PathSet; .path: OMPL's PathGeometric printout; otherwise "
      "OMPL text)");
  app->add_option("--planner", f.planner,
                  "prm (no cycles, as the paper), prm-cycles, prmstar, rrt, rrtconnect, lazyprm; "
                  "the asymptotically optimal rrtstar, informed-rrtstar, bitstar, aitstar (each "
                  "spends its whole --time and returns its best path)")
      ->capture_default_str();
  app->add_option("--count", f.count, "Number of paths (one planner run each)")
      ->capture_default_str();
  app->add_option("--time", f.time_s, "Time budget per path, seconds")->capture_default_str();
  app->add_option("--seed", f.seed, "Seed; path i uses a seed derived from (seed, i)")
      ->capture_default_str();
  app->add_flag("--simplify", f.simplify, "Shortcut each path with OMPL's PathSimplifier");
  f.fields.Add<double>(
      app, "--resolution",
      "Collision-check resolution, fraction of the space's extent (default: the scene's)",
      "resolution", [](v1::PlanPathsRequest& r, const double& v) { r.set_resolution(v); });
  // The engine's fields that the other flags fill (core/plan names them as PlanRequest does).
  f.fields.Name("planner", "--planner");
  f.fields.Name("count", "--count");
  f.fields.Name("time_s", "--time");
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
