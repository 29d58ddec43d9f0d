#include "core/merge/optimize.h"

#include <algorithm>
#include <limits>
#include <memory>
#include <numeric>
#include <utility>

#include "core/common/limits.h"
#include "core/hgraph/bridge_candidates.h"
#include "core/merge/shortcut.h"

namespace hgraph {
namespace {

// The automatic post-optimization's budget in rounds (each one call of ShortcutCertified), and
// as many again for each restart asked for. Rounds stop sooner once one gains less than
// kOptimizeMinGain: on the 21 kept benchmark problems (hgraph-bench seeds 1-3) the defaults ran
// 4 to 12 rounds, and with two restarts 14 to 43 in all.
constexpr int kAutomaticOptimizeRounds = 100;
constexpr double kOptimizeMinGain = 1e-3;
// Rounds of corner cuts (ShortcutRequest::corners_only) after the random rounds, length only.
// On the 14 kept benchmark problems they took the geometric mean of the length ratios to the
// best OMPL pipeline from 0.952 to 0.942 (one round: 0.949), for 32% more checks.
constexpr int kPolishRounds = 3;
// The share of partial shortcuts with MergeOptions::partial_shortcuts. On the 21 kept benchmark
// problems (hgraph-bench seeds 1-3, one thread, 4 seeds of the rounds) 0.25 took the geometric
// mean of the length ratios to the best OMPL pipeline from 0.944 to 0.935 for 18% more checks;
// 0.15: 0.940, 0.35: 0.938 for 25% more.
constexpr double kPartialShare = 0.25;

}  // namespace

bool PostOptimizer::Applies(const MergeOptions& options, const Measure& measure) {
  const MeasureType type = measure.spec().type;
  return options.optimize_ms != 0 &&
         (type == MeasureType::kLength || type == MeasureType::kSafeLength);
}

PostOptimizer::PostOptimizer(HybridizationSession& session, const Measure& measure,
                             const ProgressCallback& progress, const CancelToken& cancel,
                             MergeResult* result, int64_t* rechecked,
                             std::optional<Clock::time_point> until)
    : session_(session),
      graph_(session.graph_),
      measure_(measure),
      progress_(progress),
      cancel_(cancel),
      round_cancel_(cancel),
      result_(result),
      rechecked_(rechecked),
      until_(until) {}

SearchResult PostOptimizer::Run(SearchResult best) {
  const MergeOptions& options = session_.options_;
  started_ = Clock::now();
  if (options.optimize_ms > 0) budget_ms_ = options.optimize_ms;
  if (until_) {
    const double left =
        std::max(0.0, std::chrono::duration<double, std::milli>(*until_ - started_).count());
    if (budget_ms_ < 0 || left < budget_ms_) {
      budget_ms_ = left;
      budget_stop_ = OptimizeStop::kDeadline;
    }
  }
  // The clock stops the rounds only when the client gave a budget in time; the automatic budget
  // counts rounds, so that the answer is the same on any machine and under any load.
  max_rounds_ = budget_ms_ >= 0
                    ? std::numeric_limits<int>::max()
                    : kAutomaticOptimizeRounds * (1 + std::max(0, options.optimize_restarts));
  nodes_before_ = graph_.num_nodes();
  edges_before_ = graph_.num_edges();
  result_->stats.optimize_stop = OptimizeStop::kConverged;
  // Bridges from a shortcut's new points reach the nodes within the H-Graph's own scale.
  reach_ = NewNodeReach(graph_, session_.checker_->space(), session_.candidates_.radius);
  objective_ = measure_.Objective(EvaluateEdges(graph_, best.edges, measure_.spec().k));
  found_ = std::move(best);
  if (budget_ms_ >= 0) {
    budget_end_ = started_ + std::chrono::duration_cast<Clock::duration>(
                                 std::chrono::duration<double, std::milli>(budget_ms_));
    round_cancel_ = cancel_.WithDeadline(*budget_end_);
  }
  Stream();
  try {
    ShortenTheBest();
    Restart();
  } catch (const Error& e) {
    // The budget ended inside a round: the best path so far stands, certified (a round's
    // checks add facts to the H-Graph as they finish; an unfinished one adds nothing).
    if (!BudgetStop(e)) throw;
    result_->stats.optimize_stop = budget_stop_;
  }
  result_->timing.optimize_ms += MsSince(started_);
  return std::move(found_);
}

bool PostOptimizer::GoOn() {
  OptimizeStop& stop = result_->stats.optimize_stop;
  if (graph_.num_nodes() - nodes_before_ >= limits::kMaxOptimizeNodes ||
      graph_.num_edges() - edges_before_ >= limits::kMaxOptimizeEdges) {
    stop = OptimizeStop::kGrowth;
  } else if (budget_ms_ >= 0 && MsSince(started_) >= budget_ms_) {
    stop = budget_stop_;
  } else if (round_ >= max_rounds_) {
    stop = OptimizeStop::kRounds;
  } else {
    return true;
  }
  return false;
}

void PostOptimizer::Stream() {
  if (!progress_) return;
  // Every path here is certified (with CheckMode::kSampled, checked at its samples): the
  // H-Graph's optimum, each round's search and each polish.
  std::shared_ptr<InputPath> path;
  if (session_.options_.progress_paths) {
    path = std::make_shared<InputPath>(InputPath{.name = "merged"});
    for (int n : session_.OutputNodes(found_)) path->waypoints.push_back(graph_.node(n).q);
  }
  progress_(Progress{.phase = "optimize",
                     .done = round_,
                     .total = 0,
                     .collision_checks = 0,
                     .distance_queries = 0,
                     .elapsed_ms = MsSince(started_),
                     .objective = objective_,
                     .path = std::move(path)});
}

double PostOptimizer::ObjectiveOf(const SearchResult& path) const {
  return measure_.Objective(EvaluateEdges(graph_, path.edges, measure_.spec().k));
}

bool PostOptimizer::Take(SearchResult next) {
  const double next_objective = ObjectiveOf(next);
  const bool improved = next_objective < objective_ * (1 - kOptimizeMinGain);
  if (next_objective < objective_) {
    found_ = std::move(next);
    objective_ = next_objective;
    Stream();
  }
  return improved;
}

SearchResult PostOptimizer::Search() {
  // Under safe length the search may take an edge whose clearance floor proves the safety
  // without a profile; the profile makes the objective known. Under length (certified) a motion
  // whose certificate stalls is refused, not profiled (MergeOptions::give_up_stalled): a
  // profile costs hundreds of distance queries, and the rounds have other routes to try. The
  // best path so far may hold such motions (profiled by the first search); where no route is
  // left without them, it stands.
  const bool give_up = TakesAsItIs() && session_.options_.give_up_stalled;
  try {
    return session_.SearchBest(
        measure_, give_up ? EdgeProof::kCertificateOrGiveUp : session_.FinishProof(measure_),
        progress_, round_cancel_, result_, rechecked_);
  } catch (const Error& e) {
    if (!give_up || e.code() != ErrorCode::kFailedPrecondition) throw;
    return found_;
  }
}

void PostOptimizer::Keep(int a, int b, const EdgeReport& report) {
  if (a != b) session_.AddEdgeWithEvidence(a, b, false, &report);
}

ShortcutResult PostOptimizer::Shorten(const std::vector<int>& ids,
                                      const std::vector<EdgeReport>& edges, bool polishing,
                                      bool lazy) {
  round_cancel_.ThrowIfStopped();
  ++round_;
  const MeasureSpec& spec = measure_.spec();
  ShortcutRequest request{.path = {.name = "shortcut"},
                          .edges = edges,
                          .ids = ids,
                          .sources = session_.SourcesOf(ids),
                          .seed = static_cast<uint64_t>(round_),
                          .safety = spec.type == MeasureType::kSafeLength ? spec.safety : 0,
                          .corners_only = polishing,
                          .partial = session_.options_.partial_shortcuts ? kPartialShare : 0.0,
                          .lazy = lazy,
                          .sampled = session_.options_.check_mode == CheckMode::kSampled,
                          .threads = ResolveThreads(session_.options_.threads),
                          .known = [this](int a, int b) -> const EdgeReport* {
                            const int e = graph_.FindEdge(a, b);
                            return e < 0 ? nullptr : &graph_.edge(e).report;
                          },
                          .until = budget_end_};
  for (int n : ids) request.path.waypoints.push_back(graph_.node(n).q);
  ShortcutResult shortcut = ShortcutCertified(*session_.checker_, request, round_cancel_);
  *rechecked_ += shortcut.edges_checked;
  ++result_->stats.optimize_rounds;
  for (const auto& [a, b, report] : shortcut.id_checks) Keep(a, b, report);
  if (shortcut.accepted == 0) return shortcut;
  result_->stats.shortcuts += shortcut.accepted;
  result_->stats.shortcut_checks += shortcut.edges_checked;
  std::vector<int> fresh;
  for (size_t j = 0; j < shortcut.ids.size(); ++j) {
    if (shortcut.ids[j] >= 0) continue;
    shortcut.ids[j] = session_.AddNodeWithEvidence(shortcut.path.waypoints[j], shortcut.sources[j]);
    fresh.push_back(shortcut.ids[j]);
  }
  for (size_t j = 0; j + 1 < shortcut.ids.size(); ++j) {
    Keep(shortcut.ids[j], shortcut.ids[j + 1], shortcut.edges[j]);
  }
  if (!polishing) {
    const Space& space = session_.checker_->space();
    for (int u : fresh) {
      for (int v = 0; v < graph_.num_nodes(); ++v) {
        if (v == u || space.Distance(graph_.node(u).q, graph_.node(v).q) > reach_) continue;
        session_.AddEdgeWithEvidence(u, v);
      }
    }
  }
  return shortcut;
}

bool PostOptimizer::BudgetEnded() const { return budget_end_ && Clock::now() >= *budget_end_; }

bool PostOptimizer::BudgetStop(const Error& e) const {
  return e.code() == ErrorCode::kDeadlineExceeded && !cancel_.stopped() && BudgetEnded();
}

bool PostOptimizer::TakesAsItIs() const {
  return measure_.spec().type == MeasureType::kLength &&
         session_.options_.check_mode == CheckMode::kCertified;
}

SearchResult PostOptimizer::AsItIs(const ShortcutResult& shortcut) {
  // Every edge of a shortened path is proven free (the shortcuts, the cuts) or a piece of one.
  // A sampled merge's pieces of motions checked at their samples are checked at their own (a
  // search instead, if one is in collision).
  SearchResult next;
  next.found = true;
  for (int id : shortcut.ids) {
    if (!next.nodes.empty() && next.nodes.back() == id) continue;
    if (!next.nodes.empty()) next.edges.push_back(graph_.FindEdge(next.nodes.back(), id));
    next.nodes.push_back(id);
  }
  if (session_.options_.check_mode == CheckMode::kSampled &&
      !session_.FinishHolds(next, measure_, progress_, round_cancel_, rechecked_)) {
    next = Search();
  }
  return next;
}

template <typename OneRound>
void PostOptimizer::RunRounds(const OneRound& one_round) {
  const bool length = measure_.spec().type == MeasureType::kLength;
  for (int polish_rounds = -1; GoOn();) {
    const bool polishing = polish_rounds >= 0;
    if (!one_round(polishing)) {
      if (polishing || !length) return;
      polish_rounds = 0;
    } else if (polishing && ++polish_rounds == kPolishRounds) {
      return;
    }
  }
}

void PostOptimizer::ShortenTheBest() {
  // Certified shortcuts, not lazy: a lazy round's shortcut that its certificate then rejects (one
  // grazing an obstacle) leaves the round's search without gain and ends the rounds early
  // (wall_planar, seed-3 inputs: 8.38 against 8.33), and a certified round after each such round
  // cost more than laziness saved (21 kept problems: 518k against 441k, collision checks + 10 x
  // distance queries).
  RunRounds([&](bool polishing) {
    std::vector<EdgeReport> edges;
    for (int e : found_.edges) edges.push_back(graph_.edge(e).report);
    const ShortcutResult shortcut = Shorten(found_.nodes, edges, polishing, false);
    if (shortcut.accepted == 0) return false;
    // Once the budget has ended the search has no time left: under length the shortened path
    // is taken as it is, as a polished one always is.
    if (polishing || (BudgetEnded() && TakesAsItIs())) return Take(AsItIs(shortcut));
    SearchResult next;
    try {
      next = Search();
    } catch (const Error& e) {
      // The budget ended during the search: the round's shortcuts still count.
      if (!BudgetStop(e) || !TakesAsItIs()) throw;
      Take(AsItIs(shortcut));
      throw;
    }
    // A search that refuses stalled motions misses the shortened path where it keeps one of
    // the best path's motions that only a profile certified: the shorter of the two is taken.
    if (TakesAsItIs() && session_.options_.give_up_stalled) {
      SearchResult as_is = AsItIs(shortcut);
      if (ObjectiveOf(as_is) < ObjectiveOf(next)) next = std::move(as_is);
    }
    return Take(std::move(next));
  });
}

void PostOptimizer::Restart() {
  // An input path, the shortest first and then each in turn, is shortened on its own (random
  // rounds while they gain, then the polish, no search between), then the search runs over the
  // H-Graph it has joined. Where the best path's shortcuts settle in one local optimum, an input
  // may lead into a better one, and the search may take any mix of the two. Lazily: an input
  // shortened from its waypoints replaces most of its shortcuts by later ones, so they are
  // checked at their samples only and the search certifies the edges it takes (two restarts on
  // the 21 kept problems: 834k against 1316k, never longer than OMPL either way).
  const MergeOptions& options = session_.options_;
  const Space& space = session_.checker_->space();
  // Until the budget runs out (an explicit one), or this many.
  const bool by_budget = options.optimize_restarts < 0;
  std::vector<int> order(graph_.num_paths());
  std::iota(order.begin(), order.end(), 0);
  std::vector<double> input_length(order.size());
  for (int p : order) input_length[p] = PathLength(space, graph_.path(p));
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return input_length[a] < input_length[b]; });
  for (int restart = 0; !order.empty() && GoOn() &&
                        (by_budget ? budget_ms_ > 0 : restart < options.optimize_restarts);
       ++restart) {
    std::vector<int> ids;
    for (int n : graph_.path_nodes(order[restart % order.size()])) {
      if (ids.empty() || ids.back() != n) ids.push_back(n);
    }
    // The input's edges as the shortcuts need them (their lengths); checked or not, the search
    // decides on them.
    std::vector<EdgeReport> edges;
    double length = 0;
    for (size_t j = 0; j + 1 < ids.size(); ++j) {
      edges.push_back(
          EdgeReport{.length = space.Distance(graph_.node(ids[j]).q, graph_.node(ids[j + 1]).q)});
      length += edges.back().length;
    }
    RunRounds([&](bool polishing) {
      ShortcutResult shortcut = Shorten(ids, edges, polishing, true);
      if (shortcut.accepted == 0) return false;
      double shortened = 0;
      for (const EdgeReport& e : shortcut.edges) shortened += e.length;
      const bool gained = shortened < length * (1 - kOptimizeMinGain);
      length = shortened;
      ids = std::move(shortcut.ids);
      edges = std::move(shortcut.edges);
      return gained;
    });
    round_cancel_.ThrowIfStopped();
    Take(Search());
  }
}

}  // namespace hgraph
