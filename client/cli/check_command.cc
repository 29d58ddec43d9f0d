// `hgraph check`: checks every edge of every path exactly as a merge checks its inputs (the
// certified clearance check of core/merge/path_check.h), or with the plain sampled check.
#include <memory>
#include <string>

#include "client/cli/cli_common.h"
#include "client/cli/command.h"
#include "client/cli/remote.h"
#include "client/cli/request_flags.h"
#include "core/adapter/merge_proto.h"
#include "core/adapter/path_io.h"
#include "core/adapter/scene_proto.h"

namespace hgraph::cli {
namespace {

struct CheckFlags {
  std::string scene;
  std::string paths;
  bool sampled = false;
  // --resolution, read as a merge reads options.resolution.
  RequestFlags<v1::MergeOptions> options;
};

int RunCheck(const CheckFlags& f, PathChecker checker) {
  v1::Scene scene_proto = ReadSceneFile(f.scene);
  // The same rule and messages as a merge: the flag, else the scene's, else the default.
  v1::MergeOptions options;
  f.options.Apply(options);
  CheckSettings settings{.mode = f.sampled ? CheckMode::kSampled : CheckMode::kCertified};
  try {
    const double resolution = ResolutionFromProto(options, scene_proto);
    if (options.has_resolution()) settings.resolution = resolution;
  } catch (const Error& e) {
    f.options.Rethrow(e);
  }
  const Space space = SpaceFromProto(scene_proto.space(), "scene.space");
  const std::vector<InputPath> paths = LoadPathsFile(f.paths, space);
  if (paths.empty()) throw InputError("paths", "no paths in '" + f.paths + "'");
  if (!checker) checker = LocalPathChecker(std::move(scene_proto), f.scene);
  return PrintCheck(checker(paths, settings), settings.mode);
}

}  // namespace

Subcommand AddCheckCommand(CLI::App& parent) {
  auto flags = std::make_shared<CheckFlags>();
  CheckFlags& f = *flags;
  CLI::App* app = parent.add_subcommand(
      "check",
      "Check every edge of every path as a merge checks its inputs: each stretch between two "
      "samples proven free by the clearances at its ends, or refined (exit 1 if a path is "
      "invalid). Prints each path's length and minimum clearance.");
  app->add_option("--scene", f.scene, "Scene JSON (hgraph.v1.Scene) or OMPL.app problem (.cfg)")
      ->required();
  app->add_option("--paths", f.paths, "Paths: PathSet JSON or OMPL text")->required();
  f.options.Add<double>(
      app, "--resolution",
      "Local-planner resolution, fraction of the space's extent (default: the scene's, or 0.01)",
      "options.resolution", [](v1::MergeOptions& o, const double& v) { o.set_resolution(v); });
  app->add_flag("--sampled", f.sampled,
                "Only the collision test at the resolution's samples (faster; may accept an edge "
                "that grazes an obstacle between two samples, which a merge rejects)");
  return PathCheckingSubcommand(
      app, [flags](const PathChecker& checker) { return RunCheck(*flags, checker); },
      std::shared_ptr<const std::string>(flags, &flags->scene));
}

}  // namespace hgraph::cli
