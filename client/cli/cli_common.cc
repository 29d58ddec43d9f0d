#include "client/cli/cli_common.h"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>

#include "core/adapter/merge_proto.h"
#include "core/adapter/scene_proto.h"
#include "core/hgraph/bridge_candidates.h"
#include "core/measure/measure.h"

namespace hgraph::cli {
namespace {

using Clock = std::chrono::steady_clock;

constexpr auto kTtyInterval = std::chrono::milliseconds(100);
constexpr auto kLogInterval = std::chrono::seconds(1);

std::string ProblemText(const Error& e) {
  const std::string what = e.what();
  const std::string prefix = e.field() + ": ";
  if (!e.field().empty() && what.starts_with(prefix)) return what.substr(prefix.size());
  return what;
}

}  // namespace

LoadedScene LoadScene(v1::Scene proto, const std::string& path, double resolution) {
  LoadedScene loaded;
  loaded.proto = std::move(proto);
  loaded.scene = SceneFromProto(loaded.proto, std::filesystem::path(path).parent_path().string(),
                                BlobResolver());
  loaded.resolution = resolution;
  loaded.world = std::make_shared<const CollisionWorld>(loaded.scene);
  loaded.planner =
      std::make_unique<LocalPlanner>(loaded.world, LocalPlannerOptions{.resolution = resolution});
  return loaded;
}

PathChecker LocalPathChecker(v1::Scene proto, const std::string& scene_file,
                             std::shared_ptr<const Scene> scene) {
  struct State {
    v1::Scene proto;
    std::string scene_file;
    std::shared_ptr<const Scene> scene;
    std::shared_ptr<const CollisionWorld> world;
    std::map<double, std::unique_ptr<LocalPlanner>> planners;  // by resolution
  };
  auto state = std::make_shared<State>(
      State{.proto = std::move(proto), .scene_file = scene_file, .scene = std::move(scene)});
  return [state](const std::vector<InputPath>& paths, const CheckSettings& settings) {
    const double resolution =
        settings.resolution ? *settings.resolution : SceneResolution(state->proto);
    if (state->scene == nullptr) {
      state->scene = SceneFromProto(state->proto,
                                    std::filesystem::path(state->scene_file).parent_path().string(),
                                    BlobResolver());
    }
    if (state->world == nullptr)
      state->world = std::make_shared<const CollisionWorld>(state->scene);
    std::unique_ptr<LocalPlanner>& planner = state->planners[resolution];
    if (planner == nullptr) {
      planner = std::make_unique<LocalPlanner>(state->world,
                                               LocalPlannerOptions{.resolution = resolution});
    }
    return CheckRun{
        .result = CheckPaths(
            *planner, PathCheckRequest{.paths = paths, .mode = settings.mode, .k = settings.k}),
        .resolution = resolution};
  };
}

int PrintCheck(const CheckRun& run, CheckMode mode) {
  size_t valid = 0;
  for (size_t i = 0; i < run.result.paths.size(); ++i) {
    const InputReport& r = run.result.paths[i];
    const std::string who = "path '" + r.name + "' (index " + std::to_string(i) + ")";
    if (!r.valid) {
      std::printf("%s: %s\n", who.c_str(), r.invalid_reason.c_str());
      continue;
    }
    ++valid;
    std::printf("%s: valid, %d waypoints, length %.6g", who.c_str(), r.waypoints, r.quality.length);
    if (r.quality.has_clearance) std::printf(", min clearance %.6g", r.quality.min_clearance);
    // Passed the collision test at every sample, but some stretch is too close to an obstacle
    // for the clearance certificate even at the finest refinement.
    if (mode == CheckMode::kCertified && !r.certified) std::printf(" (not certified everywhere)");
    std::printf("\n");
  }
  std::printf(
      "%zu of %zu paths valid (%s check, resolution %g, %lld collision checks, %lld distance "
      "queries)\n",
      valid, run.result.paths.size(), CheckModeName(mode), run.resolution,
      static_cast<long long>(run.result.collision_checks),
      static_cast<long long>(run.result.distance_queries));
  return valid == run.result.paths.size() ? kExitOk : kExitCheckFailed;
}

ProgressPrinter::ProgressPrinter(bool enabled)
    : enabled_(enabled), tty_(isatty(fileno(stderr)) != 0) {}

ProgressPrinter::~ProgressPrinter() { Finish(); }

ProgressCallback ProgressPrinter::callback() {
  if (!enabled_) return {};
  return [this](const Progress& progress) { Report(progress); };
}

void ProgressPrinter::Finish() {
  std::lock_guard lock(mutex_);
  if (line_open_) std::fputc('\n', stderr);
  line_open_ = false;
}

void ProgressPrinter::Report(const Progress& progress) {
  std::lock_guard lock(mutex_);
  const auto now = Clock::now();
  const bool new_phase = progress.phase != phase_;
  const bool last = progress.done == progress.total;
  // Each improvement of the post-optimization is printed; other events are throttled.
  const bool improvement = !std::isnan(progress.objective);
  if (!new_phase && !last && !improvement &&
      now - last_print_ < (tty_ ? kTtyInterval : kLogInterval)) {
    return;
  }
  // On a log, the end of a phase is implied by the next one starting.
  if (!tty_ && !new_phase && last) return;
  phase_ = progress.phase;
  last_print_ = now;
  char line[256];
  // Counts only where the phase has any (planning reports none).
  if (improvement) {
    // An improvement of the post-optimization: round, objective so far, time.
    std::snprintf(line, sizeof(line), "[%-9s] round %lld  objective %.6g  %.1f ms",
                  progress.phase.c_str(), static_cast<long long>(progress.done), progress.objective,
                  progress.elapsed_ms);
  } else if (progress.collision_checks > 0 || progress.distance_queries > 0) {
    std::snprintf(line, sizeof(line),
                  "[%-9s] %lld/%lld  collision checks %lld  distance queries %lld  %.1f s",
                  progress.phase.c_str(), static_cast<long long>(progress.done),
                  static_cast<long long>(progress.total),
                  static_cast<long long>(progress.collision_checks),
                  static_cast<long long>(progress.distance_queries), progress.elapsed_ms / 1000.0);
  } else {
    std::snprintf(line, sizeof(line), "[%-9s] %lld/%lld  %.1f s", progress.phase.c_str(),
                  static_cast<long long>(progress.done), static_cast<long long>(progress.total),
                  progress.elapsed_ms / 1000.0);
  }
  if (tty_) {
    if (new_phase && line_open_) std::fputc('\n', stderr);
    std::fprintf(stderr, "\r\033[K%s", line);
    line_open_ = true;
  } else {
    std::fprintf(stderr, "%s\n", line);
  }
  std::fflush(stderr);
}

void RethrowWithFlag(const Error& e, const std::map<std::string, std::string>& flags) {
  const auto it = flags.find(e.field());
  if (it == flags.end()) throw;
  throw Error(e.code(), e.field() + " (" + it->second + ")", ProblemText(e));
}

std::string Cell(double v, int width, int precision) {
  char text[64];
  if (std::isnan(v)) {
    std::snprintf(text, sizeof(text), "%*s", width, "-");
  } else if (std::isinf(v)) {
    std::snprintf(text, sizeof(text), "%*s", width, v > 0 ? "inf" : "-inf");
  } else {
    std::snprintf(text, sizeof(text), "%*.*f", width, precision, v);
  }
  return text;
}

namespace {

void PrintQualityRow(const std::string& name, int waypoints, bool valid, const PathQuality& q) {
  std::printf("%-20.20s %9d %5s %12s %10s %10s %14s\n", name.c_str(), waypoints,
              valid ? "yes" : "NO", Cell(q.length, 12).c_str(), Cell(q.min_clearance, 10).c_str(),
              Cell(q.avg_clearance, 10).c_str(), Cell(q.inverse_clearance, 14).c_str());
}
}  // namespace

void PrintMergeTable(const MergeResult& r) {
  std::printf("%-20s %9s %5s %12s %10s %10s %14s\n", "path", "waypoints", "valid", "length",
              "min clear", "avg clear", ("inv clear k=" + Cell(r.quality.k, 0, 3)).c_str());
  bool unchecked = false;
  for (const InputReport& input : r.inputs) {
    PathQuality q = input.quality;
    if (!input.checked) {
      // Only the length is known (lazy evaluation without --report-inputs).
      q.min_clearance = q.avg_clearance = q.inverse_clearance =
          std::numeric_limits<double>::quiet_NaN();
      unchecked = true;
    }
    PrintQualityRow(input.name + (input.checked ? "" : " *"), input.waypoints, input.valid, q);
  }
  PathQuality merged = r.quality;
  if (!merged.has_clearance) {
    // Certified, not profiled (a length merge without --report-clearance).
    merged.min_clearance = merged.avg_clearance = merged.inverse_clearance =
        std::numeric_limits<double>::quiet_NaN();
  }
  PrintQualityRow("merged", static_cast<int>(r.path.waypoints.size()), true, merged);
  for (const InputReport& input : r.inputs) {
    if (!input.valid) {
      std::printf("  %s: edge %d invalid: %s\n", input.name.c_str(), input.invalid_edge,
                  input.invalid_reason.c_str());
    }
  }
  if (unchecked) {
    std::printf(
        "  * not every edge checked (lazy evaluation): length only; --report-inputs "
        "checks them all\n");
  }
  if (r.check_mode == CheckMode::kSampled) {
    std::printf(
        "  merged: NOT certified: its motions were checked at their samples only (--check "
        "sampled), a collision between two samples may be missed\n");
  }
  if (!r.quality.has_clearance) {
    std::printf("  merged: %s, clearance not profiled (merge --report-clearance profiles it)\n",
                r.check_mode == CheckMode::kSampled ? "checked at its samples" : "certified");
  }
  std::printf("measure %s (%s variant): objective %s", MeasureTypeName(r.measure.type),
              VariantName(r.variant), Cell(r.objective, 0).c_str());
  if (r.stats.optimize_rounds > 0) {
    std::printf(" (H-Graph optimum %s, %lld shortcuts in %lld rounds, stopped: %s)",
                Cell(r.hgraph_objective, 0).c_str(), static_cast<long long>(r.stats.shortcuts),
                static_cast<long long>(r.stats.optimize_rounds),
                OptimizeStopName(r.stats.optimize_stop));
  }
  if (r.best_input >= 0 && r.best_input < static_cast<int>(r.inputs.size())) {
    std::printf(", best input '%s' %s", r.inputs[r.best_input].name.c_str(),
                Cell(r.best_input_objective, 0).c_str());
  }
  std::printf("\n");
  const MergeStats& s = r.stats;
  std::printf(
      "stats: %lld nodes, %lld input edges (%lld invalid), %lld candidates, %lld edges checked, "
      "%lld valid, %lld reused, %lld collision checks, %lld distance queries, %lld search "
      "rounds, %d threads\n",
      static_cast<long long>(s.nodes), static_cast<long long>(s.input_edges),
      static_cast<long long>(s.input_edges_invalid), static_cast<long long>(s.candidate_edges),
      static_cast<long long>(s.edges_checked), static_cast<long long>(s.edges_valid),
      static_cast<long long>(s.edges_reused), static_cast<long long>(s.collision_checks),
      static_cast<long long>(s.distance_queries), static_cast<long long>(s.search_rounds),
      s.threads);
  const MergeTiming& t = r.timing;
  std::printf(
      "timing (ms): validate %.1f, inputs %.1f, align %.1f, candidates %.1f, check %.1f, "
      "search %.1f, evaluate %.1f, optimize %.1f, total %.1f\n",
      t.validate_ms, t.inputs_ms, t.align_ms, t.candidates_ms, t.check_ms, t.search_ms,
      t.evaluate_ms, t.optimize_ms, t.total_ms);
}

void MeasureFlags::Add(CLI::App* app) {
  app->add_option("--measure", measure,
                  "Quality measure: length, inverse-clearance, bottleneck-clearance, safe-length")
      ->capture_default_str();
  fields.Add<double>(app, "--k", "Inverse-clearance exponent (default 3)", "measure.k",
                     [](v1::Measure& m, const double& k) { m.set_k(k); });
  fields.Add<double>(app, "--safety", "Minimum clearance C for safe-length", "measure.safety",
                     [](v1::Measure& m, const double& safety) { m.set_safety(safety); });
}

v1::Measure MeasureFlags::ToProto() const {
  v1::Measure proto = MeasureToProto(MeasureSpec{.type = ParseMeasureType(measure, "--measure")});
  proto.clear_k();
  fields.Apply(proto);
  return proto;
}

}  // namespace hgraph::cli
