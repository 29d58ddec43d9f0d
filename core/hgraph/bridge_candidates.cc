#include "core/hgraph/bridge_candidates.h"

#include <algorithm>
#include <cmath>
#include <unordered_set>

#include "core/common/client_text.h"
#include "core/common/error.h"
#include "core/hgraph/alignment.h"

namespace hgraph {
namespace {

// Collects unordered pairs once each, skipping self pairs and pairs already joined by an edge.
class PairCollector {
 public:
  explicit PairCollector(const HGraph& graph) : graph_(graph) {}

  void Add(int u, int v) {
    if (u == v) return;
    if (u > v) std::swap(u, v);
    const uint64_t key = (static_cast<uint64_t>(u) << 32) | static_cast<uint32_t>(v);
    if (!seen_.insert(key).second) return;
    if (graph_.FindEdge(u, v) >= 0) return;
    pairs_.emplace_back(u, v);
  }
  // A pair u < v that no other call adds (all-pairs and neighborhood visit each pair once): no
  // duplicate test, which costs more than the rest for millions of pairs.
  void AddOnce(int u, int v) {
    if (graph_.FindEdge(u, v) < 0) pairs_.emplace_back(u, v);
  }
  std::vector<std::pair<int, int>> Take() { return std::move(pairs_); }

 private:
  const HGraph& graph_;
  std::unordered_set<uint64_t> seen_;
  std::vector<std::pair<int, int>> pairs_;
};

// Bridges suggested by the alignment of paths a and b (paper, "Using Path Matching to Speed Up
// the Construction of H-Graphs"): every matched pair, and every node in a gap to the two nodes
// of the other path that bound the gap. At most 2 (|a| + |b|) pairs.
void AddAlignmentBridges(const HGraph& graph, const Space& space, int a, int b, double gap_init,
                         double gap_extend, double radius, PairCollector& out) {
  const std::vector<int>& pa = graph.path_nodes(a);
  const std::vector<int>& pb = graph.path_nodes(b);
  const auto delta = [&](int i, int j) {
    return space.Distance(graph.node(pa[i]).q, graph.node(pb[j]).q);
  };
  const Alignment alignment = AlignPaths(static_cast<int>(pa.size()), static_cast<int>(pb.size()),
                                         delta, gap_init, gap_extend);
  const auto add = [&](int u, int v) {
    if (radius > 0 && space.Distance(graph.node(u).q, graph.node(v).q) > radius) return;
    out.Add(u, v);
  };
  const auto& columns = alignment.columns;
  const int count = static_cast<int>(columns.size());
  // last_i / last_j: the latest node of each path seen to the left of the current column.
  int last_i = -1, last_j = -1;
  for (int c = 0; c < count; ++c) {
    const AlignmentColumn& col = columns[c];
    if (col.i >= 0 && col.j >= 0) {
      add(pa[col.i], pb[col.j]);
    } else {
      const bool gap_in_b = col.j < 0;  // a node of a against a gap
      // The next node of the other path to the right of the gap.
      int next = -1;
      for (int k = c + 1; k < count && next < 0; ++k) next = gap_in_b ? columns[k].j : columns[k].i;
      const int node = gap_in_b ? pa[col.i] : pb[col.j];
      const std::vector<int>& other = gap_in_b ? pb : pa;
      const int before = gap_in_b ? last_j : last_i;
      if (before >= 0) add(node, other[before]);
      if (next >= 0) add(node, other[next]);
    }
    if (col.i >= 0) last_i = col.i;
    if (col.j >= 0) last_j = col.j;
  }
}

}  // namespace

const char* VariantName(Variant variant) {
  switch (variant) {
    case Variant::kAllPairs: return "all-pairs";
    case Variant::kNeighborhood: return "neighborhood";
    case Variant::kKNearest: return "knn";
    case Variant::kEditDistance: return "edit-distance";
    case Variant::kEditDistanceNeighborhood: return "edit-distance-neighborhood";
  }
  return "?";
}

Variant ParseVariant(const std::string& name, const std::string& field) {
  for (Variant v : {Variant::kAllPairs, Variant::kNeighborhood, Variant::kKNearest,
                    Variant::kEditDistance, Variant::kEditDistanceNeighborhood}) {
    if (name == VariantName(v)) return v;
  }
  throw InputError(field, "unknown variant '" + ClientText(name) +
                              "' (expected all-pairs, neighborhood, knn, edit-distance or "
                              "edit-distance-neighborhood)");
}

void ValidateCandidateOptions(const CandidateOptions& options) {
  if (!std::isfinite(options.radius)) throw InputError("options.radius", "must be finite");
  if (options.phi < 1) {
    throw InputError("options.phi", "must be >= 1, got " + std::to_string(options.phi));
  }
  if (!std::isfinite(options.gap_init)) throw InputError("options.gap_init", "must be finite");
  if (!std::isfinite(options.gap_extend)) throw InputError("options.gap_extend", "must be finite");
}

double MeanInputEdgeLength(const HGraph& graph, const Space& space) {
  double total = 0;
  int count = 0;
  // The inputs' own waypoints, not the nodes subdivision adds: the automatic parameters keep
  // their scale when the H-Graph is made denser.
  for (int p = 0; p < graph.num_paths(); ++p) {
    const std::vector<Config>& waypoints = graph.path(p).waypoints;
    for (size_t j = 0; j + 1 < waypoints.size(); ++j) {
      total += space.Distance(waypoints[j], waypoints[j + 1]);
      ++count;
    }
  }
  return count > 0 ? total / count : 0.0;
}

double NewNodeReach(const HGraph& graph, const Space& space, double radius) {
  return radius > 0 ? radius : 2 * MeanInputEdgeLength(graph, space);
}

CandidateOptions Resolved(const CandidateOptions& options, const CandidateSet& set) {
  CandidateOptions out = options;
  out.radius = set.radius;
  out.gap_init = set.gap_init;
  out.gap_extend = set.gap_extend;
  return out;
}

CandidateSet BridgeCandidates(const HGraph& graph, const Space& space,
                              const CandidateOptions& options, CandidatesSince since,
                              const CancelToken* cancel) {
  const auto poll = [cancel] {
    if (cancel != nullptr) cancel->ThrowIfStopped();
  };
  ValidateCandidateOptions(options);
  CandidateSet set;
  const double scale = MeanInputEdgeLength(graph, space);
  set.radius = options.radius > 0 ? options.radius : 2.0 * scale;
  set.gap_extend = options.gap_extend >= 0 ? options.gap_extend : scale;
  set.gap_init = options.gap_init >= 0 ? options.gap_init : 2.0 * set.gap_extend;
  PairCollector out(graph);
  const int n = graph.num_nodes();
  switch (options.variant) {
    case Variant::kAllPairs:
      for (int u = 0; u < n; ++u) {
        poll();
        for (int v = std::max(u + 1, since.nodes); v < n; ++v) out.AddOnce(u, v);
      }
      break;
    case Variant::kNeighborhood:
      for (int u = 0; u < n; ++u) {
        poll();
        for (int v = std::max(u + 1, since.nodes); v < n; ++v) {
          if (space.Distance(graph.node(u).q, graph.node(v).q) <= set.radius) out.AddOnce(u, v);
        }
      }
      break;
    case Variant::kKNearest: {
      std::vector<std::pair<double, int>> near;
      for (int u = 0; u < n; ++u) {
        poll();
        near.clear();
        for (int v = 0; v < n; ++v) {
          if (v != u) near.emplace_back(space.Distance(graph.node(u).q, graph.node(v).q), v);
        }
        const int keep = std::min<int>(options.phi, static_cast<int>(near.size()));
        std::partial_sort(near.begin(), near.begin() + keep, near.end());
        for (int k = 0; k < keep; ++k) {
          if (u >= since.nodes || near[k].second >= since.nodes) out.Add(u, near[k].second);
        }
      }
      break;
    }
    case Variant::kEditDistance:
    case Variant::kEditDistanceNeighborhood: {
      const double radius =
          options.variant == Variant::kEditDistanceNeighborhood ? set.radius : 0.0;
      for (int a = 0; a < graph.num_paths(); ++a) {
        for (int b = std::max(a + 1, since.paths); b < graph.num_paths(); ++b) {
          poll();
          AddAlignmentBridges(graph, space, a, b, set.gap_init, set.gap_extend, radius, out);
          ++set.alignments;
        }
      }
      break;
    }
  }
  set.pairs = out.Take();
  return set;
}

}  // namespace hgraph
