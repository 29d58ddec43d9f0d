// `hgraph render`: an SVG picture of a scene, input paths and (optionally) a merge result.
#include <cstdio>
#include <filesystem>
#include <string>

#include "client/cli/cli_common.h"
#include "client/cli/command.h"
#include "client/cli/merge_picture.h"
#include "client/cli/remote.h"
#include "core/adapter/json_io.h"
#include "core/adapter/scene_proto.h"
#include "core/render/svg_render.h"

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

int RunRender(const RenderFlags& f, const PathChecker& checker) {
  const Plane plane = ParsePlane(f.plane, "--plane");
  v1::Scene scene_proto = ReadSceneFile(f.scene);
  const std::shared_ptr<const Scene> scene = SceneFromProto(
      scene_proto, std::filesystem::path(f.scene).parent_path().string(), BlobResolver());

  PicturePaths paths =
      LoadPicturePaths(f.scene, std::move(scene_proto), scene, f.paths, f.result, checker);
  RenderRequest request{.inputs = std::move(paths.inputs),
                        .merged = std::move(paths.merged),
                        .plane = plane,
                        .width_px = f.width,
                        .footprints = f.footprints};
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
