// `hgraph check`: runs the local planner on every edge of every input path.
#include <cstdio>
#include <string>

#include "client/cli/cli_common.h"
#include "client/cli/command.h"
#include "core/adapter/merge_proto.h"
#include "core/adapter/path_io.h"
#include "core/adapter/scene_proto.h"
#include "core/hgraph/hgraph.h"

namespace hgraph::cli {
namespace {

struct CheckFlags {
  std::string scene;
  std::string paths;
  double resolution = 0;
  CLI::Option* resolution_opt = nullptr;
};

std::string Describe(const InputPath& path, int index) {
  return "path '" + path.name + "' (index " + std::to_string(index) + ")";
}

// Why the motion is invalid at t: leaving the bounds reads differently from a collision.
std::string InvalidWhy(const Space& space, const Config& a, const Config& b, double t) {
  char at[32];
  std::snprintf(at, sizeof(at), "%.3g", t);
  const bool out = !space.InBounds(space.Interpolate(a, b, t));
  return std::string(out ? "leaves the space's bounds" : "is in collision") + " at t=" + at;
}

// Returns the first problem of the path, or an empty string if every edge is valid.
std::string CheckPath(const LocalPlanner& planner, const InputPath& path, int index) {
  const Space& space = planner.space();
  if (path.waypoints.size() == 1) {
    if (planner.IsValid(path.waypoints[0])) return "";
    const bool out = !space.InBounds(path.waypoints[0]);
    return Describe(path, index) + ": waypoint 0 " +
           (out ? "is outside the space's bounds" : "is in collision");
  }
  for (size_t j = 0; j + 1 < path.waypoints.size(); ++j) {
    const EdgeReport report = planner.CheckEdge(
        EdgeCheckRequest{.from = &path.waypoints[j], .to = &path.waypoints[j + 1]});
    if (report.state == EdgeState::kValid) continue;
    const double t = report.invalid_at >= 0 ? report.invalid_at : 0;
    return Describe(path, index) + ": edge " + std::to_string(j) + " -> " + std::to_string(j + 1) +
           " " + InvalidWhy(space, path.waypoints[j], path.waypoints[j + 1], t);
  }
  return "";
}

int RunCheck(const CheckFlags& f) {
  v1::Scene scene_proto = ReadSceneFile(f.scene);
  // The same rule and messages as a merge: the flag, else the scene's, else the default.
  v1::MergeOptions options;
  if (f.resolution_opt->count() > 0) options.set_resolution(f.resolution);
  double resolution = 0;
  try {
    resolution = ResolutionFromProto(options, scene_proto);
  } catch (const Error& e) {
    RethrowWithFlag(e, {{"options.resolution", "--resolution"}});
  }
  const LoadedScene loaded = LoadScene(std::move(scene_proto), f.scene, resolution);
  const Space& space = loaded.scene->space;
  std::vector<InputPath> paths = LoadPathsFile(f.paths, space);
  if (paths.empty()) throw InputError("paths", "no paths in '" + f.paths + "'");

  // Same validation as a merge, without its requirement of shared endpoints.
  for (size_t i = 0; i < paths.size(); ++i) {
    const std::string field = "paths[" + std::to_string(i) + "]";
    if (paths[i].waypoints.empty()) throw InputError(field + ".waypoints", "the path is empty");
    for (size_t j = 0; j < paths[i].waypoints.size(); ++j) {
      Config& q = paths[i].waypoints[j];
      space.Validate(q, field + ".waypoints[" + std::to_string(j) + "]");
      q = space.Normalize(q);
    }
  }

  int invalid = 0;
  for (size_t i = 0; i < paths.size(); ++i) {
    const std::string problem = CheckPath(*loaded.planner, paths[i], static_cast<int>(i));
    if (problem.empty()) {
      double length = 0;
      for (size_t j = 0; j + 1 < paths[i].waypoints.size(); ++j) {
        length += space.Distance(paths[i].waypoints[j], paths[i].waypoints[j + 1]);
      }
      std::printf("%s: valid, %zu waypoints, length %.6g\n",
                  Describe(paths[i], static_cast<int>(i)).c_str(), paths[i].waypoints.size(),
                  length);
    } else {
      ++invalid;
      std::printf("%s\n", problem.c_str());
    }
  }
  std::printf("%zu of %zu paths valid (resolution %g, %lld collision checks)\n",
              paths.size() - invalid, paths.size(), resolution,
              static_cast<long long>(loaded.planner->total_collision_checks()));
  return invalid == 0 ? kExitOk : kExitCheckFailed;
}

}  // namespace

Subcommand AddCheckCommand(CLI::App& parent) {
  auto flags = std::make_shared<CheckFlags>();
  CheckFlags& f = *flags;
  CLI::App* app = parent.add_subcommand(
      "check", "Check every edge of every path with the local planner (exit 1 if one is invalid).");
  app->add_option("--scene", f.scene, "Scene JSON (hgraph.v1.Scene)")->required();
  app->add_option("--paths", f.paths, "Paths: PathSet JSON or OMPL text")->required();
  f.resolution_opt = app->add_option(
      "--resolution", f.resolution,
      "Local-planner resolution, fraction of the space's extent (default: the scene's, or 0.01)");
  return Subcommand{.app = app, .run = [flags] { return RunCheck(*flags); }};
}

}  // namespace hgraph::cli
