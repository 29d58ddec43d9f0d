#include "core/search/search.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <queue>

#include "core/common/error.h"
#include "core/search/glance.h"

namespace hgraph {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// The widest search's threshold tests (FindBestPathLazy): they stop when the width is known
// within this factor, or after kMaxThresholdTests; without a proven width the first test is at
// the widest path under the bounds divided by kFirstCapDivisor. On grid (the first 3 seed-1
// inputs, all-pairs, a bottleneck requery after a length merge) factors 1.01, 1.02, 1.05 and 1.2
// took 6759, 7059, 7295 and 23726 distance queries: the final exact search profiles the edges
// into every node whose width lies between W and the bracket's top.
constexpr double kThresholdBracket = 1.02;
constexpr int kMaxThresholdTests = 12;
constexpr double kFirstCapDivisor = 16;
// LazySP (LazyShortestPath): the most edges of a path checked at once, and the entries its
// searches may push in all (plus 16 per edge) before lazy weighted A* takes over (about 0.1-0.3 s
// of searching; a post-optimization round's search pushes about 10^4-10^6).
constexpr int kMaxBatch = 64;
constexpr int64_t kMaxPushes = 4'000'000;

// One entry of the lazy open list: `node` reached through `edge` from a settled node whose value
// is `parent_value`; `key` is the entry's value (kSum: cost so far plus cost to go; widest:
// width so far) from the edge's bound or its exact value. Entries of equal key (many, under a
// widest search's cap) go by `rank`: an edge that settles the node without a check first, then
// one checked valid, then the others (widest searches only); and then by `tie`, the node's length
// to go, and by node and edge ids. A `coarse` entry's key comes from the edge's glance (a sum
// search's cheaper bound, GlanceFn): it goes before every entry of equal key, and when it comes
// out it goes back with the key its bound gives.
struct LazyEntry {
  double key = 0;
  double parent_value = 0;
  int node = 0;
  int edge = -1;
  int rank = 0;
  double tie = 0;
  bool coarse = false;
};

// The lazy search over one combine rule. `kWidest`: maximise the minimum edge value, each capped
// at `cap`; otherwise minimise the sum. `see` returns NaN (or +inf for sums) for unusable edges.
// `target` is what a sum search asks `evaluate` to decide (a widest search asks for the key).
// Lives for one Run; not copyable.
template <bool kWidest>
class LazySearch {
 public:
  LazySearch(const HGraph& graph, const SearchEdgeFn& see, const ExactFn& exact,
             const EvaluateFn& evaluate, const std::vector<double>* cost_to_go,
             const std::vector<double>* length_to_go, double cap, double target, int batch,
             LazySearchStats* stats, const GlanceFn* glance = nullptr,
             GlanceStats* glance_stats = nullptr)
      : graph_(graph),
        see_(see),
        exact_(exact),
        evaluate_(evaluate),
        cost_to_go_(cost_to_go),
        length_to_go_(length_to_go),
        cap_(cap),
        target_(target),
        batch_(batch),
        stats_(stats),
        glance_(kWidest ? nullptr : glance),
        glance_stats_(glance_stats),
        value_(graph.num_nodes(), kWidest ? -1.0 : kInf),
        via_edge_(graph.num_nodes(), -1),
        closed_(graph.num_nodes(), 0) {}
  LazySearch(const LazySearch&) = delete;
  LazySearch& operator=(const LazySearch&) = delete;

  SearchResult Run() {
    open_.push(LazyEntry{.key = kWidest ? kInf : ToGo(graph_.start()),
                         .parent_value = kWidest ? kInf : 0.0,
                         .node = graph_.start(),
                         .edge = -1});
    while (!open_.empty()) {
      const LazyEntry top = open_.top();
      open_.pop();
      if (closed_[top.node]) continue;
      if (top.coarse) {
        Refine(top);
        continue;
      }
      if (top.edge >= 0 && !Settles(top.edge, see_(top.edge), top.key)) {
        // Check this edge and the next most promising unsettled ones together.
        Gather(top);
        EvaluatePending();
        continue;
      }
      if (Settle(top)) break;
    }
    if (!closed_[graph_.goal()]) return SearchResult{};
    return TracePath(graph_, via_edge_, value_[graph_.goal()]);
  }

 private:
  // The open list's order: Worse(a, b) when a comes out after b.
  struct Worse {
    bool operator()(const LazyEntry& a, const LazyEntry& b) const {
      if (a.key != b.key) {
        if constexpr (kWidest) {
          return a.key < b.key;  // max-heap on width
        } else {
          return a.key > b.key;  // min-heap on cost
        }
      }
      // A widest search's many entries of equal key (its cap) go by what is known of them, which
      // decides only how much it checks: what it returns is a width, or whether one is reached.
      // A sum search's path is the answer, so its ties go by one fixed rule whatever is known
      // (length to go, then node and edge ids): the same path whichever queries came before.
      if (kWidest && a.rank != b.rank) return a.rank > b.rank;
      // A glance is at most the key its bound gives: an entry of that key after it.
      if (a.coarse != b.coarse) return b.coarse;
      if (a.tie != b.tie) return a.tie > b.tie;
      if (a.node != b.node) return a.node > b.node;
      return a.edge > b.edge;
    }
  };

  double ToGo(int n) const { return cost_to_go_ != nullptr ? (*cost_to_go_)[n] : 0.0; }

  // Key of an entry through an edge of value `value` from a parent of value `parent`; NaN if the
  // edge is unusable.
  double KeyOf(double parent, double value, int node) const {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    if (std::isnan(value)) return nan;
    if constexpr (kWidest) {
      return std::min({parent, value, cap_});
    } else {
      if (!(value < kInf)) return nan;
      return parent + value + ToGo(node);
    }
  }

  // Whether the edge, seen as `s`, settles an entry of key `key` without a check: it is exact, or
  // its floor is its bound (kSum) or reaches the key (widest: then min(parent, width, cap) is
  // the key, whatever the exact width).
  bool Settles(int e, const SearchEdge& s, double key) const {
    if (exact_(e)) return true;
    if constexpr (kWidest) {
      return s.floor > 0 && s.floor >= key;
    } else {
      return s.floor == s.value;
    }
  }

  // Fills the entry's key and order from the edge as seen now (`first`: its first look, through
  // the glance where there is one); false if the edge is unusable.
  bool Place(LazyEntry& entry, bool first = false) const {
    entry.coarse = false;
    if (first && glance_ != nullptr) {
      if (const std::optional<double> glance = (*glance_)(entry.edge)) {
        entry.key = KeyOf(entry.parent_value, *glance, entry.node);
        if (std::isnan(entry.key)) return false;
        entry.coarse = true;
        entry.tie = length_to_go_ != nullptr ? (*length_to_go_)[entry.node] : 0.0;
        if (glance_stats_ != nullptr) ++glance_stats_->glanced;
        return true;
      }
    }
    const SearchEdge s = see_(entry.edge);
    entry.key = KeyOf(entry.parent_value, s.value, entry.node);
    if (std::isnan(entry.key)) return false;
    entry.rank = Settles(entry.edge, s, entry.key) ? 0 : s.checked ? 1 : 2;
    entry.tie = length_to_go_ != nullptr ? (*length_to_go_)[entry.node] : 0.0;
    return true;
  }

  // A coarse entry off the open list, back on it with the key its bound gives (never less than
  // its glance: keys only grow).
  void Refine(LazyEntry entry) {
    const double glance = entry.key;
    if (glance_stats_ != nullptr) ++glance_stats_->refined;
    if (!Place(entry)) return;
    entry.key = std::max(entry.key, glance);
    open_.push(entry);
  }

  // Takes `top` and the next most promising entries that need a check off the open list, up to
  // `batch` of them, one per node (if the first settles the node, a second would be checked for
  // nothing): the pending entries.
  void Gather(const LazyEntry& top) {
    pending_.assign(1, top);
    set_aside_.clear();
    while (static_cast<int>(pending_.size()) < batch_ && !open_.empty()) {
      const LazyEntry& next = open_.top();
      if (closed_[next.node]) {
        open_.pop();
        continue;
      }
      if (next.coarse) {
        const LazyEntry entry = next;
        open_.pop();
        Refine(entry);
        continue;
      }
      if (next.edge < 0 || Settles(next.edge, see_(next.edge), next.key)) break;
      const bool same_node = std::any_of(pending_.begin(), pending_.end(),
                                         [&](const LazyEntry& p) { return p.node == next.node; });
      (same_node ? set_aside_ : pending_).push_back(next);
      open_.pop();
    }
    for (const LazyEntry& entry : set_aside_) open_.push(entry);
  }

  // Evaluates the pending entries' edges, once each with the largest target asked of it; each is
  // exact then, or its bounds are tighter: it goes back with its new key.
  void EvaluatePending() {
    wanted_.clear();
    for (const LazyEntry& entry : pending_) {
      wanted_.emplace_back(entry.edge, kWidest ? entry.key : target_);
    }
    std::sort(wanted_.begin(), wanted_.end());
    to_check_.clear();
    targets_.clear();
    for (const auto& [e, t] : wanted_) {
      if (!to_check_.empty() && to_check_.back() == e) {
        targets_.back() = std::fmax(targets_.back(), t);  // the larger key asks more
        continue;
      }
      to_check_.push_back(e);
      targets_.push_back(t);
    }
    evaluate_(to_check_, targets_);
    if (stats_ != nullptr) {
      ++stats_->evaluations;
      stats_->edges_evaluated += static_cast<int64_t>(to_check_.size());
    }
    for (LazyEntry entry : pending_) {
      if (Place(entry)) open_.push(entry);
    }
  }

  // Closes the entry's node at its value; returns true if it is the goal, else opens its
  // neighbours.
  bool Settle(const LazyEntry& top) {
    closed_[top.node] = 1;
    value_[top.node] =
        kWidest ? top.key : top.parent_value + (top.edge >= 0 ? see_(top.edge).value : 0.0);
    via_edge_[top.node] = top.edge;
    if (top.node == graph_.goal()) return true;
    for (const auto& [v, e] : graph_.neighbours(top.node)) {
      if (closed_[v]) continue;
      LazyEntry entry{.parent_value = value_[top.node], .node = v, .edge = e};
      if (Place(entry, /*first=*/true)) open_.push(entry);
    }
    return false;
  }

  const HGraph& graph_;
  const SearchEdgeFn& see_;
  const ExactFn& exact_;
  const EvaluateFn& evaluate_;
  const std::vector<double>* cost_to_go_;
  const std::vector<double>* length_to_go_;
  const double cap_;
  const double target_;
  const int batch_;
  LazySearchStats* stats_;
  const GlanceFn* glance_;
  GlanceStats* glance_stats_;
  std::priority_queue<LazyEntry, std::vector<LazyEntry>, Worse> open_;
  std::vector<double> value_;
  std::vector<int> via_edge_;
  std::vector<char> closed_;
  // Scratch of Gather and EvaluatePending, kept to reuse their memory.
  std::vector<LazyEntry> pending_;
  std::vector<LazyEntry> set_aside_;
  std::vector<std::pair<int, double>> wanted_;
  std::vector<int> to_check_;
  std::vector<double> targets_;
};

// The lazy search of a sum whose bounds cost nothing beside a check, length's (LazySP, forward
// selector; the other sums' bounds cost more to compute, and LazySearch<false> with its glance
// computes fewer of them): the shortest path under what is known now (the bounds of unchecked
// edges), then a check of its first edge that is not settled, until the
// shortest path is settled all along. Unlike LazySearch<false>, which settles every node whose key
// is below the optimum and so checks an edge into each (nodes off every short route too), it checks
// edges of short start-goal paths only. A search costs little beside a check (tens of microseconds
// on a merge's H-Graph), so it is run again after every evaluation. Lives for one Run; not
// copyable.
class LazyShortestPath {
 public:
  LazyShortestPath(const HGraph& graph, const SearchEdgeFn& see, const ExactFn& exact,
                   const EvaluateFn& evaluate, const std::vector<double>* cost_to_go, double target,
                   LazySearchStats* stats)
      : graph_(graph),
        see_(see),
        exact_(exact),
        evaluate_(evaluate),
        cost_to_go_(cost_to_go),
        target_(target),
        stats_(stats) {}
  LazyShortestPath(const LazyShortestPath&) = delete;
  LazyShortestPath& operator=(const LazyShortestPath&) = delete;

  // The path, or nullopt once the searches have cost more than kMaxPushes entries (many motions
  // found in collision on a large H-Graph, each a search of its own): lazy weighted A* then
  // finishes the search from what the checks have found so far (the same answer).
  std::optional<SearchResult> Run() {
    const int m = graph_.num_edges();
    cost_.resize(m);
    for (int e = 0; e < m; ++e) cost_[e] = CostOf(e);
    const int64_t max_pushes = kMaxPushes + 16 * static_cast<int64_t>(m);
    SearchResult path = Shortest();
    size_t next = 0;  // where the path's edges not yet known to be settled begin
    int batch = 1;
    for (;;) {
      if (!path.found) return path;
      if (pushes_ > max_pushes) return std::nullopt;
      // The costs are kept between searches and refreshed for the evaluated edges; a check
      // only ever raises what is known of an edge (never looser), so a kept cost is still a lower
      // bound. An edge of the path whose cost rose all the same is refreshed and the search runs
      // again.
      if (Refresh(path.edges, next)) {
        path = Shortest();
        next = 0;
        continue;
      }
      // The path's first edges that are not settled (LazySP's forward selector): one, and
      // twice as many after each check that left every cost as it was (the path is then still
      // the shortest, and the next ones are checked without a search). A batch of the path's
      // next 8 each time checks more (on the real-size problems 6-12% more collision checks),
      // as the first often fails and ends the path; a check's own samples keep a second thread
      // busy (EdgeCheckRequest::threads). A long valid input takes few searches.
      std::vector<int> edges;
      size_t first = path.edges.size();  // where the first of them lies on the path
      for (; next < path.edges.size() && static_cast<int>(edges.size()) < batch; ++next) {
        const int e = path.edges[next];
        const SearchEdge s = see_(e);
        if (exact_(e) || s.floor == s.value) continue;
        if (edges.empty()) first = next;
        edges.push_back(e);
      }
      if (edges.empty()) return path;
      std::sort(edges.begin(), edges.end());
      evaluate_(edges, std::vector<double>(edges.size(), target_));
      if (stats_ != nullptr) {
        ++stats_->evaluations;
        stats_->edges_evaluated += static_cast<int64_t>(edges.size());
      }
      if (Refresh(edges, 0)) {
        path = Shortest();
        next = 0;
        batch = 1;
      } else {
        next = first;  // settled now (looked at again in passing), or tighter: checked again
        batch = std::min(2 * batch, kMaxBatch);
      }
    }
  }

 private:
  // The open list's order, LazySearch<false>'s: key, then node and edge ids, so that the path is
  // the same whatever was known before (the tie goes to the lowest edge id into each node).
  struct Worse {
    bool operator()(const LazyEntry& a, const LazyEntry& b) const {
      if (a.key != b.key) return a.key > b.key;
      if (a.node != b.node) return a.node > b.node;
      return a.edge > b.edge;
    }
  };
  double ToGo(int n) const { return cost_to_go_ != nullptr ? (*cost_to_go_)[n] : 0.0; }
  // The search's cost of an edge: its value, infinity where unusable.
  double CostOf(int e) const {
    const double v = see_(e).value;
    return std::isnan(v) ? kInf : v;
  }
  // Refreshes the kept costs of edges[from...]; whether any changed.
  bool Refresh(const std::vector<int>& edges, size_t from) {
    bool changed = false;
    for (size_t k = from; k < edges.size(); ++k) {
      const double fresh = CostOf(edges[k]);
      changed = changed || fresh != cost_[edges[k]];
      cost_[edges[k]] = fresh;
    }
    return changed;
  }

  // A* under the kept costs; an entry is pushed only if it would come out before every entry of
  // its node so far, so each edge is looked at once.
  SearchResult Shortest() {
    const int n = graph_.num_nodes();
    value_.assign(n, kInf);
    via_.assign(n, -1);
    best_edge_.assign(n, -1);
    closed_.assign(n, 0);
    heap_.clear();
    const Worse worse;
    const auto push = [&](const LazyEntry& entry) {
      ++pushes_;
      heap_.push_back(entry);
      std::push_heap(heap_.begin(), heap_.end(), worse);
    };
    push(LazyEntry{.key = ToGo(graph_.start()), .parent_value = 0, .node = graph_.start()});
    while (!heap_.empty()) {
      std::pop_heap(heap_.begin(), heap_.end(), worse);
      const LazyEntry top = heap_.back();
      heap_.pop_back();
      if (closed_[top.node]) continue;
      closed_[top.node] = 1;
      via_[top.node] = top.edge;
      const double g = top.parent_value + (top.edge >= 0 ? cost_[top.edge] : 0.0);
      if (top.node == graph_.goal()) return TracePath(graph_, via_, g);
      for (const auto& [v, e] : graph_.neighbours(top.node)) {
        if (closed_[v]) continue;
        const double ev = cost_[e];
        if (!(ev < kInf)) continue;
        const double key = g + ev + ToGo(v);
        if (key > value_[v] || (key == value_[v] && e >= best_edge_[v])) continue;
        value_[v] = key;
        best_edge_[v] = e;
        push(LazyEntry{.key = key, .parent_value = g, .node = v, .edge = e});
      }
    }
    return SearchResult{};
  }

  const HGraph& graph_;
  const SearchEdgeFn& see_;
  const ExactFn& exact_;
  const EvaluateFn& evaluate_;
  const std::vector<double>* cost_to_go_;
  const double target_;
  LazySearchStats* stats_;
  int64_t pushes_ = 0;
  std::vector<double> cost_;   // per edge
  std::vector<double> value_;  // per node: the key of its best entry so far
  std::vector<int> via_;
  std::vector<int> best_edge_;
  std::vector<char> closed_;
  std::vector<LazyEntry> heap_;
};

// FindBestPathLazy, with a glance or without (null).
SearchResult SearchLazily(const HGraph& graph, const Measure& measure, const SearchEdgeFn& see,
                          const ExactFn& exact, const EvaluateFn& evaluate,
                          const std::vector<double>* cost_to_go,
                          const std::vector<double>* length_to_go, int batch,
                          LazySearchStats* stats, const GlanceFn* glance,
                          GlanceStats* glance_stats) {
  batch = std::max(1, batch);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (measure.combine() == Measure::Combine::kSum && !measure.needs_clearance()) {
    std::optional<SearchResult> found =
        LazyShortestPath(graph, see, exact, evaluate, cost_to_go, measure.clearance_target(), stats)
            .Run();
    if (found) return *std::move(found);
  }
  if (measure.combine() == Measure::Combine::kSum) {
    return LazySearch<false>(graph, see, exact, evaluate, cost_to_go, nullptr, kInf,
                             measure.clearance_target(), batch, stats, glance, glance_stats)
        .Run();
  }
  // The widest path's width W, exactly. Whether W >= t needs of an edge only a proof that it
  // keeps t (cheap where clearance is well above t) or a point below t, never its exact width.
  // So tests at thresholds narrow [lo, hi] around W first: lo the width of a path of proven
  // floors, hi the widest path under the bounds, each test at their geometric mean. Then a
  // search whose widths are capped at hi finds W exactly, and needs exact widths only of the
  // edges narrower than hi, which is then close to W.
  const SearchEdgeFn proven = [&](int e) {
    const SearchEdge s = see(e);
    return SearchEdge{.value = s.floor > 0 ? s.floor : nan, .length = s.length};
  };
  double lo = std::max(0.0, WidestPathValue(graph, proven));
  double hi = WidestPathValue(graph, see);
  if (hi < 0) return SearchResult{};
  for (int test = 0; test < kMaxThresholdTests && hi > lo * kThresholdBracket; ++test) {
    const double tau = lo > 0 ? std::sqrt(lo * hi) : hi / kFirstCapDivisor;
    const SearchEdgeFn at_tau = [&](int e) {
      SearchEdge s = see(e);
      if (!(s.value >= tau)) s.value = nan;
      return s;
    };
    const SearchResult path = LazySearch<true>(graph, at_tau, exact, evaluate, nullptr,
                                               length_to_go, tau, nan, batch, stats)
                                  .Run();
    if (path.found) {
      lo = std::max(tau, WidestPathValue(graph, proven));
    } else {
      hi = tau;
    }
    hi = std::min(hi, WidestPathValue(graph, see));
  }
  const SearchResult widest =
      LazySearch<true>(graph, see, exact, evaluate, nullptr, length_to_go, hi, nan, batch, stats)
          .Run();
  if (!widest.found) return widest;
  // Then the shortest of the widest paths, lazily again: an edge proven that wide is usable at
  // its length.
  const double width = widest.value;
  const SearchEdgeFn among_widest = ShortestAmongWidest(see, width);
  SearchResult result = LazySearch<false>(graph, among_widest, exact, evaluate, length_to_go,
                                          nullptr, kInf, width, batch, stats)
                            .Run();
  if (!result.found) return widest;  // cannot happen: the widest path itself qualifies
  result.value = width;
  return result;
}

}  // namespace

SearchResult FindBestPathLazy(const HGraph& graph, const Measure& measure, const SearchEdgeFn& see,
                              const ExactFn& exact, const EvaluateFn& evaluate,
                              const std::vector<double>* cost_to_go,
                              const std::vector<double>* length_to_go, int batch,
                              LazySearchStats* stats) {
  return SearchLazily(graph, measure, see, exact, evaluate, cost_to_go, length_to_go, batch, stats,
                      nullptr, nullptr);
}

SearchResult FindBestPathLazy(const HGraph& graph, const Measure& measure, const SearchEdgeFn& see,
                              const ExactFn& exact, const EvaluateFn& evaluate,
                              const std::vector<double>* cost_to_go,
                              const std::vector<double>* length_to_go, int batch,
                              LazySearchStats* stats, const GlanceFn& glance,
                              GlanceStats* glance_stats) {
  return SearchLazily(graph, measure, see, exact, evaluate, cost_to_go, length_to_go, batch, stats,
                      &glance, glance_stats);
}

double WidestPathValue(const HGraph& graph, const SearchEdgeFn& edge) {
  std::vector<double> width(graph.num_nodes(), -1.0);
  using Item = std::pair<double, int>;
  std::priority_queue<Item> queue;  // max-heap on width
  width[graph.start()] = kInf;
  queue.emplace(kInf, graph.start());
  while (!queue.empty()) {
    const auto [w, u] = queue.top();
    queue.pop();
    if (w < width[u]) continue;
    if (u == graph.goal()) break;
    for (const auto& [v, e] : graph.neighbours(u)) {
      const double value = edge(e).value;
      if (std::isnan(value)) continue;
      const double nw = std::min(w, value);
      if (nw > width[v]) {
        width[v] = nw;
        queue.emplace(nw, v);
      }
    }
  }
  return width[graph.goal()];
}

SearchResult TracePath(const HGraph& graph, const std::vector<int>& via_edge, double value) {
  SearchResult result;
  int node = graph.goal();
  result.nodes.push_back(node);
  while (node != graph.start()) {
    const int e = via_edge[node];
    HGRAPH_CHECK(e >= 0);
    result.edges.push_back(e);
    const HEdge& edge = graph.edge(e);
    node = edge.u == node ? edge.v : edge.u;
    result.nodes.push_back(node);
  }
  std::reverse(result.nodes.begin(), result.nodes.end());
  std::reverse(result.edges.begin(), result.edges.end());
  result.found = true;
  result.value = value;
  return result;
}

SearchEdgeFn ShortestAmongWidest(SearchEdgeFn see, double width) {
  return [see = std::move(see), width](int e) {
    const SearchEdge s = see(e);
    const double nan = std::numeric_limits<double>::quiet_NaN();
    return SearchEdge{.value = !std::isnan(s.value) && s.value >= width ? s.length : nan,
                      .length = s.length,
                      .floor = s.floor >= width ? s.length : nan,
                      .checked = s.checked};
  };
}

PathQuality EvaluateEdges(const HGraph& graph, const std::vector<int>& edges, double k) {
  QualityAccumulator accumulator(k);
  for (int e : edges) accumulator.Add(graph.edge(e).report);
  return accumulator.Finish();
}

}  // namespace hgraph
