// `hgraph render`: an SVG picture of a scene, input paths and (optionally) a merge result.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <string>

#include "client/cli/cli_common.h"
#include "client/cli/command.h"
#include "client/cli/remote.h"
#include "core/adapter/json_io.h"
#include "core/adapter/merge_proto.h"
#include "core/adapter/path_io.h"
#include "core/adapter/scene_proto.h"
#include "core/render/svg_render.h"
#include "hgraph/v1/merge.pb.h"

namespace hgraph::cli {
namespace {

struct RenderFlags {
  std::string scene;
  std::string paths;
  std::string result;
  std::string svg;
  std::string plane = "xy";
  int footprints = 12;
  int width = 900;
};

int RunRender(const RenderFlags& f, PathChecker checker) {
  const Plane plane = ParsePlane(f.plane, "--plane");
  v1::Scene scene_proto = ReadSceneFile(f.scene);
  const std::shared_ptr<const Scene> scene = SceneFromProto(
      scene_proto, std::filesystem::path(f.scene).parent_path().string(), BlobResolver());

  RenderRequest request{.plane = plane, .width_px = f.width, .footprints = f.footprints};
  if (!f.paths.empty()) {
    for (InputPath& path : LoadPathsFile(f.paths, scene->space)) {
      request.inputs.push_back(RenderPath{.path = std::move(path)});
    }
  }
  std::vector<bool> reported(request.inputs.size(), false);
  if (!f.result.empty()) {
    v1::MergeResult result;
    ReadJsonFile(f.result, &result);
    v1::PathSet merged;
    *merged.add_paths() = result.path();
    RenderPath out{.path = PathsFromProto(merged).front(),
                   .quality = QualityFromProto(result.quality())};
    out.path.name = "merged";
    request.merged = std::move(out);
    // Reports follow the order of the merge's inputs; match by name so that a paths file in
    // another order (or a subset of it) still gets the right numbers.
    std::map<std::string, const v1::InputReport*> reports;
    for (const v1::InputReport& report : result.inputs()) reports[report.name()] = &report;
    for (size_t i = 0; i < request.inputs.size(); ++i) {
      RenderPath& input = request.inputs[i];
      const auto it = reports.find(input.path.name);
      if (it == reports.end()) continue;
      reported[i] = true;
      if (it->second->valid()) {
        input.quality = QualityFromProto(it->second->quality());
      } else {
        input.path.name += " (invalid)";
      }
    }
  }
  if (request.inputs.empty() && !request.merged) {
    throw InputError("--paths", "nothing to draw: give --paths, --result or both");
  }

  // Inputs the result does not cover get their length and clearance from the check a merge
  // runs on its inputs: here, or on the server with --server.
  std::vector<InputPath> unreported;
  std::vector<size_t> where;
  for (size_t i = 0; i < request.inputs.size(); ++i) {
    if (reported[i]) continue;
    unreported.push_back(request.inputs[i].path);
    where.push_back(i);
  }
  if (!unreported.empty()) {
    if (!checker) checker = LocalPathChecker(std::move(scene_proto), f.scene, scene);
    const CheckRun run = checker(unreported, CheckSettings{});
    for (size_t j = 0; j < where.size(); ++j) {
      RenderPath& input = request.inputs[where[j]];
      const InputReport& report = run.result.paths.at(j);
      if (report.valid) {
        input.quality = report.quality;
      } else {
        input.path.name += " (invalid)";
      }
    }
  }
  WriteTextFile(f.svg, RenderSvg(*scene, request));
  std::printf("wrote %s (%zu input paths%s, %s plane)\n", f.svg.c_str(), request.inputs.size(),
              request.merged ? " and the merged path" : "", PlaneName(plane));
  return kExitOk;
}

}  // namespace

Subcommand AddRenderCommand(CLI::App& parent) {
  auto flags = std::make_shared<RenderFlags>();
  RenderFlags& f = *flags;
  CLI::App* app = parent.add_subcommand(
      "render", "Draw a scene, input paths and a merged path as an SVG picture.");
  app->add_option("--scene", f.scene, "Scene JSON (hgraph.v1.Scene) or OMPL.app problem (.cfg)")
      ->required();
  app->add_option("--paths", f.paths,
                  "Input paths: PathSet JSON or OMPL text (drawn thin and grey; the legend's "
                  "length and clearance come from --result, else from checking them as a merge "
                  "checks its inputs, through the server with --server)");
  app->add_option("--result", f.result,
                  "MergeResult JSON written by `hgraph merge --out`: the merged path (bold) and "
                  "every path's length and clearance for the legend");
  app->add_option("--svg", f.svg, "Write the picture here")->required();
  app->add_option("--plane", f.plane, "Projection plane of 3D scenes: xy (top-down), xz, yz")
      ->capture_default_str();
  app->add_option("--footprints", f.footprints,
                  "Robot drawings along the merged path, for robots that rotate")
      ->capture_default_str();
  app->add_option("--width", f.width, "Picture width in pixels")->capture_default_str();
  return PathCheckingSubcommand(
      app, [flags](const PathChecker& checker) { return RunRender(*flags, checker); },
      std::shared_ptr<const std::string>(flags, &flags->scene));
}

}  // namespace hgraph::cli
