#include "core/adapter/merge_proto.h"

#include <cmath>
#include <sstream>
#include <string>

#include "core/adapter/path_io.h"
#include "core/adapter/scene_proto.h"
#include "core/common/error.h"
#include "core/common/limits.h"

namespace hgraph {

MeasureSpec MeasureFromProto(const v1::Measure& proto) {
  MeasureSpec spec;
  switch (proto.type()) {
    case v1::Measure::TYPE_UNSPECIFIED:
    case v1::Measure::TYPE_LENGTH: spec.type = MeasureType::kLength; break;
    case v1::Measure::TYPE_INVERSE_CLEARANCE: spec.type = MeasureType::kInverseClearance; break;
    case v1::Measure::TYPE_BOTTLENECK_CLEARANCE:
      spec.type = MeasureType::kBottleneckClearance;
      break;
    case v1::Measure::TYPE_SAFE_LENGTH: spec.type = MeasureType::kSafeLength; break;
    default:
      throw InputError("measure.type",
                       "unknown measure type " + std::to_string(static_cast<int>(proto.type())));
  }
  if (proto.has_k()) {
    limits::RequireRange(proto.k(), 0, limits::kMaxK, "measure.k");
    spec.k = proto.k();
  }
  limits::RequireRange(proto.safety(), 0, limits::kMaxDistance, "measure.safety");
  spec.safety = proto.safety();
  return spec;
}

v1::Measure MeasureToProto(const MeasureSpec& spec) {
  v1::Measure proto;
  switch (spec.type) {
    case MeasureType::kLength: proto.set_type(v1::Measure::TYPE_LENGTH); break;
    case MeasureType::kInverseClearance: proto.set_type(v1::Measure::TYPE_INVERSE_CLEARANCE); break;
    case MeasureType::kBottleneckClearance:
      proto.set_type(v1::Measure::TYPE_BOTTLENECK_CLEARANCE);
      break;
    case MeasureType::kSafeLength: proto.set_type(v1::Measure::TYPE_SAFE_LENGTH); break;
  }
  proto.set_k(spec.k);
  proto.set_safety(spec.safety);
  return proto;
}

Variant VariantFromProto(v1::Variant variant) {
  switch (variant) {
    case v1::VARIANT_UNSPECIFIED:
    case v1::VARIANT_EDIT_DISTANCE: return Variant::kEditDistance;
    case v1::VARIANT_ALL_PAIRS: return Variant::kAllPairs;
    case v1::VARIANT_NEIGHBORHOOD: return Variant::kNeighborhood;
    case v1::VARIANT_K_NEAREST: return Variant::kKNearest;
    case v1::VARIANT_EDIT_DISTANCE_NEIGHBORHOOD: return Variant::kEditDistanceNeighborhood;
    default:
      throw InputError("options.variant",
                       "unknown variant " + std::to_string(static_cast<int>(variant)));
  }
}

v1::Variant VariantToProto(Variant variant) {
  switch (variant) {
    case Variant::kAllPairs: return v1::VARIANT_ALL_PAIRS;
    case Variant::kNeighborhood: return v1::VARIANT_NEIGHBORHOOD;
    case Variant::kKNearest: return v1::VARIANT_K_NEAREST;
    case Variant::kEditDistance: return v1::VARIANT_EDIT_DISTANCE;
    case Variant::kEditDistanceNeighborhood: return v1::VARIANT_EDIT_DISTANCE_NEIGHBORHOOD;
  }
  return v1::VARIANT_UNSPECIFIED;
}

CheckMode CheckModeFromProto(v1::CheckMode mode) {
  switch (mode) {
    case v1::CHECK_MODE_UNSPECIFIED:
    case v1::CHECK_MODE_CERTIFIED: return CheckMode::kCertified;
    case v1::CHECK_MODE_SAMPLED: return CheckMode::kSampled;
    default:
      throw InputError("options.check_mode",
                       "unknown check mode " + std::to_string(static_cast<int>(mode)) +
                           " (expected CHECK_MODE_CERTIFIED or CHECK_MODE_SAMPLED)");
  }
}

v1::CheckMode CheckModeToProto(CheckMode mode) {
  return mode == CheckMode::kSampled ? v1::CHECK_MODE_SAMPLED : v1::CHECK_MODE_CERTIFIED;
}

v1::OptimizeStop OptimizeStopToProto(OptimizeStop stop) {
  switch (stop) {
    case OptimizeStop::kOff: return v1::OPTIMIZE_STOP_OFF;
    case OptimizeStop::kConverged: return v1::OPTIMIZE_STOP_CONVERGED;
    case OptimizeStop::kRounds: return v1::OPTIMIZE_STOP_ROUNDS;
    case OptimizeStop::kTime: return v1::OPTIMIZE_STOP_TIME;
    case OptimizeStop::kGrowth: return v1::OPTIMIZE_STOP_GROWTH;
    case OptimizeStop::kDeadline: return v1::OPTIMIZE_STOP_DEADLINE;
  }
  return v1::OPTIMIZE_STOP_UNSPECIFIED;
}

// A result from a server older than the field (or a value newer than this reader) reads as off:
// it says nothing a client could rely on.
OptimizeStop OptimizeStopFromProto(v1::OptimizeStop stop) {
  switch (stop) {
    case v1::OPTIMIZE_STOP_CONVERGED: return OptimizeStop::kConverged;
    case v1::OPTIMIZE_STOP_ROUNDS: return OptimizeStop::kRounds;
    case v1::OPTIMIZE_STOP_TIME: return OptimizeStop::kTime;
    case v1::OPTIMIZE_STOP_GROWTH: return OptimizeStop::kGrowth;
    case v1::OPTIMIZE_STOP_DEADLINE: return OptimizeStop::kDeadline;
    default: return OptimizeStop::kOff;
  }
}

MergeOptions MergeOptionsFromProto(const v1::MergeOptions& proto) {
  MergeOptions options;
  options.candidates.variant = VariantFromProto(proto.variant());
  // Core code reads a non-positive radius and negative gaps as "automatic", so an explicit bad
  // value must be caught here rather than silently replaced.
  if (proto.has_radius()) {
    limits::RequirePositiveUpTo(proto.radius(), limits::kMaxDistance, "options.radius");
    options.candidates.radius = proto.radius();
  }
  if (proto.has_phi()) {
    if (proto.phi() < 1 || proto.phi() > limits::kMaxPhi) {
      throw InputError("options.phi", "must be in [1, " + std::to_string(limits::kMaxPhi) +
                                          "], got " + std::to_string(proto.phi()));
    }
    options.candidates.phi = proto.phi();
  }
  if (proto.has_gap_init()) {
    limits::RequireRange(proto.gap_init(), 0, limits::kMaxGapCost, "options.gap_init");
    options.candidates.gap_init = proto.gap_init();
  }
  if (proto.has_gap_extend()) {
    limits::RequireRange(proto.gap_extend(), 0, limits::kMaxGapCost, "options.gap_extend");
    options.candidates.gap_extend = proto.gap_extend();
  }
  if (proto.has_resolution()) {
    limits::RequireRange(proto.resolution(), limits::kMinResolution, limits::kMaxResolution,
                         "options.resolution");
  }
  if (proto.threads() < 0 || proto.threads() > limits::kMaxThreads) {
    throw InputError("options.threads", "must be in [0, " + std::to_string(limits::kMaxThreads) +
                                            "] (0 = all cores), got " +
                                            std::to_string(proto.threads()));
  }
  options.threads = proto.threads();
  if (proto.has_endpoint_tolerance()) {
    limits::RequireRange(proto.endpoint_tolerance(), 0, limits::kMaxDistance,
                         "options.endpoint_tolerance");
    options.endpoint_tolerance = proto.endpoint_tolerance();
  }
  if (proto.has_max_node_spacing()) {
    limits::RequireRange(proto.max_node_spacing(), 0, limits::kMaxDistance,
                         "options.max_node_spacing");
    options.max_node_spacing = proto.max_node_spacing();
  }
  switch (proto.evaluation()) {
    case v1::EVALUATION_UNSPECIFIED:
    case v1::EVALUATION_LAZY: options.evaluation = Evaluation::kLazy; break;
    case v1::EVALUATION_EAGER: options.evaluation = Evaluation::kEager; break;
    default:
      throw InputError("options.evaluation",
                       "unknown evaluation " + std::to_string(proto.evaluation()));
  }
  options.check_mode = CheckModeFromProto(proto.check_mode());
  options.report_inputs = proto.report_inputs();
  options.report_clearance = proto.report_clearance();
  options.partial_shortcuts = proto.partial_shortcuts();
  options.progress_paths = proto.progress_paths();
  if (proto.has_optimize_ms()) {
    limits::RequireRange(proto.optimize_ms(), 0, limits::kMaxOptimizeMs, "options.optimize_ms");
    options.optimize_ms = proto.optimize_ms();
  }
  if (proto.has_optimize_restarts()) {
    if (proto.optimize_restarts() < 0 || proto.optimize_restarts() > limits::kMaxOptimizeRestarts) {
      throw InputError("options.optimize_restarts",
                       "must be in [0, " + std::to_string(limits::kMaxOptimizeRestarts) +
                           "], got " + std::to_string(proto.optimize_restarts()));
    }
    options.optimize_restarts = proto.optimize_restarts();
  }
  return options;
}

double ResolutionFromProto(const v1::MergeOptions& options, const v1::Scene& scene) {
  if (options.has_resolution()) {
    limits::RequireRange(options.resolution(), limits::kMinResolution, limits::kMaxResolution,
                         "options.resolution");
    return options.resolution();
  }
  return SceneResolution(scene);
}

v1::PathQuality QualityToProto(const PathQuality& quality) {
  v1::PathQuality proto;
  proto.set_length(quality.length);
  // Unset where unknown (has_clearance false): a reader that checks presence sees no 0.
  if (quality.has_clearance) {
    proto.set_min_clearance(quality.min_clearance);
    proto.set_avg_clearance(quality.avg_clearance);
    proto.set_inverse_clearance(quality.inverse_clearance);
  }
  proto.set_k(quality.k);
  proto.set_has_clearance(quality.has_clearance);
  return proto;
}

PathQuality QualityFromProto(const v1::PathQuality& proto) {
  // A server older than has_clearance (merge.proto 6) leaves it false but profiled every path
  // it reported with clearance; a newer one sets the clearances 0 when it is false. So a
  // positive clearance is known either way (a CLI of today against a replica not yet upgraded).
  return PathQuality{.length = proto.length(),
                     .min_clearance = proto.min_clearance(),
                     .avg_clearance = proto.avg_clearance(),
                     .inverse_clearance = proto.inverse_clearance(),
                     .k = proto.k(),
                     .has_clearance = proto.has_clearance() || proto.min_clearance() > 0};
}

v1::InputReport InputReportToProto(const InputReport& report) {
  v1::InputReport proto;
  proto.set_name(report.name);
  proto.set_valid(report.valid);
  proto.set_invalid_edge(report.invalid_edge);
  proto.set_invalid_reason(report.invalid_reason);
  *proto.mutable_quality() = QualityToProto(report.quality);
  proto.set_waypoints(report.waypoints);
  proto.set_invalid_at(report.invalid_at);
  switch (report.invalid_cause) {
    case InvalidCause::kNone: proto.set_invalid_cause(v1::InputReport::CAUSE_UNSPECIFIED); break;
    case InvalidCause::kCollision: proto.set_invalid_cause(v1::InputReport::CAUSE_COLLISION); break;
    case InvalidCause::kOutOfBounds:
      proto.set_invalid_cause(v1::InputReport::CAUSE_OUT_OF_BOUNDS);
      break;
  }
  proto.set_certified(report.certified);
  proto.set_checked(report.checked);
  if (!report.valid) {
    proto.set_validity(v1::VALIDITY_INVALID);
    v1::PathFailure* failure = proto.mutable_failure();
    failure->set_edge(report.invalid_edge);
    failure->set_at(report.invalid_at);
    failure->set_cause(proto.invalid_cause());
  } else {
    proto.set_validity(report.checked ? v1::VALIDITY_VALID : v1::VALIDITY_UNKNOWN);
  }
  return proto;
}

InputReport InputReportFromProto(const v1::InputReport& proto) {
  InputReport report{.name = proto.name(),
                     .valid = proto.valid(),
                     .invalid_edge = proto.invalid_edge(),
                     .invalid_reason = proto.invalid_reason(),
                     .quality = QualityFromProto(proto.quality()),
                     .waypoints = proto.waypoints(),
                     .invalid_at = proto.invalid_at(),
                     .certified = proto.certified(),
                     .checked = proto.checked()};
  switch (proto.invalid_cause()) {
    case v1::InputReport::CAUSE_COLLISION: report.invalid_cause = InvalidCause::kCollision; break;
    case v1::InputReport::CAUSE_OUT_OF_BOUNDS:
      report.invalid_cause = InvalidCause::kOutOfBounds;
      break;
    default: report.invalid_cause = InvalidCause::kNone; break;
  }
  return report;
}

v1::MergeResult MergeResultToProto(const MergeResult& result) {
  v1::MergeResult proto;
  *proto.mutable_path() = PathToProto(result.path);
  *proto.mutable_quality() = QualityToProto(result.quality);
  for (const InputReport& input : result.inputs) *proto.add_inputs() = InputReportToProto(input);
  const MergeStats& s = result.stats;
  v1::MergeStats* stats = proto.mutable_stats();
  stats->set_nodes(s.nodes);
  stats->set_input_edges(s.input_edges);
  stats->set_input_edges_invalid(s.input_edges_invalid);
  stats->set_candidate_edges(s.candidate_edges);
  stats->set_edges_checked(s.edges_checked);
  stats->set_edges_valid(s.edges_valid);
  stats->set_collision_checks(s.collision_checks);
  stats->set_distance_queries(s.distance_queries);
  stats->set_edges_reused(s.edges_reused);
  stats->set_threads(s.threads);
  stats->set_alignments(s.alignments);
  stats->set_radius(s.radius);
  stats->set_gap_init(s.gap_init);
  stats->set_gap_extend(s.gap_extend);
  stats->set_search_rounds(s.search_rounds);
  stats->set_node_clearances(s.node_clearances);
  stats->set_optimize_rounds(s.optimize_rounds);
  stats->set_shortcuts(s.shortcuts);
  stats->set_optimize_stop(OptimizeStopToProto(s.optimize_stop));
  const MergeTiming& t = result.timing;
  v1::Timing* timing = proto.mutable_timing();
  timing->set_validate_ms(t.validate_ms);
  timing->set_inputs_ms(t.inputs_ms);
  timing->set_align_ms(t.align_ms);
  timing->set_candidates_ms(t.candidates_ms);
  timing->set_check_ms(t.check_ms);
  timing->set_search_ms(t.search_ms);
  timing->set_evaluate_ms(t.evaluate_ms);
  timing->set_optimize_ms(t.optimize_ms);
  timing->set_total_ms(t.total_ms);
  for (int p : result.source_path) proto.add_source_path(p);
  for (int i : result.source_index) proto.add_source_index(i);
  for (double f : result.source_fraction) proto.add_source_fraction(f);
  *proto.mutable_measure() = MeasureToProto(result.measure);
  proto.set_variant(VariantToProto(result.variant));
  proto.set_check_mode(CheckModeToProto(result.check_mode));
  proto.set_certified(result.check_mode == CheckMode::kCertified);
  proto.set_best_input(result.best_input);
  proto.set_objective(result.objective);
  proto.set_best_input_objective(result.best_input_objective);
  proto.set_hgraph_objective(result.hgraph_objective);
  for (size_t i = 0; i < result.source_path.size(); ++i) {
    v1::WaypointSource* source = proto.add_sources();
    if (result.source_path[i] < 0) continue;
    source->set_input(result.source_path[i]);
    if (i < result.source_index.size()) source->set_edge(result.source_index[i]);
    if (i < result.source_fraction.size()) source->set_fraction(result.source_fraction[i]);
  }
  // Only an input known valid is the best one.
  const int best = result.best_input;
  if (best >= 0 && best < static_cast<int>(result.inputs.size()) && result.inputs[best].valid &&
      result.inputs[best].checked) {
    proto.mutable_best()->set_index(best);
    proto.mutable_best()->set_objective(result.best_input_objective);
  }
  return proto;
}

MergeResult MergeResultFromProto(const v1::MergeResult& proto) {
  MergeResult result;
  v1::PathSet one;
  *one.add_paths() = proto.path();
  result.path = PathsFromProto(one).front();
  result.quality = QualityFromProto(proto.quality());
  for (const v1::InputReport& input : proto.inputs()) {
    result.inputs.push_back(InputReportFromProto(input));
  }
  const v1::MergeStats& s = proto.stats();
  result.stats = MergeStats{.nodes = s.nodes(),
                            .input_edges = s.input_edges(),
                            .input_edges_invalid = s.input_edges_invalid(),
                            .candidate_edges = s.candidate_edges(),
                            .edges_checked = s.edges_checked(),
                            .edges_valid = s.edges_valid(),
                            .collision_checks = s.collision_checks(),
                            .distance_queries = s.distance_queries(),
                            .edges_reused = s.edges_reused(),
                            .search_rounds = s.search_rounds(),
                            .node_clearances = s.node_clearances(),
                            .optimize_rounds = s.optimize_rounds(),
                            .shortcuts = s.shortcuts(),
                            .optimize_stop = OptimizeStopFromProto(s.optimize_stop()),
                            .threads = s.threads(),
                            .alignments = s.alignments(),
                            .radius = s.radius(),
                            .gap_init = s.gap_init(),
                            .gap_extend = s.gap_extend()};
  const v1::Timing& t = proto.timing();
  result.timing = MergeTiming{.validate_ms = t.validate_ms(),
                              .inputs_ms = t.inputs_ms(),
                              .align_ms = t.align_ms(),
                              .candidates_ms = t.candidates_ms(),
                              .check_ms = t.check_ms(),
                              .search_ms = t.search_ms(),
                              .evaluate_ms = t.evaluate_ms(),
                              .optimize_ms = t.optimize_ms(),
                              .total_ms = t.total_ms()};
  result.source_path.assign(proto.source_path().begin(), proto.source_path().end());
  result.source_index.assign(proto.source_index().begin(), proto.source_index().end());
  result.source_fraction.assign(proto.source_fraction().begin(), proto.source_fraction().end());
  result.measure = MeasureFromProto(proto.measure());
  result.variant = VariantFromProto(proto.variant());
  // Either field saying sampled makes the result sampled; a server older than both certified
  // every merged path.
  const bool sampled =
      proto.check_mode() == v1::CHECK_MODE_SAMPLED || (proto.has_certified() && !proto.certified());
  result.check_mode = sampled ? CheckMode::kSampled : CheckMode::kCertified;
  result.best_input = proto.best_input();
  result.objective = proto.objective();
  result.best_input_objective = proto.best_input_objective();
  result.hgraph_objective = proto.hgraph_objective();
  return result;
}

}  // namespace hgraph
