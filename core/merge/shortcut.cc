#include "core/merge/shortcut.h"

#include <algorithm>
#include <numeric>
#include <random>

#include "core/common/error.h"
#include "core/common/parallel.h"
#include "core/measure/measure.h"

namespace hgraph {
namespace {

// The check of the straight motion from a to b: certified, with a clearance profile when a
// safety clearance must be kept. Without one, a motion whose certificate stalls (it grazes an
// obstacle) is given up at once (kCertifiedQuick): only proven motions are taken, and the random
// pairs and corners offer others. On the 21 kept benchmark problems (hgraph-bench seeds 1-3,
// defaults, one thread) this took the post-optimization's cost from 613k to 576k (collision
// checks + 10 x distance queries) and the merges' time by 8%, for a geometric mean of the length
// ratios to OMPL of 0.9446 against 0.9443. With `lazy` (ShortcutRequest::lazy), at the samples
// only.
EdgeReport Check(const MotionChecker& checker, const Config& a, const Config& b, double safety,
                 bool lazy) {
  return checker.CheckEdge(EdgeCheckRequest{.from = &a,
                                            .to = &b,
                                            .proof = safety > 0 ? EdgeProof::kProfile
                                                     : lazy     ? EdgeProof::kSamples
                                                                : EdgeProof::kCertificateOrGiveUp});
}

// Whether a path may take the motion: proven free (and keeping `safety`), or with `lazy` valid at
// its samples.
bool MayTake(const EdgeReport& report, double safety, bool lazy) {
  return report.state == EdgeState::kValid && (report.certified || lazy) && report.usable() &&
         (safety <= 0 || (report.has_clearance && MinClearance(report) >= safety));
}

// The stretch of an accepted motion (`whole`) from `from` to `to`: it keeps the motion's verdict
// (a merge profiles its output's edges at the end, which would find anything a sampled check
// missed); a certificate holds for every stretch of the motion, a profile does not map onto one.
EdgeReport Piece(const Space& space, const EdgeReport& whole, const Config& from,
                 const Config& to) {
  return EdgeReport{.state = whole.state,
                    .length = space.Distance(from, to),
                    .certified = whole.certified && !whole.has_clearance};
}

double PathLength(const std::vector<EdgeReport>& edges) {
  double total = 0;
  for (const EdgeReport& e : edges) total += e.length;
  return total;
}

// Random pairs tried per pass by default: this many per waypoint, at least kMinAttempts. With
// the merge's rounds (each re-hybridized, then a polish of corner cuts), 5 and 30 did as well as
// 10 and 50 for 11% less work on the 14 kept benchmark problems (hgraph-bench seeds 1 and 2:
// collision checks + 10 x distance queries 524k against 589k before the polish; lengths, as a
// geometric mean of the ratios to the best OMPL pipeline, 0.942 against 0.946).
constexpr int kAttemptsPerWaypoint = 5;
constexpr int kMinAttempts = 30;
// The smallest fraction of an edge a corner cut tries, and the least a cut must be able to gain,
// as a fraction of the path's length, to be checked at all (a cut f of the way gains about f
// times the f = 1 cut, so flat corners and small fractions are skipped). On the 14 kept
// benchmark problems 1e-4 took the polish's cost from 524k to 433k (collision checks + 10 x
// distance queries) for a geometric mean of the length ratios to OMPL of 0.9429 against 0.9423;
// 3e-4: 406k, 0.9439; 1e-3: 387k, 0.9468.
constexpr double kMinCornerCut = 1.0 / 16;
constexpr double kMinCornerGain = 1e-4;

// A random shortcut of a batch: from a (fraction t0 of edge e0) to b (t1 of edge e1), straight
// or through `points` (a partial shortcut's waypoints), what it gains, and the checks of its
// motions in order, up to the first one not proven free.
struct Candidate {
  size_t e0 = 0;
  size_t e1 = 0;
  double t0 = 0;
  double t1 = 0;
  Config a;
  Config b;
  std::vector<Config> points;
  double gain = 0;
  std::vector<EdgeReport> reports;
  bool free = false;
};

// What the three phases of ShortcutCertified share: the request, and the path being shortened
// (ShortcutResult's path, ids, sources and edges, kept in step).
struct Shortening {
  const MotionChecker& checker;
  const ShortcutRequest& request;
  const CancelToken& cancel;
  const Space& space;
  int threads;
  bool lazy;
  ShortcutResult& out;
};

// Phase 1: waypoints dropped where their neighbours connect.
void DropWaypoints(const Shortening& shortening) {
  const MotionChecker& checker = shortening.checker;
  const ShortcutRequest& request = shortening.request;
  const CancelToken& cancel = shortening.cancel;
  const Space& space = shortening.space;
  const int threads = shortening.threads;
  const bool lazy = shortening.lazy;
  ShortcutResult& out = shortening.out;
  std::vector<Config>& q = shortening.out.path.waypoints;
  std::vector<int>& ids = shortening.out.ids;
  std::vector<WaypointSource>& sources = shortening.out.sources;
  std::vector<EdgeReport>& edges = shortening.out.edges;
  // Waypoints whose neighbours connect directly. A pass checks every waypoint not yet settled
  // and drops those whose check passed, left to right, never two neighbours (the second one's
  // check joined a waypoint the first one removed); a drop unsettles the neighbours.
  std::vector<char> settled(q.size(), request.corners_only ? 1 : 0);
  for (;;) {
    cancel.ThrowIfStopped();
    std::vector<size_t> tried;
    for (size_t j = 1; j + 1 < q.size(); ++j) {
      if (settled[j]) continue;
      if (space.Distance(q[j - 1], q[j + 1]) >= edges[j - 1].length + edges[j].length) {
        settled[j] = 1;
        continue;
      }
      tried.push_back(j);
    }
    if (tried.empty()) break;
    std::vector<EdgeReport> joined(tried.size());
    std::vector<char> from_caller(tried.size(), 0);
    for (size_t k = 0; k < tried.size(); ++k) {
      const size_t j = tried[k];
      if (!request.known || ids[j - 1] < 0 || ids[j + 1] < 0) continue;
      const EdgeReport* known = request.known(ids[j - 1], ids[j + 1]);
      // Taken when it settles the question: free, or not free whatever the safety.
      if (known == nullptr || (!MayTake(*known, request.safety, lazy) &&
                               known->state != EdgeState::kInvalid && known->usable())) {
        continue;
      }
      joined[k] = *known;
      from_caller[k] = 1;
    }
    ParallelFor(threads, tried.size(), [&](size_t k) {
      if (from_caller[k] || cancel.stopped()) return;
      const size_t j = tried[k];
      joined[k] = Check(checker, q[j - 1], q[j + 1], request.safety, lazy);
    });
    cancel.ThrowIfStopped();
    std::vector<size_t> drops;
    std::vector<EdgeReport> drop_reports;
    for (size_t k = 0; k < tried.size(); ++k) {
      const size_t j = tried[k];
      if (!from_caller[k]) {
        ++out.edges_checked;
        if (ids[j - 1] >= 0 && ids[j + 1] >= 0) {
          out.id_checks.emplace_back(ids[j - 1], ids[j + 1], joined[k]);
        }
      }
      settled[j] = 1;
      if (!MayTake(joined[k], request.safety, lazy)) continue;
      if (!drops.empty() && drops.back() + 1 == j) {
        settled[j] = 0;  // its left neighbour goes: try again with the new one
        continue;
      }
      drops.push_back(j);
      drop_reports.push_back(std::move(joined[k]));
    }
    for (size_t d = drops.size(); d-- > 0;) {
      const size_t j = drops[d];
      q.erase(q.begin() + static_cast<std::ptrdiff_t>(j));
      ids.erase(ids.begin() + static_cast<std::ptrdiff_t>(j));
      sources.erase(sources.begin() + static_cast<std::ptrdiff_t>(j));
      edges.erase(edges.begin() + static_cast<std::ptrdiff_t>(j));
      edges[j - 1] = std::move(drop_reports[d]);
      settled.erase(settled.begin() + static_cast<std::ptrdiff_t>(j));
      settled[j - 1] = 0;
      settled[j] = 0;
      ++out.accepted;
    }
  }
}

// Phase 2: seeded random pairs of points along the path, some of them partial shortcuts.
void TryRandomPairs(const Shortening& shortening) {
  const MotionChecker& checker = shortening.checker;
  const ShortcutRequest& request = shortening.request;
  const CancelToken& cancel = shortening.cancel;
  const Space& space = shortening.space;
  const int threads = shortening.threads;
  const bool lazy = shortening.lazy;
  ShortcutResult& out = shortening.out;
  std::vector<Config>& q = shortening.out.path.waypoints;
  std::vector<int>& ids = shortening.out.ids;
  std::vector<WaypointSource>& sources = shortening.out.sources;
  std::vector<EdgeReport>& edges = shortening.out.edges;
  // Random pairs of points along the path, a batch at a time.
  std::mt19937_64 rng(request.seed);
  const std::vector<Space::Part> parts = space.Parts();
  std::uniform_real_distribution<double> share(0.0, 1.0);
  const int attempts =
      request.corners_only ? 0
      : request.attempts > 0
          ? request.attempts
          : std::max(kMinAttempts, kAttemptsPerWaypoint * static_cast<int>(q.size()));
  for (int attempt = 0; attempt < attempts && q.size() >= 2;) {
    cancel.ThrowIfStopped();
    const double total = PathLength(edges);
    if (total <= 0) break;
    std::uniform_real_distribution<double> position(0.0, total);
    // Edge index and fraction of a position along the path.
    const auto locate = [&](double s, size_t* edge, double* t) {
      double at = 0;
      for (size_t j = 0; j < edges.size(); ++j) {
        if (s <= at + edges[j].length || j + 1 == edges.size()) {
          *edge = j;
          *t = edges[j].length > 0 ? std::clamp((s - at) / edges[j].length, 0.0, 1.0) : 0.0;
          return;
        }
        at += edges[j].length;
      }
    };
    std::vector<Candidate> batch;
    for (int drawn = 0; drawn < kShortcutBatch && attempt < attempts; ++drawn, ++attempt) {
      const bool partial = request.partial > 0 && parts.size() >= 2 && share(rng) < request.partial;
      double s0 = position(rng);
      double s1 = position(rng);
      if (s0 > s1) std::swap(s0, s1);
      Candidate c;
      locate(s0, &c.e0, &c.t0);
      locate(s1, &c.e1, &c.t1);
      const double t0 = c.t0;
      const double t1 = c.t1;
      if (c.e0 == c.e1) continue;  // one straight edge: nothing to gain
      c.a = space.Interpolate(q[c.e0], q[c.e0 + 1], t0);
      c.b = space.Interpolate(q[c.e1], q[c.e1 + 1], t1);
      // What the stretch from a to b costs now, along the path.
      double along = (1 - t0) * edges[c.e0].length + t1 * edges[c.e1].length;
      for (size_t j = c.e0 + 1; j < c.e1; ++j) along += edges[j].length;
      double cost = 0;
      if (partial && along > 0) {
        // The part moves straight from a to b, as far along at each waypoint as the path is.
        const Space::Part part =
            parts[std::uniform_int_distribution<size_t>(0, parts.size() - 1)(rng)];
        double at = (1 - t0) * edges[c.e0].length;
        const Config* previous = &c.a;
        c.points.reserve(c.e1 - c.e0);
        for (size_t j = c.e0 + 1; j <= c.e1; ++j) {
          Config m = q[j];
          m.segment(part.offset, part.size) =
              space.Interpolate(c.a, c.b, at / along).segment(part.offset, part.size);
          cost += space.Distance(*previous, m);
          c.points.push_back(std::move(m));
          previous = &c.points.back();
          at += edges[j].length;
        }
        cost += space.Distance(*previous, c.b);
      } else {
        cost = space.Distance(c.a, c.b);
      }
      if (cost >= along * (1 - 1e-9)) continue;
      c.gain = along - cost;
      batch.push_back(std::move(c));
    }
    if (batch.empty()) continue;
    ParallelFor(threads, batch.size(), [&](size_t k) {
      Candidate& c = batch[k];
      for (size_t j = 0; j <= c.points.size(); ++j) {
        if (cancel.stopped()) return;
        const Config& from = j == 0 ? c.a : c.points[j - 1];
        const Config& to = j < c.points.size() ? c.points[j] : c.b;
        c.reports.push_back(Check(checker, from, to, request.safety, lazy));
        if (!MayTake(c.reports.back(), request.safety, lazy)) return;
      }
      c.free = true;
    });
    cancel.ThrowIfStopped();
    for (const Candidate& c : batch) out.edges_checked += static_cast<int64_t>(c.reports.size());
    // The free ones that gain most, no two sharing an edge of the path; applied from the end of
    // the path so that the edge indices of the others stay valid.
    std::vector<size_t> order(batch.size());
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(),
                     [&](size_t x, size_t y) { return batch[x].gain > batch[y].gain; });
    std::vector<size_t> taken;
    for (size_t k : order) {
      if (!batch[k].free) continue;
      const bool overlaps = std::any_of(taken.begin(), taken.end(), [&](size_t o) {
        return !(batch[k].e1 < batch[o].e0 || batch[o].e1 < batch[k].e0);
      });
      if (!overlaps) taken.push_back(k);
    }
    std::sort(taken.begin(), taken.end(),
              [&](size_t x, size_t y) { return batch[x].e0 > batch[y].e0; });
    for (size_t k : taken) {
      Candidate& c = batch[k];
      // The cut edges' pieces up to a and from b.
      EdgeReport head = Piece(space, edges[c.e0], q[c.e0], c.a);
      EdgeReport tail = Piece(space, edges[c.e1], c.b, q[c.e1 + 1]);
      std::vector<Config> nq(q.begin(), q.begin() + static_cast<std::ptrdiff_t>(c.e0 + 1));
      std::vector<int> ni(ids.begin(), ids.begin() + static_cast<std::ptrdiff_t>(c.e0 + 1));
      std::vector<WaypointSource> ns(sources.begin(),
                                     sources.begin() + static_cast<std::ptrdiff_t>(c.e0 + 1));
      std::vector<EdgeReport> ne(edges.begin(), edges.begin() + static_cast<std::ptrdiff_t>(c.e0));
      // Zero-length pieces (a point at a waypoint) are left out.
      if (head.length > 0) {
        nq.push_back(c.a);
        ni.push_back(-1);
        ns.push_back(SourceBetween(sources[c.e0], sources[c.e0 + 1], c.t0));
        ne.push_back(std::move(head));
      }
      for (size_t j = 0; j < c.points.size(); ++j) {
        nq.push_back(std::move(c.points[j]));
        ni.push_back(-1);
        ns.emplace_back();
        ne.push_back(std::move(c.reports[j]));
      }
      ne.push_back(std::move(c.reports.back()));
      if (tail.length > 0) {
        nq.push_back(c.b);
        ni.push_back(-1);
        ns.push_back(SourceBetween(sources[c.e1], sources[c.e1 + 1], c.t1));
        ne.push_back(std::move(tail));
      }
      nq.insert(nq.end(), q.begin() + static_cast<std::ptrdiff_t>(c.e1 + 1), q.end());
      ni.insert(ni.end(), ids.begin() + static_cast<std::ptrdiff_t>(c.e1 + 1), ids.end());
      ns.insert(ns.end(), sources.begin() + static_cast<std::ptrdiff_t>(c.e1 + 1), sources.end());
      ne.insert(ne.end(), edges.begin() + static_cast<std::ptrdiff_t>(c.e1 + 1), edges.end());
      q = std::move(nq);
      ids = std::move(ni);
      sources = std::move(ns);
      edges = std::move(ne);
      ++out.accepted;
    }
  }
}

// Phase 3 (corners_only): every corner cut where a cut is proven free.
void CutCorners(const Shortening& shortening) {
  const MotionChecker& checker = shortening.checker;
  const ShortcutRequest& request = shortening.request;
  const CancelToken& cancel = shortening.cancel;
  const Space& space = shortening.space;
  const int threads = shortening.threads;
  const bool lazy = shortening.lazy;
  ShortcutResult& out = shortening.out;
  std::vector<Config>& q = shortening.out.path.waypoints;
  std::vector<int>& ids = shortening.out.ids;
  std::vector<WaypointSource>& sources = shortening.out.sources;
  std::vector<EdgeReport>& edges = shortening.out.edges;
  // Corners cut (corners_only): each interior waypoint is replaced by two points on its edges, a
  // fraction f of each edge away from it (f = 1/2, 1/4, ..., the largest proven free), joined by
  // a straight motion. Near obstacles random pairs rarely land on both sides of one corner; this
  // is where a path tightens around them. f <= 1/2 keeps the cuts of neighbouring corners apart,
  // so every corner is tried at once.
  cancel.ThrowIfStopped();
  struct Cut {
    Config a;
    Config b;
    double f = 0;
    EdgeReport report;
    bool free = false;
    int checks = 0;
  };
  std::vector<Cut> cuts(q.size());
  const double least_gain = kMinCornerGain * PathLength(edges);
  ParallelFor(threads, q.size() - 2, [&](size_t k) {
    const size_t j = k + 1;
    if (cancel.stopped()) return;
    for (double f = 0.5; f >= kMinCornerCut; f /= 2) {
      Cut& cut = cuts[j];
      cut.f = f;
      cut.a = space.Interpolate(q[j], q[j - 1], f);
      cut.b = space.Interpolate(q[j], q[j + 1], f);
      if (space.Distance(cut.a, cut.b) >=
          f * (edges[j - 1].length + edges[j].length) * (1 - 1e-9) - least_gain) {
        return;  // a straight corner, or a cut too small to matter
      }
      cut.report = Check(checker, cut.a, cut.b, request.safety, lazy);
      ++cut.checks;
      cut.free = MayTake(cut.report, request.safety, lazy);
      if (cut.free) return;
    }
  });
  cancel.ThrowIfStopped();
  std::vector<Config> nq{q.front()};
  std::vector<int> ni{ids.front()};
  std::vector<WaypointSource> ns{sources.front()};
  std::vector<EdgeReport> ne;
  // Edge j - 1 of the path, from the previous corner's cut (if any) to this one's (if any): the
  // edge itself, or a piece of it.
  const auto add_edge = [&](size_t j, const Config& to) {
    const bool whole = !cuts[j - 1].free && !cuts[j].free;
    ne.push_back(whole ? edges[j - 1] : Piece(space, edges[j - 1], nq.back(), to));
  };
  for (size_t j = 1; j + 1 < q.size(); ++j) {
    out.edges_checked += cuts[j].checks;
    if (!cuts[j].free) {
      add_edge(j, q[j]);
      nq.push_back(q[j]);
      ni.push_back(ids[j]);
      ns.push_back(sources[j]);
      continue;
    }
    // Two cuts at the middle of one edge meet there: the point is kept once.
    if (space.Distance(nq.back(), cuts[j].a) > 0) {
      add_edge(j, cuts[j].a);
      nq.push_back(cuts[j].a);
      ni.push_back(-1);
      ns.push_back(SourceBetween(sources[j], sources[j - 1], cuts[j].f));
    }
    ne.push_back(std::move(cuts[j].report));
    nq.push_back(cuts[j].b);
    ni.push_back(-1);
    ns.push_back(SourceBetween(sources[j], sources[j + 1], cuts[j].f));
    ++out.accepted;
  }
  add_edge(q.size() - 1, q.back());
  nq.push_back(q.back());
  ni.push_back(ids.back());
  ns.push_back(sources.back());
  q = std::move(nq);
  ids = std::move(ni);
  sources = std::move(ns);
  edges = std::move(ne);
}

}  // namespace

WaypointSource SourceBetween(const WaypointSource& a, const WaypointSource& b, double t) {
  if (a.path < 0 || a.path != b.path) return {};
  // A waypoint at the start of input edge i (t = 0) is also the end of edge i - 1.
  int index = a.index;
  double from = a.t;
  double to = 0;
  if (b.index == a.index) {
    to = b.t;
  } else if (b.index == a.index + 1 && b.t == 0) {
    to = 1;
  } else if (a.index == b.index + 1 && a.t == 0) {
    index = b.index;
    from = 1;
    to = b.t;
  } else {
    return {};
  }
  const double at = from + t * (to - from);
  if (at >= 1) return WaypointSource{.path = a.path, .index = index + 1, .t = 0};
  return WaypointSource{.path = a.path, .index = index, .t = std::max(0.0, at)};
}

ShortcutResult ShortcutCertified(const MotionChecker& checker, const ShortcutRequest& request,
                                 const CancelToken& cancel) {
  const Space& space = checker.space();
  const int threads = request.threads == 0 ? DefaultConcurrency() : std::max(1, request.threads);
  const bool lazy = request.lazy && request.safety <= 0;
  ShortcutResult out;
  out.path = request.path;
  std::vector<Config>& q = out.path.waypoints;
  HGRAPH_CHECK(q.size() >= 2);
  std::vector<int>& ids = out.ids;
  ids = request.ids;
  if (ids.size() != q.size()) ids.assign(q.size(), -1);
  std::vector<WaypointSource>& sources = out.sources;
  sources = request.sources;
  if (sources.size() != q.size()) sources.assign(q.size(), WaypointSource{});
  std::vector<EdgeReport>& edges = out.edges;
  edges = request.edges;
  if (edges.size() != q.size() - 1) {
    edges.assign(q.size() - 1, EdgeReport{});
    for (size_t j = 0; j + 1 < q.size(); ++j) edges[j].length = space.Distance(q[j], q[j + 1]);
  }

  const Shortening shortening{.checker = checker,
                              .request = request,
                              .cancel = cancel,
                              .space = space,
                              .threads = threads,
                              .lazy = lazy,
                              .out = out};
  DropWaypoints(shortening);
  TryRandomPairs(shortening);
  if (request.corners_only && q.size() >= 3) CutCorners(shortening);
  return out;
}

}  // namespace hgraph
