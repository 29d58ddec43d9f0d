// The merge pipeline: validate the inputs, build the H-Graph (check input edges, choose bridge
// candidates, check them in parallel), search it under a measure, and report the quality of
// every input and of the output. MergeRequest / MergeResult mirror the proto messages of
// hgraph.v1 (merge.proto).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "core/common/progress.h"
#include "core/hgraph/bridge_candidates.h"
#include "core/hgraph/hgraph.h"
#include "core/measure/measure.h"
#include "core/merge/path_check.h"
#include "core/motion/motion_checker.h"

namespace hgraph {

struct MergeOptions {
  CandidateOptions candidates;
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

struct MergeStats {
  int64_t nodes = 0;
  int64_t input_edges = 0;
  int64_t input_edges_invalid = 0;
  int64_t candidate_edges = 0;
  int64_t edges_checked = 0;  // local-planner runs (inputs, bridges, clearance re-checks)
  int64_t edges_valid = 0;    // valid edges in the graph
  int64_t collision_checks = 0;
  int64_t distance_queries = 0;
  int64_t edges_reused = 0;  // edges whose stored report served this query
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
};

// An H-Graph built once and searched under any number of measures. Not thread safe: callers
// serialise queries on one instance. Not copyable (it may be large); movable.
class HybridizationSession {
 public:
  // Validates the request and builds the H-Graph (phases validate, inputs, align, check).
  // Throws InputError for bad input, Error(kCancelled / kDeadlineExceeded) when stopped, and
  // Error(kFailedPrecondition) if no input path is valid.
  HybridizationSession(const MotionChecker& checker, const MergeRequest& request);
  HybridizationSession(HybridizationSession&&) = default;

  // Searches under `measure`, computing clearance profiles only for valid edges that lack one.
  // Throws InputError for a bad measure and Error(kFailedPrecondition) if no path satisfies it.
  MergeResult Query(const MeasureSpec& measure, const ProgressCallback& progress = {},
                    const CancelToken& cancel = {});

  const HGraph& graph() const { return graph_; }
  const MergeStats& build_stats() const { return build_stats_; }
  const MergeTiming& build_timing() const { return build_timing_; }
  // Approximate memory held, in bytes (for cache budgets).
  size_t memory_bytes() const;

 private:
  void CheckEdges(const std::vector<int>& edge_ids, bool need_clearance, const std::string& phase,
                  const ProgressCallback& progress, const CancelToken& cancel, int64_t* checked);

  const MotionChecker* checker_;
  MergeOptions options_;
  HGraph graph_;
  MergeStats build_stats_;
  MergeTiming build_timing_;
  bool first_query_ = true;
};

// Build + one query.
MergeResult Merge(const MotionChecker& checker, const MergeRequest& request);

}  // namespace hgraph
