#include "core/merge/path_check.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>

#include "core/common/client_text.h"
#include "core/common/error.h"
#include "core/common/parallel.h"

namespace hgraph {
namespace {

using Clock = std::chrono::steady_clock;

std::string ShortNumber(double v) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.3g", v);
  return text;
}

}  // namespace

const char* CheckModeName(CheckMode mode) {
  return mode == CheckMode::kCertified ? "certified" : "sampled";
}

CheckMode ParseCheckMode(const std::string& name, const std::string& field) {
  for (CheckMode mode : {CheckMode::kCertified, CheckMode::kSampled}) {
    if (name == CheckModeName(mode)) return mode;
  }
  throw InputError(field,
                   "unknown check mode '" + ClientText(name) + "' (expected certified or sampled)");
}

const char* InvalidCauseName(InvalidCause cause) {
  switch (cause) {
    case InvalidCause::kNone: return "none";
    case InvalidCause::kCollision: return "collision";
    case InvalidCause::kOutOfBounds: return "out of bounds";
  }
  return "none";
}

InputReport ReportInputPath(const Space& space, const InputPath& path,
                            const std::vector<const EdgeReport*>& edges, double k) {
  const size_t n = path.waypoints.size();
  HGRAPH_CHECK(n >= 1 && edges.size() == std::max<size_t>(n, 2) - 1);
  InputReport report{
      .name = path.name, .valid = true, .waypoints = static_cast<int>(n), .certified = true};
  QualityAccumulator accumulator(k);
  double length = 0;
  bool moves = false;
  for (size_t j = 0; j < edges.size(); ++j) {
    const EdgeReport* edge = edges[j];
    if (edge == nullptr) continue;
    moves = true;
    accumulator.Add(*edge);
    length += edge->length;
    report.certified = report.certified && edge->has_clearance && edge->certified;
    if (!report.valid || edge->state == EdgeState::kValid) continue;
    // The first invalid edge: where, and whether the robot left the bounds or hit something.
    const Config& a = path.waypoints[j];
    const Config& b = path.waypoints[std::min(j + 1, n - 1)];
    const double t = edge->invalid_at >= 0 ? edge->invalid_at : 0;
    const bool out = !space.InBounds(space.Interpolate(a, b, t));
    report.valid = false;
    report.invalid_edge = static_cast<int>(j);
    report.invalid_at = t;
    report.invalid_cause = out ? InvalidCause::kOutOfBounds : InvalidCause::kCollision;
    if (n == 1) {
      report.invalid_reason =
          std::string("waypoint 0 ") + (out ? "is outside the space's bounds" : "is in collision");
    } else {
      report.invalid_reason = "edge " + std::to_string(j) + " -> " + std::to_string(j + 1) + " " +
                              (out ? "leaves the space's bounds" : "is in collision") +
                              " at t=" + ShortNumber(t);
    }
  }
  if (report.valid) {
    report.certified = report.certified && moves;
    report.quality = accumulator.Finish();
  } else {
    report.certified = false;
    report.quality.k = k;
    report.quality.length = length;
    report.quality.min_clearance = 0;
  }
  return report;
}

PathCheckResult CheckPaths(const MotionChecker& checker, const PathCheckRequest& request) {
  const Clock::time_point started = Clock::now();
  if (!std::isfinite(request.k) || request.k < 0) {
    throw InputError("k", "must be finite and >= 0, got " + ShortNumber(request.k));
  }
  if (request.threads < 0) throw InputError("threads", "must be >= 0 (0 = all cores)");
  if (request.paths.empty()) throw InputError(request.field, "no paths to check");
  const Space& space = checker.space();

  // The same validation and normalisation as the H-Graph applies to a merge's inputs.
  std::vector<InputPath> paths = request.paths;
  for (size_t p = 0; p < paths.size(); ++p) {
    InputPath& path = paths[p];
    const std::string field = request.field + "[" + std::to_string(p) + "]";
    if (path.name.empty()) path.name = "path" + std::to_string(p);
    if (path.waypoints.empty()) {
      throw InputError(field + ".waypoints",
                       "path '" + ClientText(path.name) + "' has no waypoints");
    }
    for (size_t j = 0; j < path.waypoints.size(); ++j) {
      space.Validate(path.waypoints[j], field + ".waypoints[" + std::to_string(j) + "]");
      path.waypoints[j] = space.Normalize(path.waypoints[j]);
    }
  }

  // Every edge of every path, flattened so that long and short paths share the threads.
  struct EdgeJob {
    int path;
    int from;
    int to;
  };
  std::vector<EdgeJob> jobs;
  std::vector<size_t> first_job(paths.size());
  for (size_t p = 0; p < paths.size(); ++p) {
    first_job[p] = jobs.size();
    const int n = static_cast<int>(paths[p].waypoints.size());
    if (n == 1) jobs.push_back({static_cast<int>(p), 0, 0});
    for (int j = 0; j + 1 < n; ++j) jobs.push_back({static_cast<int>(p), j, j + 1});
  }
  std::vector<EdgeReport> reports(jobs.size());
  const bool need_clearance = request.mode == CheckMode::kCertified;
  const int64_t total = static_cast<int64_t>(jobs.size());
  const ThrottledProgress reporter(request.progress, "check", total, started);
  std::atomic<int64_t> done{0}, checks{0}, queries{0};
  const int threads = request.threads == 0 ? DefaultConcurrency() : request.threads;
  ParallelFor(threads, jobs.size(), [&](size_t i) {
    if (request.cancel.stopped()) return;
    const InputPath& path = paths[jobs[i].path];
    reports[i] = checker.CheckEdge(
        EdgeCheckRequest{.from = &path.waypoints[jobs[i].from],
                         .to = &path.waypoints[jobs[i].to],
                         .proof = need_clearance ? EdgeProof::kProfile : EdgeProof::kSamples,
                         .cancel = &request.cancel,
                         .threads = threads});
    const int64_t c = checks += reports[i].collision_checks;
    const int64_t q = queries += reports[i].distance_queries;
    reporter.Done(++done, c, q);
  });
  request.cancel.ThrowIfStopped();

  PathCheckResult result;
  result.edges_checked = total;
  for (size_t p = 0; p < paths.size(); ++p) {
    const size_t count = std::max<size_t>(paths[p].waypoints.size(), 2) - 1;
    std::vector<const EdgeReport*> edges(count);
    for (size_t j = 0; j < count; ++j) edges[j] = &reports[first_job[p] + j];
    result.paths.push_back(ReportInputPath(space, paths[p], edges, request.k));
  }
  for (const EdgeReport& report : reports) {
    result.collision_checks += report.collision_checks;
    result.distance_queries += report.distance_queries;
  }
  result.elapsed_ms = MsSince(started);
  return result;
}

}  // namespace hgraph
