// `hgraph merge`: merge input paths in process and write the MergeResult JSON.
#include <cstdio>
#include <map>
#include <string>

#include "client/cli/cli_common.h"
#include "client/cli/command.h"
#include "client/cli/shortcut_step.h"
#include "core/adapter/json_io.h"
#include "core/adapter/merge_proto.h"
#include "core/adapter/path_io.h"
#include "core/adapter/scene_proto.h"
#include "core/hgraph/bridge_candidates.h"
#include "core/measure/measure.h"
#include "core/merge/merge.h"
#include "core/render/svg_render.h"

namespace hgraph::cli {
namespace {

struct MergeFlags {
  std::string scene;
  std::string paths;
  std::string out;
  std::string out_path;
  std::string svg;
  std::string variant = "edit-distance";
  std::string measure = "length";
  double radius = 0;
  int phi = 0;
  double gap_init = 0;
  double gap_extend = 0;
  double k = 0;
  double safety = 0;
  double resolution = 0;
  double endpoint_tolerance = 0;
  double max_node_spacing = 0;
  std::string evaluation = "lazy";
  double optimize_ms = -1;
  bool report_inputs = false;
  int threads = 0;
  bool quiet = false;
  bool shortcut = false;
  uint64_t shortcut_seed = 1;
  // Set when the flag was given; unset flags leave the proto field unset (core defaults).
  CLI::Option* radius_opt = nullptr;
  CLI::Option* phi_opt = nullptr;
  CLI::Option* gap_init_opt = nullptr;
  CLI::Option* gap_extend_opt = nullptr;
  CLI::Option* k_opt = nullptr;
  CLI::Option* resolution_opt = nullptr;
  CLI::Option* endpoint_tolerance_opt = nullptr;
  CLI::Option* max_node_spacing_opt = nullptr;
  CLI::Option* optimize_ms_opt = nullptr;
};

// The proto fields each flag fills, so that errors name the flag as well.
const std::map<std::string, std::string>& FlagNames() {
  static const std::map<std::string, std::string> names = {
      {"measure.k", "--k"},
      {"measure.safety", "--safety"},
      {"options.radius", "--radius"},
      {"options.phi", "--phi"},
      {"options.gap_init", "--gap-init"},
      {"options.gap_extend", "--gap-extend"},
      {"options.resolution", "--resolution"},
      {"options.threads", "--threads"},
      {"options.endpoint_tolerance", "--endpoint-tolerance"},
      {"options.max_node_spacing", "--max-node-spacing"},
      {"options.optimize_ms", "--optimize-ms"},
  };
  return names;
}

// Builds the request messages the service would receive, so the CLI and the service share one
// validation path (core/adapter).
void BuildProtos(const MergeFlags& f, v1::Measure* measure, v1::MergeOptions* options) {
  *measure = MeasureToProto(MeasureSpec{.type = ParseMeasureType(f.measure, "--measure")});
  measure->clear_k();
  if (f.k_opt->count() > 0) measure->set_k(f.k);
  measure->set_safety(f.safety);
  options->set_variant(VariantToProto(ParseVariant(f.variant, "--variant")));
  if (f.radius_opt->count() > 0) options->set_radius(f.radius);
  if (f.phi_opt->count() > 0) options->set_phi(f.phi);
  if (f.gap_init_opt->count() > 0) options->set_gap_init(f.gap_init);
  if (f.gap_extend_opt->count() > 0) options->set_gap_extend(f.gap_extend);
  if (f.resolution_opt->count() > 0) options->set_resolution(f.resolution);
  if (f.endpoint_tolerance_opt->count() > 0) options->set_endpoint_tolerance(f.endpoint_tolerance);
  if (f.max_node_spacing_opt->count() > 0) options->set_max_node_spacing(f.max_node_spacing);
  options->set_evaluation(ParseEvaluation(f.evaluation, "--evaluation") == Evaluation::kEager
                              ? v1::EVALUATION_EAGER
                              : v1::EVALUATION_LAZY);
  options->set_report_inputs(f.report_inputs);
  if (f.optimize_ms_opt->count() > 0) options->set_optimize_ms(f.optimize_ms);
  options->set_threads(f.threads);
}

int RunMerge(const MergeFlags& f) {
  v1::Measure measure_proto;
  v1::MergeOptions options_proto;
  MergeRequest request;
  double resolution = 0;
  v1::Scene scene_proto = ReadSceneFile(f.scene);
  try {
    BuildProtos(f, &measure_proto, &options_proto);
    request.measure = MeasureFromProto(measure_proto);
    request.options = MergeOptionsFromProto(options_proto);
    resolution = ResolutionFromProto(options_proto, scene_proto);
  } catch (const Error& e) {
    RethrowWithFlag(e, FlagNames());
  }

  const LoadedScene loaded = LoadScene(std::move(scene_proto), f.scene, resolution);
  request.paths = LoadPathsFile(f.paths, loaded.scene->space);

  ProgressPrinter printer(!f.quiet);
  request.progress = printer.callback();
  const MergeResult result = Merge(*loaded.planner, request);
  printer.Finish();

  if (!f.out.empty()) WriteTextFile(f.out, ToJson(MergeResultToProto(result)));
  ShortcutStep shortcut;
  if (f.shortcut) {
    shortcut =
        ShortcutMergedPath(*loaded.planner, result, request.measure, resolution, f.shortcut_seed);
  }
  if (!f.out_path.empty()) WritePathsFile(f.out_path, {f.shortcut ? shortcut.path : result.path});
  if (!f.svg.empty()) {
    WriteTextFile(f.svg, RenderSvg(*loaded.scene, MergePicture(request.paths, result,
                                                               f.shortcut ? &shortcut : nullptr)));
  }
  PrintMergeTable(result);
  if (f.shortcut) PrintShortcutRow(shortcut, result);
  return kExitOk;
}

}  // namespace

Subcommand AddMergeCommand(CLI::App& parent) {
  auto flags = std::make_shared<MergeFlags>();
  MergeFlags& f = *flags;
  CLI::App* app = parent.add_subcommand(
      "merge", "Merge input paths into one path of higher quality (in process).");
  app->add_option("--scene", f.scene, "Scene JSON (hgraph.v1.Scene)")->required();
  app->add_option("--paths", f.paths,
                  "Input paths: PathSet JSON, or OMPL text (one configuration per line, blank "
                  "lines between paths)")
      ->required();
  app->add_option("--out", f.out, "Write the MergeResult JSON here");
  app->add_option("--out-path", f.out_path,
                  "Write the merged path here (.json: PathSet; otherwise OMPL text)");
  app->add_option("--svg", f.svg, "Draw the scene, the inputs and the merged path here (SVG)");
  app->add_option("--variant", f.variant,
                  "H-Graph variant: all-pairs, neighborhood, knn, edit-distance, "
                  "edit-distance-neighborhood")
      ->capture_default_str();
  f.radius_opt = app->add_option("--radius", f.radius,
                                 "Neighbourhood threshold D (default: 2 x mean input edge length)");
  f.phi_opt = app->add_option("--phi", f.phi, "Neighbours per node for knn (default 5)");
  f.gap_init_opt = app->add_option("--gap-init", f.gap_init,
                                   "Alignment gap opening penalty (default: 2 x gap-extend)");
  f.gap_extend_opt = app->add_option("--gap-extend", f.gap_extend,
                                     "Alignment gap extension penalty (default: mean input edge "
                                     "length)");
  app->add_option("--measure", f.measure,
                  "Quality measure: length, inverse-clearance, bottleneck-clearance, safe-length")
      ->capture_default_str();
  f.k_opt = app->add_option("--k", f.k, "Inverse-clearance exponent (default 3)");
  app->add_option("--safety", f.safety, "Minimum clearance C for safe-length");
  f.resolution_opt = app->add_option(
      "--resolution", f.resolution,
      "Local-planner resolution, fraction of the space's extent (default: the scene's, or 0.01)");
  f.endpoint_tolerance_opt =
      app->add_option("--endpoint-tolerance", f.endpoint_tolerance,
                      "Largest distance between inputs' start (goal) waypoints (default 1e-6)");
  f.max_node_spacing_opt = app->add_option(
      "--max-node-spacing", f.max_node_spacing,
      "Subdivide input edges longer than this in the H-Graph, so bridges can leave an input "
      "mid-edge (configuration distance; default 0 = waypoints only)");
  app->add_option("--evaluation", f.evaluation,
                  "lazy: check only the edges of the paths the search would take; eager: check "
                  "every candidate first")
      ->capture_default_str();
  f.optimize_ms_opt = app->add_option(
      "--optimize-ms", f.optimize_ms,
      "Budget of the post-optimization (certified shortcuts re-hybridized, length and "
      "safe-length), ms; 0 = off (default: automatic, until a round gains < 0.1%, <= 2000 ms)");
  app->add_flag("--report-inputs", f.report_inputs,
                "Check every input edge with its clearance, so every input is fully reported "
                "(always so with --evaluation eager)");
  app->add_option("--threads", f.threads, "Worker threads (0 = all cores)")->capture_default_str();
  app->add_flag("-q,--quiet", f.quiet, "No progress on stderr");
  app->add_flag("--shortcut", f.shortcut,
                "Then shortcut the merged path with OMPL's PathSimplifier (hybridize-then-"
                "shortcut); --out-path and --svg get the shortcut path, --out keeps the merge's "
                "result. With --server the shortcutting runs here, on the local scene");
  app->add_option("--shortcut-seed", f.shortcut_seed, "Seed of the shortcutting")
      ->capture_default_str();
  return Subcommand{.app = app, .run = [flags] { return RunMerge(*flags); }};
}

}  // namespace hgraph::cli
