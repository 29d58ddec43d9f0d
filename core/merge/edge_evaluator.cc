#include "core/merge/edge_evaluator.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <limits>
#include <utility>

#include "core/common/parallel.h"
#include "core/merge/ceiling.h"

namespace hgraph {
namespace {

using Clock = std::chrono::steady_clock;

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

}  // namespace

void LazyEdgeEvaluator::CheckEdges(const std::vector<int>& edge_ids, EdgeProof need,
                                   const std::string& phase, const ProgressCallback& progress,
                                   const CancelToken& cancel, int64_t* checked) {
  const int64_t total = static_cast<int64_t>(edge_ids.size());
  if (total == 0) return;
  const ThrottledProgress reporter(progress, phase, total, Clock::now());
  const int64_t checks_at_start = checker_->total_collision_checks();
  const int64_t queries_at_start = checker_->total_distance_queries();
  std::atomic<int64_t> done{0};
  ParallelFor(threads_, edge_ids.size(), [&](size_t k) {
    if (cancel.stopped()) return;
    const int e = edge_ids[k];
    HEdge& edge = graph_.mutable_edge(e);
    EdgeReport previous = std::move(edge.report);
    // A profile reuses the clearances known on its grid: the ends' and the probes'.
    std::vector<ClearanceSample> known;
    if (need == EdgeProof::kProfile) {
      if (!std::isnan(evidence_.node_clearance[edge.u]))
        known.push_back({0.0, evidence_.node_clearance[edge.u]});
      known.insert(known.end(), evidence_.probes[e].begin(), evidence_.probes[e].end());
      if (!std::isnan(evidence_.node_clearance[edge.v]))
        known.push_back({1.0, evidence_.node_clearance[edge.v]});
    }
    try {
      edge.report = checker_->CheckEdge(
          EdgeCheckRequest{.from = &graph_.node(edge.u).q,
                           .to = &graph_.node(edge.v).q,
                           .proof = need,
                           .known = {.from_valid = evidence_.node_valid[edge.u] != 0,
                                     .to_valid = evidence_.node_valid[edge.v] != 0,
                                     .samples_valid = previous.state == EdgeState::kValid,
                                     .clearances = known.empty() ? nullptr : &known},
                           .cancel = &cancel,
                           .threads = threads_});
    } catch (...) {
      // A check stopped by the caller leaves the edge as it was (a stored H-Graph keeps it).
      edge.report = std::move(previous);
      throw;
    }
    // What the earlier check found and this one did not ask for stays: advancement's outcome,
    // and a profile (a re-check for advancement alone, on a profiled motion).
    if (edge.report.advancement == Advancement::kUnknown) {
      edge.report.advancement = previous.advancement;
    }
    if (previous.has_clearance && !edge.report.has_clearance &&
        edge.report.state == EdgeState::kValid) {
      edge.report.has_clearance = true;
      edge.report.profile = std::move(previous.profile);
      edge.report.certified = edge.report.certified || previous.certified;
    }
    // A re-check keeps counting what the first check cost.
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

void LazyEdgeEvaluator::RefineClearanceEdges(const std::vector<int>& edge_ids,
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
  ParallelFor(threads_, prove.size(), [&](size_t k) {
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
    if (ProbeNextRound(probe[k], ceilings)) in_contact.fetch_add(1, std::memory_order_relaxed);
  };
  ProbeProfileGrids(profile, cancel, probe.size(), probe_edge);
  CheckEdges(profile, EdgeProof::kProfile, "check", progress, cancel, checked);
  cancel.ThrowIfStopped();
  *checked += in_contact.load();
}

bool LazyEdgeEvaluator::ProbeNextRound(int e, bool ceilings) {
  const int rounds = static_cast<int>(ProbeFractions().size());
  const HEdge& edge = graph_.edge(e);
  if (edge.report.state == EdgeState::kInvalid) return false;
  // An unchecked candidate is often in contact, which collision checks find for a fraction
  // of a distance query; after the scan every probe point is known free.
  if (ScanForContact(e)) return true;
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
    return true;
  }
  return false;
}

double LazyEdgeEvaluator::MotionBoundOf(int e) {
  if (std::isnan(evidence_.motion_bound[e])) {
    const HEdge& edge = graph_.edge(e);
    evidence_.motion_bound[e] = checker_->MotionBound(graph_.node(edge.u).q, graph_.node(edge.v).q);
  }
  return evidence_.motion_bound[e];
}

void LazyEdgeEvaluator::MarkInContact(int e, double t, int64_t distance_queries) {
  graph_.mutable_edge(e).report = EdgeReport{.state = EdgeState::kInvalid,
                                             .length = evidence_.edge_length[e],
                                             .invalid_at = t,
                                             .distance_queries = distance_queries};
}

bool LazyEdgeEvaluator::ScanForContact(int e) {
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

bool LazyEdgeEvaluator::ProveClearance(int e, double target) {
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

void LazyEdgeEvaluator::ProbeProfileGrids(const std::vector<int>& edge_ids,
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
  ParallelFor(threads_, pieces.size() + other_count, [&](size_t k) {
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
  // An edge's pieces are consecutive: their probes go in at once.
  for (size_t k = 0; k < pieces.size();) {
    const int e = pieces[k].edge;
    std::vector<ClearanceSample> probes;
    for (; k < pieces.size() && pieces[k].edge == e; ++k) {
      probes.insert(probes.end(), found[k].begin(), found[k].end());
    }
    AddProbes(e, probes);
  }
}

void LazyEdgeEvaluator::AddProbes(int e, const std::vector<ClearanceSample>& found,
                                  const std::vector<ClearanceWitness>* witnesses) {
  if (witnesses != nullptr && !witnesses->empty()) {
    evidence_.probe_witness[e].insert(evidence_.probe_witness[e].end(), witnesses->begin(),
                                      witnesses->end());
    int8_t& state = evidence_.ceiling_done[e];
    if (state == kCeilingCurrent) state = kCeilingStale;
  }
  // The known probes stay sorted by t: the new ones are sorted and merged in, linear in what is
  // known (an edge at a fine resolution gathers a million probes, in tens of thousands of calls).
  const auto by_t = [](const ClearanceSample& a, const ClearanceSample& b) { return a.t < b.t; };
  std::vector<ClearanceSample>& known = evidence_.probes[e];
  const auto old_end = static_cast<std::ptrdiff_t>(known.size());
  known.insert(known.end(), found.begin(), found.end());
  std::sort(known.begin() + old_end, known.end(), by_t);
  std::inplace_merge(known.begin(), known.begin() + old_end, known.end(), by_t);
}

int64_t LazyEdgeEvaluator::ComputeNodeClearances(const CancelToken& cancel) {
  std::vector<int> missing;
  for (int n = 0; n < graph_.num_nodes(); ++n) {
    if (std::isnan(evidence_.node_clearance[n])) missing.push_back(n);
  }
  ParallelFor(threads_, missing.size(), [&](size_t k) {
    if (cancel.stopped()) return;
    const int n = missing[k];
    evidence_.node_clearance[n] =
        checker_->ClearanceAndWitness(graph_.node(n).q, &evidence_.node_witness[n]);
  });
  cancel.ThrowIfStopped();
  return static_cast<int64_t>(missing.size());
}

void LazyEdgeEvaluator::ComputeCeilings(const CancelToken& cancel) {
  std::vector<int> bounded;
  for (int e = 0; e < graph_.num_edges(); ++e) {
    const EdgeReport& report = graph_.edge(e).report;
    if (evidence_.ceiling_done[e] != kCeilingCurrent && report.state != EdgeState::kInvalid &&
        !report.has_clearance) {
      bounded.push_back(e);
    }
  }
  ParallelFor(threads_, bounded.size(), [&](size_t k) {
    if (!cancel.stopped()) CeilingOf(bounded[k]);
  });
  cancel.ThrowIfStopped();
}

EdgeBoundInput LazyEdgeEvaluator::BoundInput(int e, bool ceilings) {
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

const std::vector<ClearanceSample>& LazyEdgeEvaluator::CeilingOf(int e) {
  int8_t& state = evidence_.ceiling_done[e];
  if (state == kCeilingCurrent) return evidence_.ceiling[e];
  const HEdge& edge = graph_.edge(e);
  const ClearanceWitness& from = evidence_.node_witness[edge.u];
  const ClearanceWitness& to = evidence_.node_witness[edge.v];
  std::vector<ClearanceWitness>& pending = evidence_.probe_witness[e];
  if (from.body < 0 && to.body < 0 && pending.empty()) return evidence_.ceiling[e];
  std::vector<ClearanceSample>& ceiling = evidence_.ceiling[e];
  if (state == kCeilingNone) {
    ceiling.clear();
    ForEachCeilingPoint(checker_->ProfileStretches(evidence_.edge_length[e]), [&](double t) {
      ceiling.push_back({.t = t, .clearance = std::numeric_limits<double>::infinity()});
    });
  }
  state = kCeilingCurrent;
  if (!ceiling.empty()) {
    // Lowered by the witnesses found since (core/merge/ceiling.h); the ends' go in again (a
    // no-op once in), in case one was found since.
    std::vector<ClearanceWitness> witnesses = std::move(pending);
    witnesses.push_back(from);
    witnesses.push_back(to);
    checker_->LowerToWitnesses(graph_.node(edge.u).q, graph_.node(edge.v).q, witnesses, &ceiling);
    // Rounded up to floats, as the snapshot stores them.
    for (ClearanceSample& point : ceiling) point.clearance = CeilingValue(point.clearance);
  }
  // Lowered into the ceiling: no longer needed (nor stored by the snapshot).
  pending.clear();
  pending.shrink_to_fit();
  return ceiling;
}

}  // namespace hgraph
