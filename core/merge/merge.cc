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
#include "core/merge/shortcut.h"
#include "core/search/search.h"

namespace hgraph {
namespace {

using Clock = std::chrono::steady_clock;

// Edges the lazy search checks at a time (core/search/search.h): enough to keep the worker
// threads busy, few enough that little is checked on speculation. Fixed, so that the checks and
// the counts do not depend on the thread count. On grid (three PRM inputs, all-pairs) batches of
// 1, 2, 4 and 8 check 9654, 9661, 9665 and 9682 edges.
constexpr int kLazyBatch = 8;

// Grid points per edge at which the witnesses of its ends and probes bound its clearance from
// above (EdgeBoundInput::ceiling). Wrench inverse clearance (k = 3, all-pairs, spacing 1): 16,
// 32, 64 and every grid point take 29347, 24442, 18622 and 17228 distance queries; past 64 the
// ceilings cost more time than the queries they save.
constexpr int kCeilingPoints = 64;

// Probe rounds of an edge under a measure that needs clearance (RefineClearanceEdges), before
// its profile: round r probes the odd multiples of 2^-r of the way (the middle, the quarters,
// ...). On wrench (inverse clearance k = 3, all-pairs, node spacing 1; before profiles reused
// the probes) 3, 4, 5 and 6 rounds took 90139, 73678, 70351 and 74949 distance queries and
// profiled 1062, 645, 430 and 324 edges.
constexpr int kProbeRounds = 5;

// The fractions of the way each probe round asks for.
const std::vector<std::vector<double>>& ProbeFractions() {
  static const std::vector<std::vector<double>> fractions = [] {
    std::vector<std::vector<double>> out;
    for (int r = 1; r <= kProbeRounds; ++r) {
      std::vector<double> round;
      for (int j = 1; j < (1 << r); j += 2) round.push_back(static_cast<double>(j) / (1 << r));
      out.push_back(std::move(round));
    }
    return out;
  }();
  return fractions;
}

// Every probe round's fractions, round after round: the points a scan for contact checks before
// the first probe of an unchecked edge (ScanForContact).
const std::vector<double>& ScanFractions() {
  static const std::vector<double> fractions = [] {
    std::vector<double> out;
    for (const std::vector<double>& round : ProbeFractions()) {
      out.insert(out.end(), round.begin(), round.end());
    }
    return out;
  }();
  return fractions;
}

// The automatic post-optimization's budget, and the gain below which a round ends it.

// The H-Graph's shape in `stats`: its sizes and the candidate parameters, which every query
// reports as they are, without the figures that count the work of one call (checks, queries,
// rounds, reuse).
MergeStats ShapeOf(const MergeStats& stats) {
  return MergeStats{.nodes = stats.nodes,
                    .input_edges = stats.input_edges,
                    .input_edges_invalid = stats.input_edges_invalid,
                    .candidate_edges = stats.candidate_edges,
                    .threads = stats.threads,
                    .alignments = stats.alignments,
                    .radius = stats.radius,
                    .gap_init = stats.gap_init,
                    .gap_extend = stats.gap_extend};
}

// A stretch of an input edge in the H-Graph: the edge's report, whether the H-Graph edge runs
// against the input's direction, and the part [t0, t1] of the input edge it covers.
struct EdgePart {
  const EdgeReport* report = nullptr;
  bool reversed = false;
  double t0 = 0;
  double t1 = 1;
};

// The report of a whole input edge from its parts, in order along the input: profiles and the
// first invalid point mapped onto the input edge's parameter, counts and lengths summed.
EdgeReport JoinParts(const std::vector<EdgePart>& parts) {
  EdgeReport out;
  out.state = EdgeState::kValid;
  out.has_clearance = true;
  out.certified = true;
  for (const EdgePart& part : parts) {
    const EdgeReport& r = *part.report;
    const auto map = [&](double t) {
      return part.t0 + (part.reversed ? 1 - t : t) * (part.t1 - part.t0);
    };
    out.length += r.length;
    out.collision_checks += r.collision_checks;
    out.distance_queries += r.distance_queries;
    out.certified = out.certified && r.certified;
    out.has_clearance = out.has_clearance && r.has_clearance;
    if (out.state == EdgeState::kValid && r.state != EdgeState::kValid) {
      out.state = r.state;
      out.invalid_at = r.invalid_at >= 0 ? map(r.invalid_at) : -1;
    }
    if (!r.has_clearance) continue;
    const size_t first = out.profile.size();
    for (const ClearanceSample& sample : r.profile) {
      out.profile.push_back({.t = map(sample.t), .clearance = sample.clearance});
    }
    if (part.reversed) std::reverse(out.profile.begin() + first, out.profile.end());
  }
  if (!out.has_clearance || out.state != EdgeState::kValid) out.profile.clear();
  if (out.state != EdgeState::kValid) out.has_clearance = false;
  return out;
}

// What a check report says of its motion, in one byte: 0 unchecked, else its state, whether
// it carries a profile and whether it is certified (a later check adds one or the other).
uint8_t KnownOf(const EdgeReport& report) {
  if (report.state == EdgeState::kUnchecked) return 0;
  return static_cast<uint8_t>((report.state == EdgeState::kValid ? 1 : 2) |
                              (report.has_clearance ? 4 : 0) | (report.certified ? 8 : 0));
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

HybridizationSession::HybridizationSession(const MotionChecker& checker,
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
  build_stats_.threads = ResolveThreads(options_.threads);
  build_stats_.nodes = graph_.num_nodes();
  evidence_.Grow(graph_, space);
  build_timing_.validate_ms = MsSince(started);

  // Input edges carry their clearance profile when every input is reported.
  Clock::time_point phase = Clock::now();
  std::vector<int> input_edges(graph_.num_edges());
  for (int e = 0; e < graph_.num_edges(); ++e) input_edges[e] = e;
  build_stats_.input_edges = graph_.num_edges();
  if (eager || options_.report_inputs) {
    CheckEdges(input_edges, EdgeNeed::kClearance, "inputs", request.progress, request.cancel,
               &build_stats_.edges_checked);
    for (int e : input_edges) {
      if (graph_.edge(e).report.state == EdgeState::kInvalid) ++build_stats_.input_edges_invalid;
    }
  }
  build_timing_.inputs_ms = MsSince(phase);

  phase = Clock::now();
  request.cancel.ThrowIfStopped();
  const CandidateSet candidates = BridgeCandidates(graph_, space, options_.candidates);
  const bool aligned = options_.candidates.variant == Variant::kEditDistance ||
                       options_.candidates.variant == Variant::kEditDistanceNeighborhood;
  (aligned ? build_timing_.align_ms : build_timing_.candidates_ms) = MsSince(phase);
  build_stats_.candidate_edges = static_cast<int64_t>(candidates.pairs.size());
  build_stats_.alignments = candidates.alignments;
  build_stats_.radius = candidates.radius;
  build_stats_.gap_init = candidates.gap_init;
  build_stats_.gap_extend = candidates.gap_extend;
  std::vector<int> bridge_edges;
  bridge_edges.reserve(candidates.pairs.size());
  for (const auto& [u, v] : candidates.pairs) bridge_edges.push_back(graph_.AddEdge(u, v, false));
  evidence_.Grow(graph_, space);

  if (eager) {
    phase = Clock::now();
    CheckEdges(bridge_edges,
               NeedsClearance(request.measure) ? EdgeNeed::kClearance : EdgeNeed::kValidity,
               "check", request.progress, request.cancel, &build_stats_.edges_checked);
    build_timing_.check_ms = MsSince(phase);
  }
  for (int e = 0; e < graph_.num_edges(); ++e) {
    if (graph_.edge(e).report.state == EdgeState::kValid) ++build_stats_.edges_valid;
  }
  for (int e = 0; e < graph_.num_edges(); ++e) {
    build_stats_.collision_checks += graph_.edge(e).report.collision_checks;
    build_stats_.distance_queries += graph_.edge(e).report.distance_queries;
  }
  build_timing_.total_ms = MsSince(started);
}

void HybridizationSession::CheckEdges(const std::vector<int>& edge_ids, EdgeNeed need,
                                      const std::string& phase, const ProgressCallback& progress,
                                      const CancelToken& cancel, int64_t* checked) {
  const int64_t total = static_cast<int64_t>(edge_ids.size());
  if (total == 0) return;
  const ThrottledProgress reporter(progress, phase, total, Clock::now());
  const int64_t checks_at_start = checker_->total_collision_checks();
  const int64_t queries_at_start = checker_->total_distance_queries();
  std::atomic<int64_t> done{0};
  ParallelFor(ResolveThreads(options_.threads), edge_ids.size(), [&](size_t k) {
    if (cancel.stopped()) return;
    const int e = edge_ids[k];
    HEdge& edge = graph_.mutable_edge(e);
    const EdgeReport previous = std::move(edge.report);
    // A profile reuses the clearances known on its grid: the ends' and the probes'.
    std::vector<ClearanceSample> known;
    if (need == EdgeNeed::kClearance) {
      if (!std::isnan(evidence_.node_clearance[edge.u]))
        known.push_back({0.0, evidence_.node_clearance[edge.u]});
      known.insert(known.end(), evidence_.probes[e].begin(), evidence_.probes[e].end());
      if (!std::isnan(evidence_.node_clearance[edge.v]))
        known.push_back({1.0, evidence_.node_clearance[edge.v]});
    }
    edge.report = checker_->CheckEdge(EdgeCheckRequest{
        .from = &graph_.node(edge.u).q,
        .to = &graph_.node(edge.v).q,
        .mode = need == EdgeNeed::kValidity ? EdgeCheckMode::kSampled
                : need == EdgeNeed::kCertificate
                    ? (previous.state == EdgeState::kValid ? EdgeCheckMode::kCertifiedOfValid
                                                           : EdgeCheckMode::kCertified)
                : previous.state == EdgeState::kValid ? EdgeCheckMode::kClearanceOfValid
                                                      : EdgeCheckMode::kClearance,
        .known = known.empty() ? nullptr : &known,
        .from_valid = evidence_.node_valid[edge.u] != 0,
        .to_valid = evidence_.node_valid[edge.v] != 0});
    // A re-check for clearance keeps counting what the first check cost.
    if (previous.state != EdgeState::kUnchecked) {
      edge.report.collision_checks += previous.collision_checks;
      edge.report.distance_queries += previous.distance_queries;
    }
    reporter.Done(done.fetch_add(1, std::memory_order_relaxed) + 1,
                  checker_->total_collision_checks() - checks_at_start,
                  checker_->total_distance_queries() - queries_at_start);
  });
  cancel.ThrowIfStopped();
  // The ends each check found valid, for the next checks (after the loop, so that what a check
  // knows does not depend on the thread count). A check tests its end `to`, then `from`, then
  // the motion between them: a collision inside the motion, or at `from`, leaves `to` valid.
  for (const int e : edge_ids) {
    const HEdge& edge = graph_.edge(e);
    const EdgeReport& report = edge.report;
    if (report.state == EdgeState::kUnchecked) continue;
    const bool valid = report.state == EdgeState::kValid;
    if (valid || report.invalid_at < 1) evidence_.node_valid[edge.v] = 1;
    if (valid || (report.invalid_at > 0 && report.invalid_at < 1)) evidence_.node_valid[edge.u] = 1;
  }
  *checked += total;
}

void HybridizationSession::RefineClearanceEdges(const std::vector<int>& edge_ids,
                                                const std::vector<double>& targets, bool ceilings,
                                                const ProgressCallback& progress,
                                                const CancelToken& cancel, int64_t* checked) {
  const int rounds = static_cast<int>(ProbeFractions().size());
  std::vector<int> probe;
  std::vector<int> profile;
  std::vector<std::pair<int, double>> prove;
  for (size_t k = 0; k < edge_ids.size(); ++k) {
    const int e = edge_ids[k];
    if (targets[k] > 0) {
      prove.emplace_back(e, targets[k]);
    } else {
      (evidence_.probe_rounds[e] >= rounds ? profile : probe).push_back(e);
    }
  }
  // Edges a target decides: proven to keep it, or shown not to, or else profiled.
  std::vector<char> undecided(prove.size(), 0);
  std::atomic<int64_t> decided{0};
  ParallelFor(ResolveThreads(options_.threads), prove.size(), [&](size_t k) {
    if (cancel.stopped()) return;
    const auto [e, target] = prove[k];
    if (ProveClearance(e, target)) {
      decided.fetch_add(1, std::memory_order_relaxed);
    } else {
      undecided[k] = 1;
    }
  });
  cancel.ThrowIfStopped();
  *checked += decided.load();
  for (size_t k = 0; k < prove.size(); ++k) {
    if (undecided[k]) profile.push_back(prove[k].first);
  }
  // Edges are counted once, when profiled or found in contact. The profiles' grids, in pieces,
  // and the probes share one parallel loop: a batch holds few profiles among cheap probes, and
  // one long profile alone would leave the other threads idle. Then the profiles themselves.
  std::atomic<int64_t> in_contact{0};
  const auto probe_edge = [&](size_t k) {
    const int e = probe[k];
    const HEdge& edge = graph_.edge(e);
    if (edge.report.state == EdgeState::kInvalid) return;
    // An unchecked candidate is often in contact, which collision checks find for a fraction
    // of a distance query; after the scan every probe point is known free.
    if (ScanForContact(e)) {
      in_contact.fetch_add(1, std::memory_order_relaxed);
      return;
    }
    std::vector<ClearanceSample>& known = evidence_.probes[e];
    std::vector<ClearanceSample> found;
    std::vector<ClearanceWitness> witnesses;
    // A round that finds no new point of the grid (a short edge) gives way to the next.
    while (found.empty() && evidence_.probe_rounds[e] < rounds) {
      found = checker_->ProbeClearance(graph_.node(edge.u).q, graph_.node(edge.v).q,
                                       ProbeFractions()[evidence_.probe_rounds[e]], known,
                                       ProbeOrder::kDistanceOnly, &witnesses);
      ++evidence_.probe_rounds[e];
    }
    AddProbes(e, found, &witnesses);
    if (ceilings) CeilingOf(e);  // with the new probes' witnesses, in parallel
    // A probe in contact: the profile would find the motion invalid there.
    for (const ClearanceSample& sample : found) {
      if (sample.clearance > 0) continue;
      MarkInContact(e, sample.t, static_cast<int64_t>(known.size()));
      in_contact.fetch_add(1, std::memory_order_relaxed);
      break;
    }
  };
  ProbeProfileGrids(profile, cancel, probe.size(), probe_edge);
  CheckEdges(profile, EdgeNeed::kClearance, "check", progress, cancel, checked);
  cancel.ThrowIfStopped();
  *checked += in_contact.load();
}

double HybridizationSession::MotionBoundOf(int e) {
  if (std::isnan(evidence_.motion_bound[e])) {
    const HEdge& edge = graph_.edge(e);
    evidence_.motion_bound[e] = checker_->MotionBound(graph_.node(edge.u).q, graph_.node(edge.v).q);
  }
  return evidence_.motion_bound[e];
}

void HybridizationSession::MarkInContact(int e, double t, int64_t distance_queries) {
  graph_.mutable_edge(e).report = EdgeReport{.state = EdgeState::kInvalid,
                                             .length = evidence_.edge_length[e],
                                             .invalid_at = t,
                                             .distance_queries = distance_queries};
}

bool HybridizationSession::ScanForContact(int e) {
  const HEdge& edge = graph_.edge(e);
  if (edge.report.state != EdgeState::kUnchecked || evidence_.scanned[e]) return false;
  evidence_.scanned[e] = 1;
  // Points the ends' clearances already prove free (no robot point moves farther than D t from
  // the start) need no check.
  std::vector<double> fractions;
  const double from = evidence_.node_clearance[edge.u];
  const double to = evidence_.node_clearance[edge.v];
  if (std::isnan(from) || std::isnan(to)) {
    fractions = ScanFractions();
  } else {
    const double d = MotionBoundOf(e);
    for (double f : ScanFractions()) {
      if (ReachFloor({.t = 0, .clearance = from}, f, d) > 0 ||
          ReachFloor({.t = 1, .clearance = to}, f, d) > 0) {
        continue;
      }
      fractions.push_back(f);
    }
  }
  const std::vector<ClearanceSample> contact =
      checker_->ProbeClearance(graph_.node(edge.u).q, graph_.node(edge.v).q, fractions,
                               evidence_.probes[e], ProbeOrder::kCollisionOnly);
  if (contact.empty()) return false;
  AddProbes(e, contact);
  MarkInContact(e, contact.front().t, 0);
  return true;
}

bool HybridizationSession::ProveClearance(int e, double target) {
  const HEdge& edge = graph_.edge(e);
  if (edge.report.state == EdgeState::kInvalid || ScanForContact(e)) return true;
  const int stretches = checker_->ProfileStretches(evidence_.edge_length[e]);
  const double from = evidence_.node_clearance[edge.u];
  const double to = evidence_.node_clearance[edge.v];
  // An infinite target (no obstacle in reach) asks for the exact width.
  if (stretches < 1 || std::isnan(from) || std::isnan(to) || !std::isfinite(target)) return false;
  const double d = MotionBoundOf(e);
  if (!std::isfinite(d)) return false;
  // A motion checked valid has no contact on its grid; an unchecked one often has.
  const ProbeOrder order = edge.report.state == EdgeState::kUnchecked ? ProbeOrder::kCollisionFirst
                                                                      : ProbeOrder::kDistanceOnly;
  std::vector<ClearanceSample>& known = evidence_.probes[e];
  double narrowest = std::min(from, to);
  for (const ClearanceSample& sample : known) narrowest = std::min(narrowest, sample.clearance);
  if (narrowest < target) return true;
  // A target the narrowest known sample meets exactly asks for the exact width: the profile.
  if (narrowest == target) return false;
  for (;;) {
    // The samples in order, ends included; the first stretch between two that their
    // clearances do not prove above the target (StretchFloor, as ClearanceFloor decides).
    ClearanceSample a{.t = 0, .clearance = from};
    bool covered = true;
    ClearanceSample gap_from;
    ClearanceSample gap_to;
    for (size_t i = 0; i <= known.size(); ++i) {
      const ClearanceSample b = i < known.size() ? known[i] : ClearanceSample{1.0, to};
      if (b.clearance < target) return true;  // the motion is narrower: decided
      if (covered && StretchFloor(a, b, d) < target) {
        covered = false;
        gap_from = a;
        gap_to = b;
      }
      a = b;
    }
    if (covered) return true;
    // A sample at the middle of the stretch neither end proves, on the grid (the reaches need
    // not be exact: any grid point between the two is progress).
    const double reach_from = (gap_from.clearance - target) / d;
    const double reach_to = (gap_to.clearance - target) / d;
    const double middle = 0.5 * (gap_from.t + reach_from + gap_to.t - reach_to);
    const long lo = std::lround(gap_from.t * stretches) + 1;
    const long hi = std::lround(gap_to.t * stretches) - 1;
    if (lo > hi) return false;  // no grid point between: only the profile decides
    const long k = std::clamp(std::lround(middle * stretches), lo, hi);
    const std::vector<ClearanceSample> found =
        checker_->ProbeClearance(graph_.node(edge.u).q, graph_.node(edge.v).q,
                                 {static_cast<double>(k) / stretches}, known, order);
    if (found.empty()) return false;
    AddProbes(e, found);
    if (found.front().clearance <= 0) {
      MarkInContact(e, found.front().t, static_cast<int64_t>(known.size()));
      return true;
    }
  }
}

void HybridizationSession::ProbeProfileGrids(const std::vector<int>& edge_ids,
                                             const CancelToken& cancel, size_t other_count,
                                             const std::function<void(size_t)>& other) {
  // Pieces of about this many grid points, so that a few long edges keep every thread busy.
  constexpr int kPiece = 16;
  struct Piece {
    int edge;
    std::vector<double> fractions;
  };
  std::vector<Piece> pieces;
  for (int e : edge_ids) {
    if (graph_.edge(e).report.state == EdgeState::kInvalid) continue;
    const int stretches = checker_->ProfileStretches(evidence_.edge_length[e]);
    for (int k = 1; k < stretches; k += kPiece) {
      Piece piece{.edge = e, .fractions = {}};
      for (int j = k; j < std::min(stretches, k + kPiece); ++j) {
        piece.fractions.push_back(static_cast<double>(j) / stretches);
      }
      pieces.push_back(std::move(piece));
    }
  }
  // One piece alone is left to the profile, unless other work shares the loop.
  if (pieces.size() < 2 && other_count == 0) return;
  std::vector<std::vector<ClearanceSample>> found(pieces.size());
  ParallelFor(ResolveThreads(options_.threads), pieces.size() + other_count, [&](size_t k) {
    if (cancel.stopped()) return;
    if (k >= pieces.size()) {
      other(k - pieces.size());
      return;
    }
    const HEdge& edge = graph_.edge(pieces[k].edge);
    found[k] =
        checker_->ProbeClearance(graph_.node(edge.u).q, graph_.node(edge.v).q, pieces[k].fractions,
                                 evidence_.probes[pieces[k].edge], ProbeOrder::kDistanceOnly);
  });
  cancel.ThrowIfStopped();
  for (size_t k = 0; k < pieces.size(); ++k) AddProbes(pieces[k].edge, found[k]);
}

void HybridizationSession::AddProbes(int e, const std::vector<ClearanceSample>& found,
                                     const std::vector<ClearanceWitness>* witnesses) {
  if (witnesses != nullptr && !witnesses->empty()) {
    evidence_.probe_witness[e].insert(evidence_.probe_witness[e].end(), witnesses->begin(),
                                      witnesses->end());
    evidence_.ceiling_done[e] = 0;
  }
  std::vector<ClearanceSample>& known = evidence_.probes[e];
  known.insert(known.end(), found.begin(), found.end());
  std::sort(known.begin(), known.end(),
            [](const ClearanceSample& a, const ClearanceSample& b) { return a.t < b.t; });
}

int64_t HybridizationSession::ComputeNodeClearances(const CancelToken& cancel) {
  std::vector<int> missing;
  for (int n = 0; n < graph_.num_nodes(); ++n) {
    if (std::isnan(evidence_.node_clearance[n])) missing.push_back(n);
  }
  ParallelFor(ResolveThreads(options_.threads), missing.size(), [&](size_t k) {
    if (cancel.stopped()) return;
    const int n = missing[k];
    evidence_.node_clearance[n] =
        checker_->ClearanceAndWitness(graph_.node(n).q, &evidence_.node_witness[n]);
  });
  cancel.ThrowIfStopped();
  return static_cast<int64_t>(missing.size());
}

EdgeBoundInput HybridizationSession::BoundInput(int e, bool ceilings) {
  const HEdge& edge = graph_.edge(e);
  const auto clearance = [&](int n) {
    return std::isnan(evidence_.node_clearance[n]) ? std::numeric_limits<double>::infinity()
                                                   : evidence_.node_clearance[n];
  };
  return EdgeBoundInput{
      .length = evidence_.edge_length[e],
      .clearance_from = clearance(edge.u),
      .clearance_to = clearance(edge.v),
      .motion_bound = MotionBoundOf(e),
      .interior = evidence_.probes[e].empty() ? nullptr : &evidence_.probes[e],
      .ceiling = !ceilings || CeilingOf(e).empty() ? nullptr : &evidence_.ceiling[e]};
}

const std::vector<ClearanceSample>& HybridizationSession::CeilingOf(int e) {
  if (evidence_.ceiling_done[e]) return evidence_.ceiling[e];
  const HEdge& edge = graph_.edge(e);
  const ClearanceWitness& from = evidence_.node_witness[edge.u];
  const ClearanceWitness& to = evidence_.node_witness[edge.v];
  if (from.body < 0 && to.body < 0 && evidence_.probe_witness[e].empty())
    return evidence_.ceiling[e];
  evidence_.ceiling_done[e] = 1;
  evidence_.ceiling[e].clear();
  const int stretches = checker_->ProfileStretches(evidence_.edge_length[e]);
  // Evenly spread grid points (all of them on an edge of up to kCeilingPoints + 1 stretches).
  const int points = std::min(stretches - 1, kCeilingPoints);
  if (points < 1) return evidence_.ceiling[e];
  std::vector<ClearanceSample>& ceiling = evidence_.ceiling[e];
  for (int i = 1; i <= points; ++i) {
    const long k = std::lround(static_cast<double>(i) * stretches / (points + 1));
    if (k < 1 || k >= stretches) continue;
    if (!ceiling.empty() && ceiling.back().t == static_cast<double>(k) / stretches) continue;
    ceiling.push_back({.t = static_cast<double>(k) / stretches,
                       .clearance = std::numeric_limits<double>::infinity()});
  }
  std::vector<ClearanceWitness> witnesses = evidence_.probe_witness[e];
  witnesses.push_back(from);
  witnesses.push_back(to);
  checker_->LowerToWitnesses(graph_.node(edge.u).q, graph_.node(edge.v).q, witnesses, &ceiling);
  return ceiling;
}

int64_t HybridizationSession::AddPaths(const std::vector<InputPath>& paths,
                                       const ProgressCallback& progress,
                                       const CancelToken& cancel) {
  const Space& space = checker_->space();
  if (paths.empty()) throw InputError("paths", "at least one path is required");
  // Validate every path before the H-Graph changes.
  graph_.CheckNewPaths(space, paths, options_.endpoint_tolerance, options_.max_node_spacing,
                       "paths");
  const double reach = options_.candidates.variant == Variant::kAllPairs
                           ? std::numeric_limits<double>::infinity()
                           : NewNodeReach(graph_, space, build_stats_.radius);
  const int first_edge = graph_.num_edges();
  std::vector<int> input_edges;
  std::vector<int> bridges;
  for (size_t i = 0; i < paths.size(); ++i) {
    const int before = graph_.num_nodes();
    const int p = graph_.AddPath(space, paths[i], options_.endpoint_tolerance,
                                 options_.max_node_spacing, "paths[" + std::to_string(i) + "]");
    for (int e : graph_.path_edges(p)) {
      if (e >= first_edge) input_edges.push_back(e);
    }
    for (int u = before; u < graph_.num_nodes(); ++u) {
      for (int v = 0; v < u; ++v) {
        if (space.Distance(graph_.node(u).q, graph_.node(v).q) > reach) continue;
        const int e = graph_.AddEdge(u, v, false);
        if (e >= first_edge && !graph_.edge(e).input) bridges.push_back(e);
      }
    }
  }
  std::sort(bridges.begin(), bridges.end());
  bridges.erase(std::unique(bridges.begin(), bridges.end()), bridges.end());
  SyncEdgeData();
  build_stats_.nodes = graph_.num_nodes();
  build_stats_.input_edges += static_cast<int64_t>(input_edges.size());
  build_stats_.candidate_edges += static_cast<int64_t>(bridges.size());
  if (options_.evaluation == Evaluation::kEager) {
    // The next query reports this work with its own (AddPaths answers with that query).
    const int64_t checks_before = checker_->total_collision_checks();
    const int64_t queries_before = checker_->total_distance_queries();
    CheckEdges(input_edges, EdgeNeed::kClearance, "inputs", progress, cancel,
               &unreported_.edges_checked);
    CheckEdges(bridges, EdgeNeed::kValidity, "check", progress, cancel, &unreported_.edges_checked);
    unreported_.collision_checks += checker_->total_collision_checks() - checks_before;
    unreported_.distance_queries += checker_->total_distance_queries() - queries_before;
  }
  return static_cast<int64_t>(bridges.size());
}

void HybridizationSession::SyncEdgeData() { evidence_.Grow(graph_, checker_->space()); }

SearchResult HybridizationSession::SearchBest(const Measure& measure, EdgeNeed finish,
                                              const ProgressCallback& progress,
                                              const CancelToken& cancel, MergeResult* result,
                                              int64_t* rechecked) {
  SyncEdgeData();
  const bool needs_clearance = measure.needs_clearance();
  if (options_.evaluation == Evaluation::kLazy && measure.needs_node_clearance()) {
    const Clock::time_point phase = Clock::now();
    result->stats.node_clearances += ComputeNodeClearances(cancel);
    result->timing.check_ms += MsSince(phase);
  }
  if (options_.evaluation == Evaluation::kLazy && measure.uses_ceilings()) {
    const Clock::time_point phase = Clock::now();
    // The ceilings the nodes' witnesses give, in parallel rather than one at a time in the search.
    std::vector<int> bounded;
    for (int e = 0; e < graph_.num_edges(); ++e) {
      const EdgeReport& report = graph_.edge(e).report;
      if (!evidence_.ceiling_done[e] && report.state != EdgeState::kInvalid &&
          !report.has_clearance) {
        bounded.push_back(e);
      }
    }
    ParallelFor(ResolveThreads(options_.threads), bounded.size(), [&](size_t k) {
      if (!cancel.stopped()) CeilingOf(bounded[k]);
    });
    cancel.ThrowIfStopped();
    result->timing.check_ms += MsSince(phase);
  }
  // How the search sees an edge: invalid ones not at all, checked ones (with a profile where the
  // measure needs one) by their value, the others by the measure's bound.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const ExactFn exact = [&](int e) {
    const EdgeReport& report = graph_.edge(e).report;
    return !report.usable() ||
           (report.state == EdgeState::kValid && (!needs_clearance || report.has_clearance));
  };
  const auto look = [&](int e) {
    const EdgeReport& report = graph_.edge(e).report;
    if (!report.usable()) {
      return SearchEdge{.value = nan, .length = evidence_.edge_length[e]};
    }
    if (exact(e)) {
      const double value = measure.EdgeValue(report);
      return SearchEdge{
          .value = value, .length = evidence_.edge_length[e], .floor = value, .checked = true};
    }
    const EdgeBoundInput input = BoundInput(e, measure.uses_ceilings());
    return SearchEdge{.value = measure.EdgeBound(input),
                      .length = evidence_.edge_length[e],
                      .floor = measure.EdgeFloor(input),
                      .checked = report.state == EdgeState::kValid};
  };
  // What the search saw of each edge, until a check changes what is known of it: a search
  // looks at an edge once per node it settles next to it, and a bound scans the edge's probes.
  std::vector<SearchEdge> seen(graph_.num_edges());
  std::vector<char> seen_now(graph_.num_edges(), 0);
  const SearchEdgeFn see = [&](int e) {
    if (!seen_now[e]) {
      seen[e] = look(e);
      seen_now[e] = 1;
    }
    return seen[e];
  };
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
      if (needs_clearance) {
        RefineClearanceEdges(edges, targets, measure.uses_ceilings(), progress, cancel, rechecked);
      } else {
        CheckEdges(edges, EdgeNeed::kValidity, "check", progress, cancel, rechecked);
      }
      for (int e : edges) seen_now[e] = 0;
      checking_ms += MsSince(checking);
    };
    SearchResult best = FindBestPathLazy(graph_, measure, see, exact, evaluate,
                                         cost_to_go.empty() ? nullptr : &cost_to_go,
                                         &evidence_.goal_distance, kLazyBatch, &lazy);
    result->stats.search_rounds += lazy.evaluations + 1;
    result->timing.check_ms += checking_ms;
    result->timing.search_ms += MsSince(phase) - checking_ms;
    if (!best.found) {
      if (measure.spec().type == MeasureType::kSafeLength) {
        throw Error(
            ErrorCode::kFailedPrecondition, "measure.safety",
            "no path in the H-Graph keeps clearance >= " + std::to_string(measure.spec().safety));
      }
      throw Error(
          ErrorCode::kFailedPrecondition, "paths",
          "the valid, certified edges of the H-Graph do not connect start and goal (are the "
          "inputs valid?)");
    }
    phase = Clock::now();
    std::vector<int> output_recheck;
    for (int e : best.edges) {
      const EdgeReport& report = graph_.edge(e).report;
      if (finish == EdgeNeed::kClearance ? !report.has_clearance : !report.certified) {
        output_recheck.push_back(e);
      }
    }
    if (finish == EdgeNeed::kClearance) ProbeProfileGrids(output_recheck, cancel);
    CheckEdges(output_recheck, finish, "evaluate", progress, cancel, rechecked);
    for (int e : output_recheck) seen_now[e] = 0;
    result->timing.evaluate_ms += MsSince(phase);
    bool still_valid = true;
    for (int e : output_recheck) {
      const EdgeReport& report = graph_.edge(e).report;
      still_valid = still_valid && report.state == EdgeState::kValid && report.usable();
    }
    if (still_valid) return best;
  }
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

MergeResult HybridizationSession::Query(const MeasureSpec& spec, const ProgressCallback& progress,
                                        const CancelToken& cancel,
                                        std::optional<bool> report_clearance) {
  const std::unique_ptr<const Measure> measure = Measure::Make(spec);
  const bool needs_clearance = measure->needs_clearance();
  const bool profile_result = report_clearance.value_or(options_.report_clearance);
  const Clock::time_point started = Clock::now();
  MergeResult result;
  result.measure = spec;
  result.variant = options_.candidates.variant;
  // The first query reports the build with its own work; a later one reports the same shape
  // and only its own work.
  const bool first = std::exchange(first_query_, false);
  result.stats = first ? build_stats_ : ShapeOf(build_stats_);
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
  if (options_.evaluation == Evaluation::kEager) {
    // Every valid edge that lacks a clearance profile gets one now; everything else is reused.
    std::vector<int> recheck;
    if (needs_clearance) {
      for (int e = 0; e < graph_.num_edges(); ++e) {
        const EdgeReport& report = graph_.edge(e).report;
        if (report.state == EdgeState::kValid && !report.has_clearance) recheck.push_back(e);
      }
    }
    CheckEdges(recheck, EdgeNeed::kClearance, "clearance", progress, cancel, &rechecked);
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
      ProbeProfileGrids(profile, cancel);
      CheckEdges(profile, EdgeNeed::kClearance, "clearance", progress, cancel, &rechecked);
    }
  }
  unprofiled_result_.clear();
  result.timing.check_ms += MsSince(phase);

  // The optimum is certified first; the profiles, which only the report needs under a measure
  // that does not search by clearance, are computed for the final path when it asks for them
  // (MergeOptions::report_clearance).
  SearchResult best =
      SearchBest(*measure, needs_clearance ? EdgeNeed::kClearance : EdgeNeed::kCertificate,
                 progress, cancel, &result, &rechecked);
  result.hgraph_objective = measure->Objective(EvaluateEdges(graph_, best.edges, spec.k));
  if (PostOptimizer::Applies(options_, *measure)) {
    best =
        PostOptimizer(*this, *measure, progress, cancel, &result, &rechecked).Run(std::move(best));
  }
  if (!needs_clearance && profile_result) {
    best = SearchBest(*measure, EdgeNeed::kClearance, progress, cancel, &result, &rechecked);
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

  // Every input, under every measure, from the reports stored on its edges.
  PathQuality best_quality;
  for (int p = 0; p < graph_.num_paths(); ++p) {
    const InputPath& input = graph_.path(p);
    const std::vector<int>& ids = graph_.path_nodes(p);
    // One report per edge of the input (from waypoint j to j + 1), joined from the H-Graph edges
    // subdivision cut it into; nullptr where the input does not move in the H-Graph.
    std::vector<std::vector<EdgePart>> parts(std::max<size_t>(input.waypoints.size(), 2) - 1);
    std::vector<std::vector<EdgeReport>> estimated(parts.size());
    bool checked = true;
    for (size_t j = 0; j + 1 < ids.size(); ++j) {
      if (ids[j] == ids[j + 1]) continue;
      const int e = graph_.FindEdge(ids[j], ids[j + 1]);
      HGRAPH_CHECK(e >= 0);
      const HNode& from = graph_.node(ids[j]);
      const HNode& to = graph_.node(ids[j + 1]);
      // The shared start and goal nodes carry path 0's indices.
      const int index = j == 0 ? 0 : from.index;
      const double t1 = (j + 2 == ids.size() || to.t == 0) ? 1.0 : to.t;
      const EdgeReport* report = &graph_.edge(e).report;
      if (report->state == EdgeState::kUnchecked ||
          (needs_clearance && report->state == EdgeState::kValid && !report->has_clearance)) {
        // Not checked by this lazy merge (or, under a measure of clearance, found valid but not
        // profiled): its length is known, nothing else.
        checked = false;
        estimated[index].push_back(
            EdgeReport{.state = EdgeState::kValid, .length = evidence_.edge_length[e]});
      }
      parts[index].push_back(EdgePart{.report = report,
                                      .reversed = graph_.edge(e).u != ids[j],
                                      .t0 = j == 0 ? 0.0 : from.t,
                                      .t1 = t1});
    }
    std::vector<EdgeReport> joined(parts.size());
    std::vector<const EdgeReport*> edges(parts.size(), nullptr);
    for (size_t j = 0; j < parts.size(); ++j) {
      if (parts[j].empty()) continue;
      size_t next_estimate = 0;
      for (EdgePart& part : parts[j]) {
        if (part.report->state == EdgeState::kUnchecked ||
            (needs_clearance && part.report->state == EdgeState::kValid &&
             !part.report->has_clearance)) {
          part.report = &estimated[j][next_estimate++];
        }
      }
      joined[j] = JoinParts(parts[j]);
      edges[j] = &joined[j];
    }
    InputReport report = ReportInputPath(checker_->space(), graph_.path(p), edges, spec.k);
    report.checked = checked;
    if (!checked) report.certified = false;
    if (checked && report.valid &&
        (result.best_input < 0 || measure->Better(report.quality, best_quality))) {
      result.best_input = p;
      best_quality = report.quality;
    }
    result.inputs.push_back(std::move(report));
  }
  if (result.best_input >= 0) result.best_input_objective = measure->Objective(best_quality);
  result.timing.evaluate_ms += MsSince(phase);

  result.stats.collision_checks +=
      checker_->total_collision_checks() - checks_before + unreported_.collision_checks;
  result.stats.distance_queries +=
      checker_->total_distance_queries() - queries_before + unreported_.distance_queries;
  result.stats.edges_checked += rechecked + unreported_.edges_checked;
  unreported_ = MergeStats{};
  // Of the stored H-Graph's own edges: the valid ones, and those whose stored check served this
  // query as it was (checked before it, and nothing more learnt of them since).
  // Derived from the graph, not kept beside it: the input edges found invalid so far, after
  // AddPaths and lazy checks too.
  result.stats.edges_valid = 0;
  result.stats.edges_reused = 0;
  result.stats.input_edges_invalid = 0;
  for (int e = 0; e < base_edges; ++e) {
    const EdgeReport& report = graph_.edge(e).report;
    if (report.state == EdgeState::kValid) ++result.stats.edges_valid;
    if (graph_.edge(e).input && report.state == EdgeState::kInvalid) {
      ++result.stats.input_edges_invalid;
    }
    if (!first && known_before[e] != 0 && known_before[e] == KnownOf(report)) {
      ++result.stats.edges_reused;
    }
  }
  result.timing.total_ms += MsSince(started);
  return result;
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

MergeResult Merge(const MotionChecker& checker, const MergeRequest& request) {
  HybridizationSession session(checker, request);
  return session.Query(request.measure, request.progress, request.cancel);
}

}  // namespace hgraph
