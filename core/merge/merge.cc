#include "core/merge/merge.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <mutex>
#include <numeric>
#include <utility>

#include "core/common/client_text.h"
#include "core/common/error.h"
#include "core/common/limits.h"
#include "core/common/parallel.h"
#include "core/merge/optimize.h"
#include "core/merge/path_check.h"
#include "core/merge/search_view.h"
#include "core/merge/shortcut.h"
#include "core/merge/stored_input.h"
#include "core/search/glance.h"
#include "core/search/search.h"

namespace hgraph {
namespace {

using Clock = std::chrono::steady_clock;

// Edges the widest lazy search checks at a time (core/search/search.h; a sum's checks one):
// enough to keep the worker threads busy, few enough that little is checked on speculation. Fixed,
// so that the checks and the counts do not depend on the thread count. On grid (three PRM inputs,
// all-pairs) batches of 1, 2, 4 and 8 check 9654, 9661, 9665 and 9682 edges.
constexpr int kLazyBatch = 8;

// What a check report says of its motion, in one byte: 0 unchecked, else its state, whether
// it carries a profile and whether it is certified (a later check adds one or the other).
uint8_t KnownOf(const EdgeReport& report) {
  if (report.state == EdgeState::kUnchecked) return 0;
  return static_cast<uint8_t>((report.state == EdgeState::kValid ? 1 : 2) |
                              (report.has_clearance ? 4 : 0) | (report.certified ? 8 : 0));
}

// The error of a search that found no path under `measure`.
[[noreturn]] void ThrowNoPath(const Measure& measure) {
  if (measure.spec().type == MeasureType::kSafeLength) {
    throw Error(
        ErrorCode::kFailedPrecondition, "measure.safety",
        "no path in the H-Graph keeps clearance >= " + std::to_string(measure.spec().safety));
  }
  throw Error(ErrorCode::kFailedPrecondition, "paths",
              "the valid, certified edges of the H-Graph do not connect start and goal (are the "
              "inputs valid?)");
}

}  // namespace

int ResolveThreads(int threads) {
  if (threads < 0) throw InputError("options.threads", "must be >= 0 (0 = all cores)");
  return threads == 0 ? DefaultConcurrency() : threads;
}

const char* OptimizeStopName(OptimizeStop stop) {
  switch (stop) {
    case OptimizeStop::kOff: return "off";
    case OptimizeStop::kConverged: return "converged";
    case OptimizeStop::kRounds: return "rounds";
    case OptimizeStop::kTime: return "time";
    case OptimizeStop::kGrowth: return "growth";
    case OptimizeStop::kDeadline: return "deadline";
  }
  return "off";
}

const char* EvaluationName(Evaluation evaluation) {
  switch (evaluation) {
    case Evaluation::kLazy: return "lazy";
    case Evaluation::kEager: return "eager";
  }
  return "?";
}

Evaluation ParseEvaluation(const std::string& name, const std::string& field) {
  for (Evaluation e : {Evaluation::kLazy, Evaluation::kEager}) {
    if (name == EvaluationName(e)) return e;
  }
  throw InputError(field, "unknown evaluation '" + ClientText(name) + "' (expected lazy or eager)");
}

HybridizationSession::HybridizationSession(const ClearanceChecker& checker,
                                           const MergeRequest& request)
    : checker_(&checker), options_(request.options), graph_(([&]() -> HGraph {
        ValidateMeasure(request.measure);
        ValidateCandidateOptions(request.options.candidates);
        ResolveThreads(request.options.threads);
        return HGraph(checker.space(), request.paths, request.options.endpoint_tolerance,
                      request.options.max_node_spacing);
      })()) {
  const Clock::time_point started = Clock::now();
  const Space& space = checker.space();
  const bool eager = options_.evaluation == Evaluation::kEager;
  GrowEvidence();  // the inputs' nodes and edges
  build_timing_.validate_ms = MsSince(started);

  // Input edges carry their clearance profile when every input is reported.
  Clock::time_point phase = Clock::now();
  std::vector<int> input_edges(graph_.num_edges());
  std::iota(input_edges.begin(), input_edges.end(), 0);
  if (eager || options_.report_inputs) {
    Evaluator().CheckEdges(input_edges, EdgeProof::kProfile, "inputs", request.progress,
                           request.cancel, &unreported_.edges_checked);
  }
  build_timing_.inputs_ms = MsSince(phase);

  phase = Clock::now();
  request.cancel.ThrowIfStopped();
  const CandidateSet candidates =
      BridgeCandidates(graph_, space, options_.candidates, {}, &request.cancel);
  const bool aligned = options_.candidates.variant == Variant::kEditDistance ||
                       options_.candidates.variant == Variant::kEditDistanceNeighborhood;
  (aligned ? build_timing_.align_ms : build_timing_.candidates_ms) = MsSince(phase);
  alignments_ = candidates.alignments;
  candidates_ = Resolved(options_.candidates, candidates);
  std::vector<int> bridge_edges;
  bridge_edges.reserve(candidates.pairs.size());
  for (const auto& [u, v] : candidates.pairs) {
    constexpr size_t kPollEvery = 4096;  // millions of pairs for all-pairs on a dense H-Graph
    if (bridge_edges.size() % kPollEvery == 0) request.cancel.ThrowIfStopped();
    bridge_edges.push_back(AddEdgeWithEvidence(u, v));
  }

  if (eager) {
    phase = Clock::now();
    Evaluator().CheckEdges(
        bridge_edges, NeedsClearance(request.measure) ? EdgeProof::kProfile : EdgeProof::kSamples,
        "check", request.progress, request.cancel, &unreported_.edges_checked);
    build_timing_.check_ms = MsSince(phase);
  }
  // The build's checks as its edges' reports count them, for the first query to report.
  for (int e = 0; e < graph_.num_edges(); ++e) {
    unreported_.collision_checks += graph_.edge(e).report.collision_checks;
    unreported_.distance_queries += graph_.edge(e).report.distance_queries;
  }
  build_timing_.total_ms = MsSince(started);
}

int64_t HybridizationSession::AddPaths(const std::vector<InputPath>& paths,
                                       const ProgressCallback& progress,
                                       const CancelToken& cancel) {
  const Space& space = checker_->space();
  if (paths.empty()) throw InputError("paths", "at least one path is required");
  // Validate every path before the H-Graph changes.
  graph_.CheckNewPaths(space, paths, options_.endpoint_tolerance, options_.max_node_spacing,
                       "paths");
  const CandidatesSince since{.nodes = graph_.num_nodes(), .paths = graph_.num_paths()};
  const int first_edge = graph_.num_edges();
  std::vector<int> input_edges;
  for (size_t i = 0; i < paths.size(); ++i) {
    const int p = AddPathWithEvidence(paths[i], "paths[" + std::to_string(i) + "]");
    for (int e : graph_.path_edges(p)) {
      if (e >= first_edge) input_edges.push_back(e);
    }
  }
  // The bridges merging every input at once would add (the build's parameters, every variant).
  const CandidateSet candidates = BridgeCandidates(graph_, space, candidates_, since);
  std::vector<int> bridges;
  bridges.reserve(candidates.pairs.size());
  for (const auto& [u, v] : candidates.pairs) bridges.push_back(AddEdgeWithEvidence(u, v));
  alignments_ += candidates.alignments;
  std::sort(bridges.begin(), bridges.end());
  bridges.erase(std::unique(bridges.begin(), bridges.end()), bridges.end());
  if (options_.evaluation == Evaluation::kEager) {
    // The next query reports this work with its own (AddPaths answers with that query).
    const int64_t checks_before = checker_->total_collision_checks();
    const int64_t queries_before = checker_->total_distance_queries();
    Evaluator().CheckEdges(input_edges, EdgeProof::kProfile, "inputs", progress, cancel,
                           &unreported_.edges_checked);
    Evaluator().CheckEdges(bridges, EdgeProof::kSamples, "check", progress, cancel,
                           &unreported_.edges_checked);
    unreported_.collision_checks += checker_->total_collision_checks() - checks_before;
    unreported_.distance_queries += checker_->total_distance_queries() - queries_before;
  }
  return static_cast<int64_t>(bridges.size());
}

int HybridizationSession::AddEdgeWithEvidence(int u, int v, bool input, const EdgeReport* report) {
  const int e = graph_.AddEdge(u, v, input);
  if (report != nullptr && graph_.edge(e).report.state == EdgeState::kUnchecked) {
    graph_.mutable_edge(e).report = *report;
  }
  GrowEvidence();
  return e;
}

int HybridizationSession::AddNodeWithEvidence(const Config& q, const WaypointSource& source) {
  const int n = graph_.AddNode(q, source.path, source.index, source.t);
  GrowEvidence();
  return n;
}

int HybridizationSession::AddPathWithEvidence(const InputPath& path, const std::string& field) {
  const int p = graph_.AddPath(checker_->space(), path, options_.endpoint_tolerance,
                               options_.max_node_spacing, field);
  GrowEvidence();
  return p;
}

void HybridizationSession::GrowEvidence() { evidence_.Grow(graph_, checker_->space()); }

LazyEdgeEvaluator HybridizationSession::Evaluator() {
  HGRAPH_CHECK(evidence_.num_nodes() == graph_.num_nodes() &&
               evidence_.num_edges() == graph_.num_edges());
  return LazyEdgeEvaluator(*checker_, graph_, evidence_, ResolveThreads(options_.threads));
}

void HybridizationSession::FillShape(int nodes, int edges, MergeStats* stats) const {
  stats->nodes = nodes;
  stats->threads = ResolveThreads(options_.threads);
  stats->alignments = alignments_;
  stats->radius = candidates_.radius;
  stats->gap_init = candidates_.gap_init;
  stats->gap_extend = candidates_.gap_extend;
  stats->input_edges = 0;
  stats->candidate_edges = 0;
  stats->edges_valid = 0;
  stats->input_edges_invalid = 0;
  for (int e = 0; e < edges; ++e) {
    const HEdge& edge = graph_.edge(e);
    ++(edge.input ? stats->input_edges : stats->candidate_edges);
    if (edge.report.state == EdgeState::kValid) ++stats->edges_valid;
    if (edge.input && edge.report.state == EdgeState::kInvalid) ++stats->input_edges_invalid;
  }
}

MergeStats HybridizationSession::build_stats() const {
  MergeStats stats = unreported_;
  FillShape(graph_.num_nodes(), graph_.num_edges(), &stats);
  return stats;
}

SearchResult HybridizationSession::SearchBest(const Measure& measure, EdgeProof finish,
                                              const ProgressCallback& progress,
                                              const CancelToken& cancel, MergeResult* result,
                                              int64_t* rechecked) {
  PrepareBounds(measure, cancel, result);
  const bool refuse_stalled = finish == EdgeProof::kCertificateOrGiveUp;
  SearchView view(graph_, evidence_, measure, Evaluator(), options_.check_mode, refuse_stalled);
  std::vector<double> cost_to_go;
  if (measure.cost_per_distance() > 0) {
    cost_to_go.resize(graph_.num_nodes());
    for (int n = 0; n < graph_.num_nodes(); ++n) {
      cost_to_go[n] = measure.cost_per_distance() * evidence_.goal_distance[n];
    }
  }
  // Lazy search: edges are seen through their bounds and checked only when the search would
  // settle a node through them (core/search/search.h); eager evaluation has checked them all
  // already. Then the path's own edges get their certificates (and with kClearance their
  // profiles, so that every measure can be reported); that check can find a collision the
  // validity check missed, or a motion it cannot certify, and then the search runs again.
  for (;;) {
    Clock::time_point phase = Clock::now();
    double checking_ms = 0;
    LazySearchStats lazy;
    const EvaluateFn evaluate = [&](const std::vector<int>& edges,
                                    const std::vector<double>& targets) {
      const Clock::time_point checking = Clock::now();
      if (measure.needs_clearance()) {
        Evaluator().RefineClearanceEdges(edges, targets, measure.uses_ceilings(), progress, cancel,
                                         rechecked);
      } else {
        Evaluator().CheckEdges(edges, EdgeProof::kSamples, "check", progress, cancel, rechecked);
      }
      view.Forget(edges);
      checking_ms += MsSince(checking);
    };
    const GlanceFn glance = view.glance();
    SearchResult best =
        FindBestPathLazy(graph_, measure, view.see(), view.exact(), evaluate,
                         cost_to_go.empty() ? nullptr : &cost_to_go, &evidence_.goal_distance,
                         kLazyBatch, &lazy, glance, nullptr);
    result->stats.search_rounds += lazy.evaluations + 1;
    result->timing.check_ms += checking_ms;
    result->timing.search_ms += MsSince(phase) - checking_ms;
    if (!best.found) ThrowNoPath(measure);
    phase = Clock::now();
    const std::vector<int> rechecked_edges = FinishPath(best, finish, progress, cancel, rechecked);
    view.Forget(rechecked_edges);
    result->timing.evaluate_ms += MsSince(phase);
    bool still_valid = true;
    for (int e : rechecked_edges) {
      const EdgeReport& report = graph_.edge(e).report;
      still_valid = still_valid && report.state == EdgeState::kValid &&
                    UsableBy(report, options_.check_mode, refuse_stalled);
    }
    if (still_valid) return best;
  }
}

EdgeProof HybridizationSession::FinishProof(const Measure& measure) const {
  if (measure.needs_clearance()) return EdgeProof::kProfile;
  return options_.check_mode == CheckMode::kSampled ? EdgeProof::kSamples : EdgeProof::kCertificate;
}

bool HybridizationSession::Usable(const EdgeReport& report) const {
  return options_.check_mode == CheckMode::kSampled ? report.usable_at_samples() : report.usable();
}

bool HybridizationSession::FinishHolds(const SearchResult& path, const Measure& measure,
                                       const ProgressCallback& progress, const CancelToken& cancel,
                                       int64_t* rechecked) {
  bool holds = true;
  for (int e : FinishPath(path, FinishProof(measure), progress, cancel, rechecked)) {
    const EdgeReport& report = graph_.edge(e).report;
    holds = holds && report.state == EdgeState::kValid && Usable(report);
  }
  return holds;
}

void HybridizationSession::PrepareBounds(const Measure& measure, const CancelToken& cancel,
                                         MergeResult* result) {
  if (options_.evaluation != Evaluation::kLazy) return;
  const Clock::time_point phase = Clock::now();
  if (measure.needs_node_clearance()) {
    result->stats.node_clearances += Evaluator().ComputeNodeClearances(cancel);
  }
  if (measure.uses_ceilings()) Evaluator().ComputeCeilings(cancel);
  result->timing.check_ms += MsSince(phase);
}

std::vector<int> HybridizationSession::FinishPath(const SearchResult& best, EdgeProof finish,
                                                  const ProgressCallback& progress,
                                                  const CancelToken& cancel, int64_t* rechecked) {
  std::vector<int> recheck;
  for (int e : best.edges) {
    const EdgeReport& report = graph_.edge(e).report;
    const bool lacks =
        finish == EdgeProof::kProfile   ? !report.has_clearance
        : finish == EdgeProof::kSamples ? report.state == EdgeState::kUnchecked
        : finish == EdgeProof::kCertificateOrGiveUp
            ? report.state != EdgeState::kInvalid && report.advancement == Advancement::kUnknown
            : !report.certified;
    if (lacks) recheck.push_back(e);
  }
  if (finish == EdgeProof::kProfile) Evaluator().ProbeProfileGrids(recheck, cancel);
  Evaluator().CheckEdges(recheck, finish, "evaluate", progress, cancel, rechecked);
  return recheck;
}

std::vector<int> HybridizationSession::OutputNodes(const SearchResult& found) const {
  std::vector<int> nodes;
  for (int n : found.nodes) {
    // An input that repeats a waypoint gives a zero-length edge; the output lists it once.
    if (!nodes.empty() &&
        checker_->space().Distance(graph_.node(nodes.back()).q, graph_.node(n).q) == 0) {
      continue;
    }
    nodes.push_back(n);
  }
  return nodes;
}

std::vector<WaypointSource> HybridizationSession::SourcesOf(const std::vector<int>& ids) const {
  std::vector<WaypointSource> sources;
  sources.reserve(ids.size());
  for (int n : ids) {
    const HNode& node = graph_.node(n);
    sources.push_back(WaypointSource{.path = node.path, .index = node.index, .t = node.t});
  }
  // The shared start and goal carry path 0's indices; beside a point of another input they are
  // that input's first (last) waypoint, so that the stretch between them lies on its edge.
  for (size_t j = 0; j < ids.size(); ++j) {
    const bool start = ids[j] == graph_.start();
    if (!start && ids[j] != graph_.goal()) continue;
    const size_t beside = start ? j + 1 : j - 1;
    if ((start && j + 1 >= ids.size()) || (!start && j == 0)) continue;
    const HNode& node = graph_.node(ids[beside]);
    if (node.path <= 0) continue;
    const int last = static_cast<int>(graph_.path(node.path).waypoints.size()) - 1;
    if (start && node.index == 0) sources[j] = WaypointSource{.path = node.path, .index = 0};
    if (!start && node.index == last - 1) {
      sources[j] = WaypointSource{.path = node.path, .index = last};
    }
  }
  return sources;
}

void HybridizationSession::ProfileWhatIsKnown(bool needs_clearance,
                                              const ProgressCallback& progress,
                                              const CancelToken& cancel, int64_t* rechecked) {
  if (options_.evaluation == Evaluation::kEager) {
    // Every valid edge that lacks a clearance profile gets one now; everything else is reused.
    std::vector<int> recheck;
    if (needs_clearance) {
      for (int e = 0; e < graph_.num_edges(); ++e) {
        const EdgeReport& report = graph_.edge(e).report;
        if (report.state == EdgeState::kValid && !report.has_clearance) recheck.push_back(e);
      }
    }
    Evaluator().CheckEdges(recheck, EdgeProof::kProfile, "clearance", progress, cancel, rechecked);
  }
  if (needs_clearance) {
    // A clearance query after a length query: the length path's profiles first (the ones that
    // query left out, MergeOptions::report_clearance), so that the search starts from a path
    // whose clearance is known. Without them the widest search's threshold tests probe more:
    // grid, first 3 seed-1 inputs, a bottleneck requery after a length merge, 5955 distance
    // queries against 4231 with them (of which 1229 the profiles), the same widest path.
    std::vector<int> profile;
    for (int e : unprofiled_result_) {
      const EdgeReport& report = graph_.edge(e).report;
      if (report.state == EdgeState::kValid && !report.has_clearance) profile.push_back(e);
    }
    if (!profile.empty()) {
      Evaluator().ProbeProfileGrids(profile, cancel);
      Evaluator().CheckEdges(profile, EdgeProof::kProfile, "clearance", progress, cancel,
                             rechecked);
    }
  }
}

MergeResult HybridizationSession::Query(const MeasureSpec& spec, const ProgressCallback& progress,
                                        const CancelToken& cancel,
                                        std::optional<bool> report_clearance,
                                        std::optional<Clock::time_point> optimize_until) {
  const std::unique_ptr<const Measure> measure = Measure::Make(spec);
  const bool needs_clearance = measure->needs_clearance();
  const bool profile_result = report_clearance.value_or(options_.report_clearance);
  const Clock::time_point started = Clock::now();
  MergeResult result;
  result.measure = spec;
  result.variant = options_.candidates.variant;
  result.check_mode = options_.check_mode;
  // The first query reports the build's timing; every query its own work, with what no query
  // has reported yet (the build's, an eager AddPaths'), and the H-Graph's shape (CountWork).
  const bool first = std::exchange(first_query_, false);
  result.timing = first ? build_timing_ : MergeTiming{};
  const int64_t checks_before = checker_->total_collision_checks();
  const int64_t queries_before = checker_->total_distance_queries();
  int64_t rechecked = 0;
  // The post-optimization's nodes and edges are this query's own (its overlay): they go when it
  // returns or throws, so that no later query's answer depends on this one. The check reports
  // it left on the H-Graph's own edges stay (they change what a later query costs, not what it
  // answers).
  const int base_nodes = graph_.num_nodes();
  const int base_edges = graph_.num_edges();
  struct DropOverlay {
    HybridizationSession* session;
    int nodes;
    int edges;
    ~DropOverlay() {
      session->graph_.Truncate(nodes, edges);
      session->evidence_.Truncate(nodes, edges);
    }
  } drop_overlay{this, base_nodes, base_edges};
  std::vector<uint8_t> known_before(static_cast<size_t>(base_edges));
  for (int e = 0; e < base_edges; ++e) known_before[e] = KnownOf(graph_.edge(e).report);

  Clock::time_point phase = Clock::now();
  ProfileWhatIsKnown(needs_clearance, progress, cancel, &rechecked);
  unprofiled_result_.clear();
  result.timing.check_ms += MsSince(phase);

  // The optimum is certified first (with CheckMode::kSampled, checked at its samples); the
  // profiles, which only the report needs under a measure that does not search by clearance, are
  // computed for the final path when it asks for them (MergeOptions::report_clearance).
  SearchResult best =
      SearchBest(*measure, FinishProof(*measure), progress, cancel, &result, &rechecked);
  result.hgraph_objective = measure->Objective(EvaluateEdges(graph_, best.edges, spec.k));
  if (PostOptimizer::Applies(options_, *measure)) {
    best = PostOptimizer(*this, *measure, progress, cancel, &result, &rechecked, optimize_until)
               .Run(std::move(best));
  }
  if (!needs_clearance && profile_result) {
    best = SearchBest(*measure, EdgeProof::kProfile, progress, cancel, &result, &rechecked);
  }
  if (!needs_clearance && !profile_result) {
    for (int e : best.edges) {
      if (e < base_edges) unprofiled_result_.push_back(e);
    }
  }
  phase = Clock::now();
  result.quality = EvaluateEdges(graph_, best.edges, spec.k);
  for (int n : OutputNodes(best)) {
    const HNode& node = graph_.node(n);
    result.path.waypoints.push_back(node.q);
    result.source_path.push_back(node.path);
    result.source_index.push_back(node.index);
    result.source_fraction.push_back(node.t);
  }
  result.path.name = "merged";
  result.objective = measure->Objective(result.quality);

  ReportInputs(*measure, &result);
  result.timing.evaluate_ms += MsSince(phase);
  CountWork(first, base_nodes, known_before, checks_before, queries_before, rechecked, &result);
  result.timing.total_ms += MsSince(started);
  return result;
}

void HybridizationSession::ReportInputs(const Measure& measure, MergeResult* result) const {
  const bool needs_clearance = measure.needs_clearance();
  PathQuality best_quality;
  for (int p = 0; p < graph_.num_paths(); ++p) {
    InputReport report = ReportStoredInput(graph_, checker_->space(), evidence_.edge_length, p,
                                           needs_clearance, measure.spec().k);
    if (report.checked && report.valid &&
        (result->best_input < 0 || measure.Better(report.quality, best_quality))) {
      result->best_input = p;
      best_quality = report.quality;
    }
    result->inputs.push_back(std::move(report));
  }
  if (result->best_input >= 0) result->best_input_objective = measure.Objective(best_quality);
}

void HybridizationSession::CountWork(bool first, int base_nodes,
                                     const std::vector<uint8_t>& known_before,
                                     int64_t checks_before, int64_t queries_before,
                                     int64_t rechecked, MergeResult* result) {
  MergeStats& stats = result->stats;
  stats.collision_checks +=
      checker_->total_collision_checks() - checks_before + unreported_.collision_checks;
  stats.distance_queries +=
      checker_->total_distance_queries() - queries_before + unreported_.distance_queries;
  stats.edges_checked += rechecked + unreported_.edges_checked;
  unreported_ = MergeStats{};
  FillShape(base_nodes, static_cast<int>(known_before.size()), &stats);
  // Of the stored H-Graph's own edges, those whose stored check served this query as it was
  // (checked before it, and nothing more learnt of them since).
  stats.edges_reused = 0;
  for (size_t e = 0; e < known_before.size(); ++e) {
    const uint8_t known = KnownOf(graph_.edge(static_cast<int>(e)).report);
    if (!first && known_before[e] != 0 && known_before[e] == known) ++stats.edges_reused;
  }
}

size_t HybridizationSession::memory_bytes() const {
  size_t bytes = sizeof(*this);
  for (int n = 0; n < graph_.num_nodes(); ++n) {
    bytes += sizeof(HNode) + graph_.node(n).q.size() * sizeof(double);
  }
  for (int e = 0; e < graph_.num_edges(); ++e) {
    bytes += sizeof(HEdge) + 2 * sizeof(std::pair<int, int>) +
             graph_.edge(e).report.profile.capacity() * sizeof(ClearanceSample);
  }
  for (int p = 0; p < graph_.num_paths(); ++p) {
    for (const Config& q : graph_.path(p).waypoints) bytes += q.size() * sizeof(double);
  }
  bytes += evidence_.memory_bytes();
  return bytes;
}

MergeResult Merge(const ClearanceChecker& checker, const MergeRequest& request) {
  HybridizationSession session(checker, request);
  return session.Query(request.measure, request.progress, request.cancel);
}

}  // namespace hgraph
