// `hgraph plan`: input paths for a scene from OMPL's planners, each checked with the scene's
// local planner, written as a PathSet.
#include <cstdio>
#include <map>
#include <string>

#include "client/cli/cli_common.h"
#include "client/cli/command.h"
#include "core/adapter/path_io.h"
#include "core/adapter/scene_proto.h"
#include "core/plan/plan.h"

namespace hgraph::cli {
namespace {

struct PlanFlags {
  std::string scene;
  std::string out;
  std::string planner = "prm";
  int count = 1;
  double time_s = 1.0;
  uint64_t seed = 1;
  bool simplify = false;
  double resolution = 0;
  CLI::Option* resolution_opt = nullptr;
};

const std::map<std::string, std::string>& FlagNames() {
  static const std::map<std::string, std::string> names = {
      {"planner", "--planner"},
      {"count", "--count"},
      {"time_s", "--time"},
      {"start", "--scene"},
      {"goal", "--scene"},
      {"resolution", "--resolution"},
      {"scene.resolution", "--scene"},
  };
  return names;
}

int RunPlan(const PlanFlags& f) {
  v1::Scene scene_proto = ReadSceneFile(f.scene);
  PlanRequest request;
  double resolution = 0;
  try {
    request.planner = ParsePlannerType(f.planner, "planner");
    resolution = f.resolution_opt->count() > 0 ? f.resolution : SceneResolution(scene_proto);
  } catch (const Error& e) {
    RethrowWithFlag(e, FlagNames());
  }
  const LoadedScene loaded = LoadScene(std::move(scene_proto), f.scene, resolution);
  if (!loaded.scene->start || !loaded.scene->goal) {
    throw InputError(f.scene, "the scene has no start and goal to plan between");
  }
  const Space& space = loaded.scene->space;
  request.start = *loaded.scene->start;
  request.goal = *loaded.scene->goal;
  request.count = f.count;
  request.time_s = f.time_s;
  request.seed = f.seed;
  request.simplify = f.simplify;
  request.resolution = resolution;
  const double straight = space.Distance(request.start, request.goal);
  std::printf("%-16s %-36s %10s %9s %12s %9s\n", "path", "status", "time (ms)", "waypoints",
              "length", "/ direct");
  request.on_path = [](int, const InputPath&, double) { std::fflush(stdout); };

  PlanResult result;
  try {
    result = PlanPaths(*loaded.planner, request);
  } catch (const Error& e) {
    RethrowWithFlag(e, FlagNames());
  }
  int found = 0;
  std::string missing;
  for (const PlanAttempt& a : result.attempts) {
    const std::string name =
        std::string(PlannerTypeName(request.planner)) + "-" + std::to_string(a.index);
    if (a.found) {
      ++found;
      std::printf("%-16s %-36.36s %10.1f %9d %12s %9s\n", name.c_str(), a.status.c_str(),
                  a.elapsed_ms, a.waypoints, Cell(a.length, 12).c_str(),
                  Cell(straight > 0 ? a.length / straight : 0, 9, 3).c_str());
    } else {
      std::printf("%-16s %-36.36s %10.1f %9s %12s %9s\n", name.c_str(), a.status.c_str(),
                  a.elapsed_ms, "-", "-", "-");
      missing += (missing.empty() ? "" : ", ") + std::to_string(a.index);
    }
  }
  // Nothing found, nothing written: a stale file from an earlier run would read as success.
  const bool write = !f.out.empty() && found > 0;
  if (write) WritePathsFile(f.out, result.paths);
  std::printf("found %d of %d paths with %s in %g s each (seed %llu)%s%s\n", found, f.count,
              PlannerTypeName(request.planner), f.time_s, static_cast<unsigned long long>(f.seed),
              write ? "; wrote " : "", write ? f.out.c_str() : "");
  if (found < f.count) {
    std::fprintf(stderr, "error: %s found no path within %g s in %d of %d runs (index %s); %s\n",
                 PlannerTypeName(request.planner), f.time_s, f.count - found, f.count,
                 missing.c_str(),
                 found > 0 ? "the paths found were written" : "no path was written");
    return kExitCheckFailed;
  }
  return kExitOk;
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
  app->add_option("--out", f.out, "Write the paths here (.json: PathSet; otherwise OMPL text)");
  app->add_option("--planner", f.planner,
                  "prm (no cycles, as the paper), prm-cycles, prmstar, rrt, rrtconnect, lazyprm")
      ->capture_default_str();
  app->add_option("--count", f.count, "Number of paths (one planner run each)")
      ->capture_default_str();
  app->add_option("--time", f.time_s, "Time budget per path, seconds")->capture_default_str();
  app->add_option("--seed", f.seed, "Seed; path i uses a seed derived from (seed, i)")
      ->capture_default_str();
  app->add_flag("--simplify", f.simplify, "Shortcut each path with OMPL's PathSimplifier");
  f.resolution_opt = app->add_option(
      "--resolution", f.resolution,
      "Collision-check resolution, fraction of the space's extent (default: the scene's)");
  return Subcommand{.app = app, .run = [flags] { return RunPlan(*flags); }};
}

}  // namespace hgraph::cli
