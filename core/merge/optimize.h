// The anytime post-optimization of a query's H-Graph optimum (docs/design.md, "Anytime
// post-optimization"; merge.proto MergeOptions.optimize_ms): rounds of certified shortcuts of
// the best path, each re-hybridized with the H-Graph, a polish of corner cuts, and restarts from
// the inputs. Everything it adds is the query's own overlay of the H-Graph (the query drops it
// when it returns). Internal to core/merge.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <vector>

#include "core/merge/merge.h"

namespace hgraph {

// Worker threads for `threads` (0 = all cores); InputError naming options.threads if < 0.
int ResolveThreads(int threads);

// One post-optimization of one query. Not copyable; lives for one Run.
class PostOptimizer {
 public:
  // `until`: HybridizationSession::Query's optimize_until.
  PostOptimizer(HybridizationSession& session, const Measure& measure,
                const ProgressCallback& progress, const CancelToken& cancel, MergeResult* result,
                int64_t* rechecked, std::optional<std::chrono::steady_clock::time_point> until);
  PostOptimizer(const PostOptimizer&) = delete;
  PostOptimizer& operator=(const PostOptimizer&) = delete;

  // Whether the measure and options ask for a post-optimization at all.
  static bool Applies(const MergeOptions& options, const Measure& measure);
  // The best path found from `best` (never worse); adds to the result's stats and timing.
  SearchResult Run(SearchResult best);

 private:
  using Clock = std::chrono::steady_clock;
  // Whether the budget lasts and the overlay may still grow; records what stopped the rounds.
  bool GoOn();
  // The best path so far as a progress event (with progress_paths, its path).
  void Stream();
  // Takes `next` if it is better; whether it gains at least kOptimizeMinGain.
  bool Take(SearchResult next);
  // The search over everything the H-Graph holds now, certified (and under safe length
  // profiled, for the objective to be known).
  SearchResult Search();
  // A motion checked between two nodes joins the H-Graph with its report (an edge it already
  // holds keeps its own report unless unchecked), so that no later round or search checks it
  // again.
  void Keep(int a, int b, const EdgeReport& report);
  // One round of shortcuts (or, polishing, of corner cuts) of a path whose waypoints are the
  // nodes `ids`. What it checks joins the H-Graph; so does its path when it gained (new points as
  // nodes, its edges with their reports, and unless polishing unchecked bridges from the new
  // points to the nodes near them), whose node ids then replace `ids`. With `lazy` its motions
  // are taken when valid at their samples (ShortcutRequest::lazy), for a search to certify.
  ShortcutResult Shorten(const std::vector<int>& ids, const std::vector<EdgeReport>& edges,
                         bool polishing, bool lazy);
  // Runs `one_round(polishing)` (it returns whether it gained at least kOptimizeMinGain) while
  // the rounds gain and GoOn() allows: random rounds, then up to kPolishRounds polishing rounds
  // (length only: under safe length a cut's pieces would need profiles of their own).
  template <typename OneRound>
  void RunRounds(const OneRound& one_round);
  // Whether the budget in time has ended; whether `e` is what its end threw (not the caller's
  // stop); whether a shortened path may be taken without a search (length, certified).
  bool BudgetEnded() const;
  bool BudgetStop(const Error& e) const;
  bool TakesAsItIs() const;
  // The measure's objective of a path of the H-Graph.
  double ObjectiveOf(const SearchResult& path) const;
  // The path a round of shortcuts made, as a search result over the H-Graph it joined.
  SearchResult AsItIs(const ShortcutResult& shortcut);
  // Rounds of the best path, each re-hybridized (a polished path is taken as it is).
  void ShortenTheBest();
  // Restarts from the input paths (MergeOptions::optimize_restarts).
  void Restart();

  HybridizationSession& session_;
  // The session's H-Graph, grown through the session only (AddEdgeWithEvidence and
  // AddNodeWithEvidence), so that its evidence grows with it.
  const HGraph& graph_;
  const Measure& measure_;
  const ProgressCallback& progress_;
  const CancelToken& cancel_;
  // The caller's token, with the budget's end as a deadline of its own when there is a budget in
  // time: a round (its shortcuts, its search) stops there, not after it.
  CancelToken round_cancel_;
  std::optional<Clock::time_point> budget_end_;
  MergeResult* result_;
  int64_t* rechecked_;
  std::optional<Clock::time_point> until_;
  Clock::time_point started_;
  // The budget in time (< 0: the automatic one, in rounds), and what its end is called: kTime
  // for optimize_ms, kDeadline for `until`.
  double budget_ms_ = -1;
  OptimizeStop budget_stop_ = OptimizeStop::kTime;
  int nodes_before_ = 0;
  int edges_before_ = 0;
  int max_rounds_ = 0;
  int round_ = 0;
  double reach_ = 0;  // how far bridges from a shortcut's new points reach
  double objective_ = 0;
  SearchResult found_;
};

}  // namespace hgraph
