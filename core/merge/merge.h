// The merge pipeline: validate the inputs, build the H-Graph (check input edges, choose bridge
// candidates, check them in parallel), search it under a measure, and report the quality of
// every input and of the output. MergeRequest / MergeResult mirror the proto messages of
// hgraph.v1 (merge.proto).
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/common/progress.h"
#include "core/hgraph/bridge_candidates.h"
#include "core/hgraph/hgraph.h"
#include "core/measure/measure.h"
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
};
// "off", "converged", "rounds", "time", "growth".
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
  HybridizationSession(const MotionChecker& checker, const MergeRequest& request);
  HybridizationSession(HybridizationSession&&) = default;
  // A copy that can be queried while the original serves other callers (the server's
  // re-queries); shares the checker.
  HybridizationSession Clone() const { return HybridizationSession(*this); }

  // Searches under `measure`, computing clearance profiles only for valid edges that lack one.
  // `report_clearance` overrides MergeOptions::report_clearance for this query only (a requery
  // under length that wants its path's clearance). Throws InputError for a bad measure and
  // Error(kFailedPrecondition) if no path satisfies it.
  MergeResult Query(const MeasureSpec& measure, const ProgressCallback& progress = {},
                    const CancelToken& cancel = {},
                    std::optional<bool> report_clearance = std::nullopt);

  // Adds input paths to the H-Graph (AddPaths): their nodes (subdivided as the first inputs),
  // their edges, and bridge candidates from every new node to every node added before it (its own
  // path's too: all of them for all-pairs, else those within the H-Graph's radius), all unchecked;
  // checked reports are kept. Eager evaluation checks the new edges at once. The next Query reports
  // the new inputs too. Throws InputError naming "paths[i]..." (i counted from 0 in `paths`) for a
  // bad path. Returns the number of bridge candidates added.
  int64_t AddPaths(const std::vector<InputPath>& paths, const ProgressCallback& progress = {},
                   const CancelToken& cancel = {});

  const HGraph& graph() const { return graph_; }
  const MergeStats& build_stats() const { return build_stats_; }
  const MergeTiming& build_timing() const { return build_timing_; }
  // Approximate memory held, in bytes (for cache budgets).
  size_t memory_bytes() const;

 private:
  // The anytime post-optimization (optimize.h) grows the query's overlay and searches it.
  friend class PostOptimizer;
  HybridizationSession(const HybridizationSession&) = default;
  // What a check of an edge must establish: validity at the resolution's samples (kSampled), a
  // certificate of the whole motion without a profile (kCertified, a few distance queries in
  // open space), or the clearance profile with its certificate.
  enum class EdgeNeed { kValidity, kCertificate, kClearance };
  // Checks the edges in parallel for `need`.
  void CheckEdges(const std::vector<int>& edge_ids, EdgeNeed need, const std::string& phase,
                  const ProgressCallback& progress, const CancelToken& cancel, int64_t* checked);
  // Brings the edges a lazy search wants one step closer to their exact value under a measure
  // that needs clearance: a probe of the middle of the profile's grid, then of its quarters, its
  // eighths, ..., then the whole profile. Each step tightens the edge's bound (or finds the
  // motion in contact), so an edge that stops being wanted never pays for its profile.
  // An edge with a positive target (a clearance that decides its value, from the search) is
  // proven to keep it or shown not to (ProveClearance), and profiled only if neither holds.
  // With `ceilings`, the probed edges' ceilings are brought up to date in the same parallel loop.
  void RefineClearanceEdges(const std::vector<int>& edge_ids, const std::vector<double>& targets,
                            bool ceilings, const ProgressCallback& progress,
                            const CancelToken& cancel, int64_t* checked);
  // Decides whether edge e keeps clearance >= target all along: samples its profile's grid where
  // the known clearances (its ends', its probes') do not yet prove it, until they do
  // (ClearanceFloor >= target), or one sample is below the target, or a contact makes the motion
  // invalid. Returns false if only the profile can decide (no grid point left where a proof
  // lacks). Thread safe for distinct edges.
  bool ProveClearance(int e, double target);
  // Once per unchecked edge, before its first probe: a collision check at each probe round's
  // points (ScanFractions), which finds most candidates in contact for no distance query at all.
  // Marks the edge invalid and returns true if one is in contact. Thread safe for distinct edges.
  bool ScanForContact(int e);
  // Edge e's motion bound (MotionChecker::MotionBound), computed once. Thread safe for distinct
  // edges.
  double MotionBoundOf(int e);
  // Edge e is invalid: a point at t of it is in contact (found for this many distance queries).
  void MarkInContact(int e, double t, int64_t distance_queries);
  // Computes the clearances on the profile grids of the edges in parallel, in pieces of each
  // edge, before their profiles (which reuse them, EdgeCheckRequest::known): the output's few
  // long edges would otherwise keep one thread each busy.
  // Runs other(0) ... other(other_count - 1) in the same parallel loop (work on other edges).
  void ProbeProfileGrids(const std::vector<int>& edge_ids, const CancelToken& cancel,
                         size_t other_count = 0,
                         const std::function<void(size_t)>& other = nullptr);
  // Adds probed clearances to edge e's, kept sorted by t.
  void AddProbes(int e, const std::vector<ClearanceSample>& found,
                 const std::vector<ClearanceWitness>* witnesses = nullptr);
  // Computes the clearance of every node that lacks one (the lazy bounds use them). Returns how
  // many it computed.
  int64_t ComputeNodeClearances(const CancelToken& cancel);
  // What the search knows of edge e before its check (with its ceilings, if asked).
  EdgeBoundInput BoundInput(int e, bool ceilings);
  // Edge e's ceilings (EdgeBoundInput::ceiling), computed when its ends' or probes' witnesses
  // change. Thread safe for distinct edges.
  const std::vector<ClearanceSample>& CeilingOf(int e);
  // Extends the per-node and per-edge data to nodes and edges added since.
  void SyncEdgeData();
  // The best path under `measure` with every edge checked, and then certified (`finish`
  // kCertificate) or also profiled (kClearance, so that every measure can be reported). The
  // certificate can find a collision a sampled check missed, or fail where a motion grazes an
  // obstacle; then the search runs again. Adds to the result's stats and timing.
  SearchResult SearchBest(const Measure& measure, EdgeNeed finish, const ProgressCallback& progress,
                          const CancelToken& cancel, MergeResult* result, int64_t* rechecked);
  // The nodes of a path found, as the output lists them: a node at the same configuration as
  // the one before it (an input that repeats a waypoint) once.
  std::vector<int> OutputNodes(const SearchResult& found) const;
  // Where each node of `ids` lies on an input (ShortcutRequest::sources).
  std::vector<WaypointSource> SourcesOf(const std::vector<int>& ids) const;

  const MotionChecker* checker_;
  MergeOptions options_;
  HGraph graph_;
  MergeStats build_stats_;
  MergeTiming build_timing_;
  bool first_query_ = true;
  // Work done since the last query that no result has reported yet (an eager AddPaths' checks).
  MergeStats unreported_;
  // The edges of the last query's result under a measure that needs no clearance (a length
  // merge's path, certified but not profiled unless report_clearance).
  std::vector<int> unprofiled_result_;
  EdgeEvidence evidence_;
};

// Build + one query.
MergeResult Merge(const MotionChecker& checker, const MergeRequest& request);

}  // namespace hgraph
