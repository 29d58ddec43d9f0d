// `hgraph render`: an SVG picture of a scene, input paths and (optionally) a merge result.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <string>

#include "client/cli/command.h"
#include "core/adapter/json_io.h"
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

// A result file carries every path's quality; the proto has no "has clearance" flag because a
// merge reports clearance for every valid path, so only invalid inputs are left without one.
PathQuality QualityFromProto(const v1::PathQuality& proto) {
  return PathQuality{.length = proto.length(),
                     .min_clearance = proto.min_clearance(),
                     .avg_clearance = proto.avg_clearance(),
                     .inverse_clearance = proto.inverse_clearance(),
                     .k = proto.k(),
                     .has_clearance = true};
}

int RunRender(const RenderFlags& f) {
  const Plane plane = ParsePlane(f.plane, "--plane");
  const v1::Scene scene_proto = ReadSceneFile(f.scene);
  const std::shared_ptr<const Scene> scene = SceneFromProto(
      scene_proto, std::filesystem::path(f.scene).parent_path().string(), BlobResolver());

  RenderRequest request{.plane = plane, .width_px = f.width, .footprints = f.footprints};
  if (!f.paths.empty()) {
    for (InputPath& path : LoadPathsFile(f.paths, scene->space)) {
      request.inputs.push_back(RenderPath{.path = std::move(path)});
    }
  }
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
    for (RenderPath& input : request.inputs) {
      const auto it = reports.find(input.path.name);
      if (it == reports.end()) continue;
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
                  "Input paths: PathSet JSON or OMPL text (drawn thin and grey)");
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
  return Subcommand{.app = app, .run = [flags] { return RunRender(*flags); }};
}

}  // namespace hgraph::cli
