// `hgraph view`: the 3D view of a scene, input paths and a merge result, as one HTML file that
// opens from file:// (core/render/view_render.h).
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include "client/cli/cli_common.h"
#include "client/cli/command.h"
#include "client/cli/merge_picture.h"
#include "client/cli/remote.h"
#include "core/adapter/json_io.h"
#include "core/adapter/merge_proto.h"
#include "core/adapter/scene_proto.h"
#include "core/common/error.h"
#include "core/render/view_render.h"

namespace hgraph::cli {
namespace {

struct ViewFlags {
  std::string scene;
  std::string paths;
  std::string result;
  std::string out;
  std::string title;
  int64_t max_mesh_triangles = 1'000'000;
  int frames = 400;
};

std::string Short(double v) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g", v);
  return text;
}

std::string MeasureLabel(const v1::Measure& proto) {
  const MeasureSpec spec = MeasureFromProto(proto);
  std::string label = MeasureTypeName(spec.type);
  if (spec.type == MeasureType::kInverseClearance) label += " (k = " + Short(spec.k) + ")";
  if (spec.type == MeasureType::kSafeLength) label += " (safety " + Short(spec.safety) + ")";
  return label;
}

int RunView(const ViewFlags& f, const PathChecker& checker) {
  v1::Scene scene_proto = ReadSceneFile(f.scene);
  const std::shared_ptr<const Scene> scene = SceneFromProto(
      scene_proto, std::filesystem::path(f.scene).parent_path().string(), BlobResolver());
  PicturePaths paths =
      LoadPicturePaths(f.scene, std::move(scene_proto), scene, f.paths, f.result, checker);

  ViewRequest request{.inputs = std::move(paths.inputs),
                      .merged = std::move(paths.merged),
                      .title = f.title,
                      .max_mesh_triangles = f.max_mesh_triangles,
                      .frames = f.frames};
  if (paths.result) {
    const v1::MergeResult& result = *paths.result;
    // source_fraction came later than the other two: a result without it has fractions 0.
    for (int i = 0; i < result.source_path_size() && i < result.source_index_size(); ++i) {
      request.sources.push_back(
          WaypointSource{.path = result.source_path(i),
                         .index = result.source_index(i),
                         .t = i < result.source_fraction_size() ? result.source_fraction(i) : 0.0});
    }
    for (const v1::InputReport& input : result.inputs()) {
      request.input_waypoints.push_back(input.waypoints());
    }
    request.measure = MeasureLabel(result.measure());
    request.objective = result.objective();
    // A --best-so-far result reports no inputs (and best_input reads 0).
    if (result.best_input() >= 0 && result.best_input() < result.inputs_size()) {
      request.best_input_objective = result.best_input_objective();
    }
    for (const v1::ProgressRecord& p : result.progress()) {
      if (p.phase() != "optimize" || !p.has_objective()) continue;
      request.rounds.push_back(OptimizeRound{
          .round = p.done(), .elapsed_ms = p.elapsed_ms(), .objective = p.objective()});
    }
  }
  std::string html;
  try {
    html = RenderViewHtml(*scene, request);
  } catch (const InputError& e) {
    const std::string what = e.what();
    const std::string message = e.field().empty() ? what : what.substr(e.field().size() + 2);
    // The scene's fields are named after the scene file, the request's after their flags.
    if (e.field().rfind("scene.", 0) == 0) {
      throw InputError(f.scene + ": " + e.field().substr(6), message + " (--max-mesh-triangles)");
    }
    if (e.field() == "request.frames") throw InputError("--frames", message);
    if (e.field() == "request.max_mesh_triangles") {
      throw InputError("--max-mesh-triangles", message);
    }
    throw;
  }
  WriteTextFile(f.out, html);
  std::printf("wrote %s (%zu input paths%s, %.0f KiB; open it in a browser)\n", f.out.c_str(),
              request.inputs.size(), request.merged ? " and the merged path" : "",
              std::ceil(static_cast<double>(html.size()) / 1024));
  return kExitOk;
}

}  // namespace

Subcommand AddViewCommand(CLI::App& parent) {
  auto flags = std::make_shared<ViewFlags>();
  ViewFlags& f = *flags;
  CLI::App* app = parent.add_subcommand(
      "view",
      "Write an interactive 3D view of a scene, input paths and a merged path: one HTML file "
      "that opens from file:// with no server or network.");
  app->add_option("--scene", f.scene, "Scene JSON (hgraph.v1.Scene) or OMPL.app problem (.cfg)")
      ->required();
  app->add_option("--paths", f.paths,
                  "Input paths: PathSet JSON or OMPL text, each drawn in its own colour (length "
                  "and clearance from --result, else from checking them as a merge checks its "
                  "inputs, through the server with --server)");
  app->add_option("--result", f.result,
                  "MergeResult JSON written by `hgraph merge --out`: the merged path, coloured "
                  "by the input (or shortcut) each stretch came from, every path's length and "
                  "clearance, and the post-optimization's progress");
  app->add_option("--out", f.out, "Write the HTML file here")->required();
  app->add_option("--title", f.title, "Title of the legend (default: the scene's name)");
  app->add_option("--max-mesh-triangles", f.max_mesh_triangles,
                  "Refuse a mesh with more triangles than this (the file holds every triangle)")
      ->capture_default_str();
  app->add_option("--frames", f.frames, "Robot poses sampled along each path for the animation")
      ->capture_default_str();
  return PathCheckingSubcommand(
      app, [flags](const PathChecker& checker) { return RunView(*flags, checker); },
      std::shared_ptr<const std::string>(flags, &flags->scene));
}

}  // namespace hgraph::cli
