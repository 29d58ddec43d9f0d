#include "core/merge/shortcut.h"

#include <algorithm>
#include <random>

#include "core/common/error.h"
#include "core/measure/measure.h"

namespace hgraph {
namespace {

// The straight motion from a to b if it is proven free (and keeps `safety`), else a report that
// is not valid.
EdgeReport Check(const MotionChecker& checker, const Config& a, const Config& b, double safety,
                 int64_t* checked) {
  ++*checked;
  EdgeReport report = checker.CheckEdge(
      EdgeCheckRequest{.from = &a, .to = &b, .need_clearance = safety > 0, .certify = safety <= 0});
  const bool ok = report.state == EdgeState::kValid && report.certified &&
                  (safety <= 0 || MinClearance(report) >= safety);
  if (!ok) report.state = EdgeState::kInvalid;
  return report;
}

}  // namespace

ShortcutResult ShortcutCertified(const MotionChecker& checker, const ShortcutRequest& request,
                                 const CancelToken& cancel) {
  const Space& space = checker.space();
  ShortcutResult out;
  out.path = request.path;
  std::vector<Config>& q = out.path.waypoints;
  HGRAPH_CHECK(q.size() >= 2);
  std::vector<int>& ids = out.ids;
  ids = request.ids;
  if (ids.size() != q.size()) ids.assign(q.size(), -1);
  std::vector<EdgeReport>& edges = out.edges;
  edges = request.edges;
  if (edges.size() != q.size() - 1) {
    edges.assign(q.size() - 1, EdgeReport{});
    for (size_t j = 0; j + 1 < q.size(); ++j) edges[j].length = space.Distance(q[j], q[j + 1]);
  }

  // Waypoints whose neighbours connect directly.
  for (size_t j = 1; j + 1 < q.size();) {
    cancel.ThrowIfStopped();
    if (space.Distance(q[j - 1], q[j + 1]) >= edges[j - 1].length + edges[j].length) {
      ++j;
      continue;
    }
    EdgeReport joined = Check(checker, q[j - 1], q[j + 1], request.safety, &out.edges_checked);
    if (joined.state != EdgeState::kValid) {
      ++j;
      continue;
    }
    q.erase(q.begin() + static_cast<std::ptrdiff_t>(j));
    ids.erase(ids.begin() + static_cast<std::ptrdiff_t>(j));
    edges.erase(edges.begin() + static_cast<std::ptrdiff_t>(j));
    edges[j - 1] = std::move(joined);
    ++out.accepted;
  }

  // Random pairs of points along the path.
  std::mt19937_64 rng(request.seed);
  const int attempts =
      request.attempts > 0 ? request.attempts : std::max(50, 10 * static_cast<int>(q.size()));
  for (int attempt = 0; attempt < attempts && q.size() >= 2; ++attempt) {
    cancel.ThrowIfStopped();
    double total = 0;
    for (const EdgeReport& e : edges) total += e.length;
    if (total <= 0) break;
    std::uniform_real_distribution<double> position(0.0, total);
    double s0 = position(rng);
    double s1 = position(rng);
    if (s0 > s1) std::swap(s0, s1);
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
    size_t e0 = 0, e1 = 0;
    double t0 = 0, t1 = 0;
    locate(s0, &e0, &t0);
    locate(s1, &e1, &t1);
    if (e0 == e1) continue;  // one straight edge: nothing to gain
    const Config a = space.Interpolate(q[e0], q[e0 + 1], t0);
    const Config b = space.Interpolate(q[e1], q[e1 + 1], t1);
    const double direct = space.Distance(a, b);
    // What the stretch from a to b costs now, along the path.
    double along = (1 - t0) * edges[e0].length + t1 * edges[e1].length;
    for (size_t j = e0 + 1; j < e1; ++j) along += edges[j].length;
    if (direct >= along * (1 - 1e-9)) continue;
    EdgeReport bridge = Check(checker, a, b, request.safety, &out.edges_checked);
    if (bridge.state != EdgeState::kValid) continue;
    // The pieces of the cut edges up to a and from b are parts of motions already accepted:
    // they keep their edge's verdict (a merge profiles its output's edges at the end, which
    // would find anything a sampled check missed).
    const auto piece = [&](const EdgeReport& whole, const Config& from, const Config& to) {
      return EdgeReport{.state = whole.state,
                        .length = space.Distance(from, to),
                        .certified = whole.certified && !whole.has_clearance};
    };
    EdgeReport head = piece(edges[e0], q[e0], a);
    EdgeReport tail = piece(edges[e1], b, q[e1 + 1]);
    std::vector<Config> nq(q.begin(), q.begin() + static_cast<std::ptrdiff_t>(e0 + 1));
    std::vector<int> ni(ids.begin(), ids.begin() + static_cast<std::ptrdiff_t>(e0 + 1));
    std::vector<EdgeReport> ne(edges.begin(), edges.begin() + static_cast<std::ptrdiff_t>(e0));
    // Zero-length pieces (a point at a waypoint) are left out.
    if (head.length > 0) {
      nq.push_back(a);
      ni.push_back(-1);
      ne.push_back(std::move(head));
    }
    ne.push_back(std::move(bridge));
    if (tail.length > 0) {
      nq.push_back(b);
      ni.push_back(-1);
      ne.push_back(std::move(tail));
    }
    nq.insert(nq.end(), q.begin() + static_cast<std::ptrdiff_t>(e1 + 1), q.end());
    ni.insert(ni.end(), ids.begin() + static_cast<std::ptrdiff_t>(e1 + 1), ids.end());
    ids = std::move(ni);
    ne.insert(ne.end(), edges.begin() + static_cast<std::ptrdiff_t>(e1 + 1), edges.end());
    q = std::move(nq);
    edges = std::move(ne);
    ++out.accepted;
  }
  return out;
}

}  // namespace hgraph
