// The merge pipeline: validate the inputs, build the H-Graph (check input edges, choose bridge
// candidates, check them in parallel), search it under a measure, and report the quality of
// every input and of the output. MergeRequest / MergeResult mirror the proto messages of
// hgraph.v1 (merge.proto).
#pragma once

#include <chrono>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/common/progress.h"
#include "core/hgraph/bridge_candidates.h"
#include "core/hgraph/hgraph.h"
#include "core/measure/measure.h"
#include "core/merge/edge_evaluator.h"
#include "core/merge/evidence.h"
#include "core/merge/path_check.h"
#include "core/merge/shortcut.h"
#include "core/motion/motion_checker.h"
#include "core/search/search.h"

namespace hgraph {

// How the H-Graph's edges are checked (docs/design.md, "Evaluation is lazy").
enum class Evaluation {
  // Edges enter unchecked with the measure's bound on their cost; the search checks only the
  // edges of the path it would take and searches again until that path is fully checked
  // (LazySP). Same optimum as kEager for length and bottleneck clearance; no worse for the
  // others; far fewer checks.
  kLazy,
  // Every input edge and every bridge candidate is checked before the first search.
  kEager,
};
// "lazy", "eager".
const char* EvaluationName(Evaluation evaluation);
// Parses the names above; throws InputError naming `field` otherwise.
Evaluation ParseEvaluation(const std::string& name, const std::string& field);

struct MergeOptions {
  CandidateOptions candidates;
  Evaluation evaluation = Evaluation::kLazy;
  // What a motion must pass for the merged path to take it (see merge.proto
  // MergeOptions.check_mode). kCertified: proven free between its samples (the clearance
  // certificate of core/motion/local_planner.h). kSampled: the collision test at the
  // resolution's samples only, as OMPL's DiscreteMotionValidator checks: no distance query for a
  // measure that needs no clearance, and a result that may graze an obstacle between two samples
  // (MergeResult::check_mode says so). The measures of clearance still profile the motions they
  // take (their values are clearances), and take a profile whose certificate fails where its
  // samples passed; so do report_inputs, report_clearance and eager evaluation's input profiles.
  CheckMode check_mode = CheckMode::kCertified;
  // Check every input edge with its clearance profile so that every input report is complete
  // (InputReport::checked). Always so with kEager. Lazy evaluation otherwise reports what its
  // search checked.
  bool report_inputs = false;
  // Profile the merged path's clearance for its quality under a measure that needs none
  // (length): see merge.proto MergeOptions.report_clearance. Off: the path is certified and its
  // quality has its length only (PathQuality::has_clearance false).
  bool report_clearance = false;
  // Anytime post-optimization budget in ms (see merge.proto MergeOptions.optimize_ms): < 0
  // automatic, 0 off.
  double optimize_ms = -1;
  // A quarter of the post-optimization's random shortcuts are partial (ShortcutRequest::partial):
  // shorter paths on average for more checks (see merge.proto MergeOptions.partial_shortcuts).
  bool partial_shortcuts = false;
  // Restarts of the post-optimization from the input paths (see merge.proto
  // MergeOptions.optimize_restarts): < 0 none with the automatic budget and as many as an
  // explicit one allows, else this many (within the budget).
  int optimize_restarts = -1;
  // The post-optimization's progress events carry their path (Progress::path; see merge.proto
  // MergeOptions.progress_paths).
  bool progress_paths = false;
  // Under length with certified checks, the post-optimization's searches refuse a motion whose
  // certificate stalls (conservative advancement cannot prove it free: it grazes an obstacle)
  // instead of profiling it, as its shortcuts do; the search takes another route, and the best
  // path so far stands. Off: such a motion is profiled, and taken if its profile certifies it.
  // Not in the API: the benchmark's comparison (hgraph-bench, hgraph-profiled-stalls).
  bool give_up_stalled = true;
  double endpoint_tolerance = kEndpointTolerance;
  int threads = 0;  // worker threads; 0 = all cores
  // > 0: input edges longer than this are subdivided in the H-Graph (see HGraph); 0 = off.
  double max_node_spacing = 0;
};

struct MergeRequest {
  std::vector<InputPath> paths;
  MeasureSpec measure;
  MergeOptions options;
  ProgressCallback progress;  // may be empty
  CancelToken cancel;
};

// What ended the post-optimization's rounds (MergeStats::optimize_stop).
enum class OptimizeStop {
  kOff,        // not run: optimize_ms 0, or a measure it does not serve
  kConverged,  // a round gained less than 0.1% (and, with restarts, each restart ran)
  kRounds,     // the automatic budget's rounds ran out
  kTime,       // the client's optimize_ms ran out
  kGrowth,     // the overlay reached limits::kMaxOptimizeNodes or kMaxOptimizeEdges
  kDeadline,   // the query's optimize_until came (the caller's deadline, less a margin)
};
// "off", "converged", "rounds", "time", "growth", "deadline".
const char* OptimizeStopName(OptimizeStop stop);

struct MergeStats {
  int64_t nodes = 0;
  int64_t input_edges = 0;
  int64_t input_edges_invalid = 0;  // input edges found invalid so far
  int64_t candidate_edges = 0;
  int64_t edges_checked = 0;  // local-planner runs (inputs, bridges, clearance re-checks)
  int64_t edges_valid = 0;    // valid edges in the graph
  int64_t collision_checks = 0;
  int64_t distance_queries = 0;
  int64_t edges_reused = 0;     // edges whose stored report served this query
  int64_t search_rounds = 0;    // searches run (lazy: one per batch of checks, plus the last)
  int64_t node_clearances = 0;  // node clearances computed for the lazy bounds
  int64_t optimize_rounds = 0;  // post-optimization rounds
  int64_t shortcuts = 0;        // shortcuts the post-optimization accepted
  int64_t shortcut_checks = 0;  // motions its shortcuts checked (accepted or not)
  OptimizeStop optimize_stop = OptimizeStop::kOff;
  int threads = 0;
  int alignments = 0;
  double radius = 0;
  double gap_init = 0;
  double gap_extend = 0;
};

struct MergeTiming {
  double validate_ms = 0;
  double inputs_ms = 0;
  double align_ms = 0;  // choosing candidates (alignment for the edit-distance variants)
  double candidates_ms = 0;
  double check_ms = 0;
  double search_ms = 0;
  double evaluate_ms = 0;
  double optimize_ms = 0;  // the post-optimization, inside total_ms
  double total_ms = 0;
};

struct MergeResult {
  InputPath path;
  PathQuality quality;
  std::vector<InputReport> inputs;
  MergeStats stats;
  MergeTiming timing;
  std::vector<int> source_path;
  std::vector<int> source_index;
  std::vector<double> source_fraction;  // along edge (source_index, +1); 0 at input waypoints
  MeasureSpec measure;
  Variant variant = Variant::kEditDistance;
  // The merge's MergeOptions::check_mode: with kCertified every motion of `path` is proven free;
  // with kSampled it passed the collision test at its samples only (not certified).
  CheckMode check_mode = CheckMode::kCertified;
  int best_input = -1;
  double objective = 0;
  double best_input_objective = 0;
  double hgraph_objective = 0;  // the H-Graph optimum, before the post-optimization
};

// An H-Graph built once and searched under any number of measures. Not thread safe: callers
// serialise queries on one instance. Movable; copied only explicitly (Clone: it may be large).
class HybridizationSession {
 public:
  // Validates the request and builds the H-Graph (phases validate, inputs, align, check).
  // Throws InputError for bad input, Error(kCancelled / kDeadlineExceeded) when stopped, and
  // Error(kFailedPrecondition) if no input path is valid.
  HybridizationSession(const ClearanceChecker& checker, const MergeRequest& request);
  HybridizationSession(HybridizationSession&&) = default;
  // A copy that can be queried while the original serves other callers (the server's
  // re-queries); shares the checker.
  HybridizationSession Clone() const { return HybridizationSession(*this); }

  // Searches under `measure`, computing clearance profiles only for valid edges that lack one.
  // `report_clearance` overrides MergeOptions::report_clearance for this query only (a requery
  // under length that wants its path's clearance). `optimize_until` gives this query's
  // post-optimization a budget that ends then (the time left when it starts; none if that has
  // passed), spent as an explicit optimize_ms is, restarts included; with optimize_ms > 0 too
  // the shorter budget holds. Throws InputError for a bad measure and Error(kFailedPrecondition)
  // if no path satisfies it.
  MergeResult Query(
      const MeasureSpec& measure, const ProgressCallback& progress = {},
      const CancelToken& cancel = {}, std::optional<bool> report_clearance = std::nullopt,
      std::optional<std::chrono::steady_clock::time_point> optimize_until = std::nullopt);

  // Adds input paths to the H-Graph (AddPaths): their nodes (subdivided as the first inputs),
  // their edges, and bridge candidates from every new node to every node added before it (its own
  // path's too: all of them for all-pairs, else those within the H-Graph's radius), all unchecked;
  // checked reports are kept. Eager evaluation checks the new edges at once. The next Query reports
  // the new inputs too. Throws InputError naming "paths[i]..." (i counted from 0 in `paths`) for a
  // bad path. Returns the number of bridge candidates added.
  int64_t AddPaths(const std::vector<InputPath>& paths, const ProgressCallback& progress = {},
                   const CancelToken& cancel = {});

  const HGraph& graph() const { return graph_; }
  // The H-Graph's shape (FillShape), with the work no query has reported yet: before the first
  // query, the build's.
  MergeStats build_stats() const;
  const MergeTiming& build_timing() const { return build_timing_; }
  // Approximate memory held, in bytes (for cache budgets).
  size_t memory_bytes() const;

 private:
  // The anytime post-optimization (optimize.h) grows the query's overlay and searches it.
  friend class PostOptimizer;
  // Saves and loads every member below (core/merge/snapshot.h).
  friend class SessionSnapshot;
  HybridizationSession(const HybridizationSession&) = default;
  // An empty session for SessionSnapshot to fill.
  HybridizationSession(const ClearanceChecker& checker, HGraph graph)
      : checker_(&checker), graph_(std::move(graph)) {}
  // Every growth of the H-Graph goes through these three, and each grows the evidence with it
  // (GrowEvidence), so that the two always match.
  // The edge (u, v), or the one the H-Graph holds between them (HGraph::AddEdge); `report`, if
  // given, becomes its report while it is unchecked. Returns its id.
  int AddEdgeWithEvidence(int u, int v, bool input = false, const EdgeReport* report = nullptr);
  // A node at q that lies where `source` says on the inputs; returns its id.
  int AddNodeWithEvidence(const Config& q, const WaypointSource& source);
  // An input path, its nodes and edges (HGraph::AddPath); returns its index.
  int AddPathWithEvidence(const InputPath& path, const std::string& field);
  // Extends the evidence to the H-Graph's nodes and edges (the only caller of EdgeEvidence::Grow).
  void GrowEvidence();
  // The evaluator of this H-Graph's edges (a view of graph_ and evidence_).
  LazyEdgeEvaluator Evaluator();
  // The shape of the H-Graph's first `nodes` nodes and `edges` edges (the stored H-Graph without
  // a query's overlay) in *stats, derived from them: their counts, the valid edges and the
  // invalid input edges, the resolved candidate parameters and the alignments run.
  void FillShape(int nodes, int edges, MergeStats* stats) const;
  // The best path under `measure` with every edge checked, and then certified (`finish`
  // kCertificate) or also profiled (kClearance, so that every measure can be reported), or with
  // kSamples left at the samples its lazy search checked (CheckMode::kSampled); with
  // kCertificateOrGiveUp certified by advancement alone, a motion where it stalls refused (the
  // post-optimization's searches, MergeOptions::give_up_stalled). The
  // certificate can find a collision a sampled check missed, or fail where a motion grazes an
  // obstacle; then the search runs again. Adds to the result's stats and timing.
  SearchResult SearchBest(const Measure& measure, EdgeProof finish,
                          const ProgressCallback& progress, const CancelToken& cancel,
                          MergeResult* result, int64_t* rechecked);
  // What the edges of a path found under `measure` must establish before the path stands: a
  // profile for a measure of clearance, else a certificate, or with CheckMode::kSampled only their
  // samples.
  EdgeProof FinishProof(const Measure& measure) const;
  // Whether a path may use the motion under the merge's check mode (EdgeReport::usable, or
  // usable_at_samples for kSampled).
  bool Usable(const EdgeReport& report) const;
  // Checks the edges of `path` that lack what FinishProof asks (a polished path's new pieces);
  // whether every one of them may still be used.
  bool FinishHolds(const SearchResult& path, const Measure& measure,
                   const ProgressCallback& progress, const CancelToken& cancel, int64_t* rechecked);
  // Before a lazy search under `measure`: the node clearances and ceilings its bounds use.
  void PrepareBounds(const Measure& measure, const CancelToken& cancel, MergeResult* result);
  // Checks the edges of a path found that lack what `finish` asks (a certificate, a profile, or
  // with kSamples a check at all); returns them (the path stands if they are still valid).
  std::vector<int> FinishPath(const SearchResult& best, EdgeProof finish,
                              const ProgressCallback& progress, const CancelToken& cancel,
                              int64_t* rechecked);
  // Before a query: profiles of the valid edges that lack one where they are wanted (eager
  // evaluation under a measure of clearance: all of them; lazy: the last length query's path).
  void ProfileWhatIsKnown(bool needs_clearance, const ProgressCallback& progress,
                          const CancelToken& cancel, int64_t* rechecked);
  // Every input's report under `measure`, from the reports stored on its edges, and the best
  // checked valid input.
  void ReportInputs(const Measure& measure, MergeResult* result) const;
  // The query's work (checks since the counts `*_before`, with the work no query has reported:
  // the build's, an eager AddPaths') and the edges whose stored report served it (known_before[e]:
  // what was known of edge e before the query, KnownOf).
  void CountWork(bool first, int base_nodes, const std::vector<uint8_t>& known_before,
                 int64_t checks_before, int64_t queries_before, int64_t rechecked,
                 MergeResult* result);
  // The nodes of a path found, as the output lists them: a node at the same configuration as
  // the one before it (an input that repeats a waypoint) once.
  std::vector<int> OutputNodes(const SearchResult& found) const;
  // Where each node of `ids` lies on an input (ShortcutRequest::sources).
  std::vector<WaypointSource> SourcesOf(const std::vector<int>& ids) const;

  const ClearanceChecker* checker_;
  MergeOptions options_;
  // The candidate options with the build's resolved parameters (radius, gaps): AddPaths and the
  // post-optimization's new points use them, so that they do not drift with new inputs.
  CandidateOptions candidates_;
  int alignments_ = 0;  // pairs of paths aligned for candidates, by the build and AddPaths
  HGraph graph_;
  MergeTiming build_timing_;
  bool first_query_ = true;
  // Work that no result has reported yet (the build's checks, an eager AddPaths'): the next
  // query reports it with its own. Its edges_checked, collision_checks, distance_queries only.
  MergeStats unreported_;
  // The edges of the last query's result under a measure that needs no clearance (a length
  // merge's path, certified but not profiled unless report_clearance).
  std::vector<int> unprofiled_result_;
  EdgeEvidence evidence_;
};

// Build + one query.
MergeResult Merge(const ClearanceChecker& checker, const MergeRequest& request);

}  // namespace hgraph
