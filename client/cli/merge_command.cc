// `hgraph merge`: merge input paths, in process or through hgraph-server (--server), and write
// the MergeResult JSON. One request builder (BuildRequest) and one printout serve both runs.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <limits>
#include <map>
#include <mutex>
#include <optional>
#include <string>

#include "client/cli/cli_common.h"
#include "client/cli/command.h"
#include "client/cli/merge_picture.h"
#include "client/cli/remote.h"
#include "client/cli/request_flags.h"
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
  MeasureFlags measure;
  std::string evaluation = "lazy";
  std::string check = "certified";
  bool report_inputs = false;
  bool report_clearance = false;
  bool partial_shortcuts = false;
  bool best_so_far = false;
  bool quiet = false;
  // The options whose fields stay unset unless their flag is given (core defaults).
  RequestFlags<v1::MergeOptions> options;
};

// The proto fields the flags fill, so that errors name the flag as well.
std::map<std::string, std::string> FlagNames(const MergeFlags& f) {
  std::map<std::string, std::string> names = f.measure.fields.names();
  names.insert(f.options.names().begin(), f.options.names().end());
  return names;
}

// The request the service receives (without its session), validated here as the service
// validates it (core/adapter), so that a bad flag is reported the same way in both runs.
v1::MergePathsRequest BuildRequest(const MergeFlags& f, const v1::Scene& scene,
                                   const std::vector<InputPath>& paths, double* resolution) {
  v1::MergePathsRequest request;
  *request.mutable_paths() = PathsToProto(paths);
  try {
    *request.mutable_measure() = f.measure.ToProto();
    v1::MergeOptions* options = request.mutable_options();
    options->set_variant(VariantToProto(ParseVariant(f.variant, "--variant")));
    options->set_evaluation(ParseEvaluation(f.evaluation, "--evaluation") == Evaluation::kEager
                                ? v1::EVALUATION_EAGER
                                : v1::EVALUATION_LAZY);
    options->set_check_mode(CheckModeToProto(ParseCheckMode(f.check, "--check")));
    options->set_report_inputs(f.report_inputs);
    options->set_report_clearance(f.report_clearance);
    options->set_partial_shortcuts(f.partial_shortcuts);
    f.options.Apply(*options);
    MeasureFromProto(request.measure());
    MergeOptionsFromProto(*options);
    *resolution = ResolutionFromProto(*options, scene);
  } catch (const Error& e) {
    RethrowWithFlag(e, FlagNames(f));
  }
  return request;
}

// What a merge run returns, wherever it ran.
struct MergeRun {
  v1::MergeResult result;
  std::string hgraph;  // with --server: the stored H-Graph's name, for `hgraph requery`
  // With --server: whether the server kept the H-Graph, or why not.
  v1::Retention retention = v1::RETENTION_UNSPECIFIED;
  // False: the deadline passed (--best-so-far) and `result` holds the best path streamed before
  // it, with its objective and measure only.
  bool complete = true;
};

// Runs the request; `scene` is loaded on demand (in process: always, for the merge itself).
using MergeRunner =
    std::function<MergeRun(const v1::MergePathsRequest& request, const ProgressCallback& progress)>;

int RunMerge(const MergeFlags& f, const MergeRunner& run, std::optional<LoadedScene>* loaded,
             double resolution, const v1::Scene& scene_proto, const std::vector<InputPath>& paths,
             const v1::MergePathsRequest& request) {
  ProgressPrinter printer(!f.quiet);
  // The events are kept for the result file (--quiet only silences stderr): the view charts the
  // post-optimization from them. In process the engine reports every round's checks, hundreds of
  // events a merge; they are kept about as the service streams them: every objective, the first
  // event of each phase, and the others at most one per kRecordInterval. The engine reports
  // from its worker threads.
  constexpr auto kRecordInterval = std::chrono::milliseconds(100);
  std::mutex records_mutex;
  google::protobuf::RepeatedPtrField<v1::ProgressRecord> records;
  std::chrono::steady_clock::time_point last_kept;
  const ProgressCallback print = printer.callback();
  const ProgressCallback record = [&](const Progress& p) {
    {
      std::lock_guard lock(records_mutex);
      const auto now = std::chrono::steady_clock::now();
      const bool keep = records.empty() || records[records.size() - 1].phase() != p.phase ||
                        !std::isnan(p.objective) || now - last_kept >= kRecordInterval;
      if (keep) {
        last_kept = now;
        v1::ProgressRecord* r = records.Add();
        r->set_phase(p.phase);
        r->set_done(p.done);
        r->set_total(p.total);
        r->set_collision_checks(p.collision_checks);
        r->set_distance_queries(p.distance_queries);
        r->set_elapsed_ms(p.elapsed_ms);
        if (!std::isnan(p.objective)) r->set_objective(p.objective);
      }
    }
    if (print) print(p);
  };
  MergeRun response = run(request, record);
  printer.Finish();
  {
    std::lock_guard lock(records_mutex);
    *response.result.mutable_progress() = std::move(records);
  }

  if (!f.out.empty()) WriteTextFile(f.out, ToJson(response.result));
  // --svg needs the scene, which this side holds: it is drawn here, from the result.
  const MergeResult result = MergeResultFromProto(response.result);
  if (!f.out_path.empty()) {
    WritePathsFile(f.out_path, {result.path}, SpaceFromProto(scene_proto.space(), "scene.space"));
  }
  if (!f.svg.empty()) {
    if (!*loaded) loaded->emplace(LoadScene(scene_proto, f.scene, resolution));
    WriteTextFile(f.svg, RenderSvg(*(*loaded)->scene, MergePicture(paths, result)));
  }
  if (!response.complete) {
    std::printf(
        "deadline passed during the post-optimization: the best path so far, %s, %zu "
        "waypoints, %s objective %.6g (no report)\n",
        CheckModeName(result.check_mode), result.path.waypoints.size(),
        MeasureTypeName(result.measure.type), result.objective);
    return kExitOk;
  }
  PrintMergeTable(result);
  if (!response.hgraph.empty()) std::printf("hgraph %s\n", response.hgraph.c_str());
  if (response.retention == v1::RETENTION_TOO_LARGE) {
    std::printf("hgraph not kept: larger than the server's --cache-bytes\n");
  } else if (response.retention == v1::RETENTION_SESSION_ENDED) {
    std::printf("hgraph not kept: the session ended while the merge ran\n");
  }
  return kExitOk;
}

int RunLocal(const MergeFlags& f) {
  if (f.best_so_far) {
    throw InputError("--best-so-far", "needs --server and --timeout (the call's deadline)");
  }
  const v1::Scene scene_proto = ReadSceneFile(f.scene);
  double resolution = 0;
  const Space space = SpaceFromProto(scene_proto.space(), "scene.space");
  const std::vector<InputPath> paths = LoadPathsFile(f.paths, space);
  const v1::MergePathsRequest request = BuildRequest(f, scene_proto, paths, &resolution);
  std::optional<LoadedScene> loaded;
  loaded.emplace(LoadScene(scene_proto, f.scene, resolution));
  const MergeRunner run = [&](const v1::MergePathsRequest& r, const ProgressCallback& progress) {
    MergeRequest merge{.paths = paths,
                       .measure = MeasureFromProto(r.measure()),
                       .options = MergeOptionsFromProto(r.options()),
                       .progress = progress};
    return MergeRun{.result = MergeResultToProto(Merge(*loaded->planner, merge))};
  };
  return RunMerge(f, run, &loaded, resolution, scene_proto, paths, request);
}

int RunRemote(const MergeFlags& f, const RemoteOptions& remote) {
  if (f.best_so_far && remote.timeout_s <= 0) {
    throw InputError("--best-so-far", "needs --timeout (the call's deadline)");
  }
  RemoteClient client(remote);
  const v1::Scene scene_proto = ReadSceneFile(f.scene);
  double resolution = 0;
  const Space space = SpaceFromProto(scene_proto.space(), "scene.space");
  const std::vector<InputPath> paths = LoadPathsFile(f.paths, space);
  v1::MergePathsRequest request = BuildRequest(f, scene_proto, paths, &resolution);
  if (f.best_so_far) request.mutable_options()->set_progress_paths(true);
  v1::Scene uploaded;
  request.set_session(OpenSceneFile(client, f.scene, remote, &uploaded));
  const MergeRunner run = [&](const v1::MergePathsRequest& r, const ProgressCallback& progress) {
    // The best path streamed so far (--best-so-far), as a result of its own.
    std::optional<v1::MergeResult> best;
    const auto on_progress = [&](const v1::MergeProgress& p) {
      if (p.has_path()) {
        if (!best) {
          best.emplace();
          *best->mutable_measure() = r.measure();
          const CheckMode mode = CheckModeFromProto(r.options().check_mode());
          best->set_check_mode(CheckModeToProto(mode));
          best->set_certified(mode == CheckMode::kCertified);
        }
        *best->mutable_path() = p.path();
        best->set_objective(p.objective());
        if (p.done() == 0) best->set_hgraph_objective(p.objective());
      }
      progress(Progress{.phase = p.phase(),
                        .done = p.done(),
                        .total = p.total(),
                        .collision_checks = p.collision_checks(),
                        .distance_queries = p.distance_queries(),
                        .elapsed_ms = p.elapsed_ms(),
                        .objective = p.has_objective() ? p.objective()
                                                       : std::numeric_limits<double>::quiet_NaN()});
    };
    try {
      v1::MergePathsResponse response = client.Merge(r, on_progress);
      return MergeRun{.result = std::move(*response.mutable_result()),
                      .hgraph = response.hgraph(),
                      .retention = response.retention()};
    } catch (const Error& e) {
      if (!f.best_so_far || !best || e.code() != ErrorCode::kDeadlineExceeded) throw;
      return MergeRun{.result = std::move(*best), .complete = false};
    }
  };
  std::optional<LoadedScene> loaded;
  return RunMerge(f, run, &loaded, resolution, scene_proto, paths, request);
}

}  // namespace

Subcommand AddMergeCommand(CLI::App& parent) {
  auto flags = std::make_shared<MergeFlags>();
  MergeFlags& f = *flags;
  CLI::App* app = parent.add_subcommand(
      "merge",
      "Merge input paths into one path of higher quality (in process, or with --server "
      "through hgraph-server).");
  app->add_option("--scene", f.scene, "Scene JSON (hgraph.v1.Scene) or OMPL.app problem (.cfg)")
      ->required();
  app->add_option("--paths", f.paths,
                  "Input paths: PathSet JSON, or OMPL text (one configuration per line, blank "
                  "lines between paths)")
      ->required();
  app->add_option("--out", f.out, "Write the MergeResult JSON here");
  app->add_option(
      "--out-path", f.out_path,
      "Write the merged path here (.json: PathSet; .path: OMPL's PathGeometric printout, as "
      "OMPL.app's .path files; otherwise OMPL text, one configuration per line)");
  app->add_option("--svg", f.svg, "Draw the scene, the inputs and the merged path here (SVG)");
  app->add_option("--variant", f.variant,
                  "H-Graph variant: all-pairs, neighborhood, knn, edit-distance, "
                  "edit-distance-neighborhood")
      ->capture_default_str();
  using Options = v1::MergeOptions;
  f.options.Add<double>(app, "--radius",
                        "Neighbourhood threshold D (default: 2 x mean input edge length)",
                        "options.radius", [](Options& o, const double& v) { o.set_radius(v); });
  f.options.Add<int>(app, "--phi", "Neighbours per node for knn (default 5)", "options.phi",
                     [](Options& o, const int& v) { o.set_phi(v); });
  f.options.Add<double>(app, "--gap-init",
                        "Alignment gap opening penalty (default: 2 x gap-extend)",
                        "options.gap_init", [](Options& o, const double& v) { o.set_gap_init(v); });
  f.options.Add<double>(
      app, "--gap-extend", "Alignment gap extension penalty (default: mean input edge length)",
      "options.gap_extend", [](Options& o, const double& v) { o.set_gap_extend(v); });
  f.measure.Add(app);
  f.options.Add<double>(
      app, "--resolution",
      "Local-planner resolution, fraction of the space's extent (default: the scene's, or 0.01)",
      "options.resolution", [](Options& o, const double& v) { o.set_resolution(v); });
  f.options.Add<double>(app, "--endpoint-tolerance",
                        "Largest distance between inputs' start (goal) waypoints (default 1e-6)",
                        "options.endpoint_tolerance",
                        [](Options& o, const double& v) { o.set_endpoint_tolerance(v); });
  f.options.Add<double>(
      app, "--max-node-spacing",
      "Subdivide input edges longer than this in the H-Graph, so bridges can leave an input "
      "mid-edge (configuration distance; default 0 = waypoints only)",
      "options.max_node_spacing", [](Options& o, const double& v) { o.set_max_node_spacing(v); });
  app->add_option("--evaluation", f.evaluation,
                  "lazy: check only the edges of the paths the search would take; eager: check "
                  "every candidate first")
      ->capture_default_str();
  app->add_option("--check", f.check,
                  "certified: every motion the merged path takes proven free between its "
                  "samples; sampled: checked at the resolution's samples only, as OMPL's "
                  "DiscreteMotionValidator (cheaper, may miss a collision between two samples; "
                  "the result says certified false)")
      ->capture_default_str();
  f.options.Add<double>(
      app, "--optimize-ms",
      "Budget of the post-optimization (certified shortcuts re-hybridized, length and "
      "safe-length), ms; 0 = off (default: automatic, until a round gains < 0.1%, at most 100 "
      "rounds: the same answer on any machine); a budget given is spent, on --restarts once the "
      "rounds stop gaining",
      "options.optimize_ms", [](Options& o, const double& v) { o.set_optimize_ms(v); });
  f.options.Add<int>(
      app, "--restarts",
      "Restarts of the post-optimization from the input paths once its rounds stop gaining, "
      "each about one post-optimization (length, safe-length; default: none, or as many as an "
      "explicit --optimize-ms allows)",
      "options.optimize_restarts", [](Options& o, const int& v) { o.set_optimize_restarts(v); });
  app->add_flag("--partial-shortcuts", f.partial_shortcuts,
                "A quarter of the post-optimization's shortcuts move one part (a translation or "
                "a rotation) alone: ~1% shorter paths for ~18% more checks");
  app->add_flag("--best-so-far", f.best_so_far,
                "With --server and --timeout: if the deadline passes during the "
                "post-optimization, write the best path streamed so far (certified; --out then "
                "holds its path and objective only) and exit 0");
  app->add_flag("--report-inputs", f.report_inputs,
                "Check every input edge with its clearance, so every input is fully reported "
                "(always so with --evaluation eager)");
  app->add_flag("--report-clearance", f.report_clearance,
                "Profile the merged path's clearance for the report under length (the clearance "
                "measures always do); without it a length merge reports the certified path's "
                "length only");
  f.options
      .Add<int>(app, "--threads", "Worker threads (0 = all cores)", "options.threads",
                [](Options& o, const int& v) { o.set_threads(v); })
      ->capture_default_str();
  return Subcommand{
      .app = app,
      .run = [flags] { return RunLocal(*flags); },
      .run_remote = [flags](const RemoteOptions& remote) { return RunRemote(*flags, remote); },
      .quiet = &f.quiet};
}

}  // namespace hgraph::cli
