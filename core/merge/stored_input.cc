#include "core/merge/stored_input.h"

#include <algorithm>

#include "core/common/error.h"

namespace hgraph {
namespace {

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

// Whether only the length of a motion is known to the report: not checked by this lazy merge,
// or, under a measure of clearance, found valid but not profiled.
bool LengthOnly(const EdgeReport& report, bool needs_clearance) {
  return report.state == EdgeState::kUnchecked ||
         (needs_clearance && report.state == EdgeState::kValid && !report.has_clearance);
}

}  // namespace

InputReport ReportStoredInput(const HGraph& graph, const Space& space,
                              const std::vector<double>& edge_length, int p, bool needs_clearance,
                              double k) {
  const InputPath& input = graph.path(p);
  const std::vector<int>& ids = graph.path_nodes(p);
  // One report per edge of the input (from waypoint j to j + 1), joined from the H-Graph edges
  // subdivision cut it into; nullptr where the input does not move in the H-Graph.
  std::vector<std::vector<EdgePart>> parts(std::max<size_t>(input.waypoints.size(), 2) - 1);
  std::vector<std::vector<EdgeReport>> estimated(parts.size());
  bool checked = true;
  for (size_t j = 0; j + 1 < ids.size(); ++j) {
    if (ids[j] == ids[j + 1]) continue;
    const int e = graph.FindEdge(ids[j], ids[j + 1]);
    HGRAPH_CHECK(e >= 0);
    const HNode& from = graph.node(ids[j]);
    const HNode& to = graph.node(ids[j + 1]);
    // The shared start and goal nodes carry path 0's indices.
    const int index = j == 0 ? 0 : from.index;
    const double t1 = (j + 2 == ids.size() || to.t == 0) ? 1.0 : to.t;
    const EdgeReport* report = &graph.edge(e).report;
    if (LengthOnly(*report, needs_clearance)) {
      checked = false;
      estimated[index].push_back(EdgeReport{.state = EdgeState::kValid, .length = edge_length[e]});
    }
    parts[index].push_back(EdgePart{.report = report,
                                    .reversed = graph.edge(e).u != ids[j],
                                    .t0 = j == 0 ? 0.0 : from.t,
                                    .t1 = t1});
  }
  std::vector<EdgeReport> joined(parts.size());
  std::vector<const EdgeReport*> edges(parts.size(), nullptr);
  for (size_t j = 0; j < parts.size(); ++j) {
    if (parts[j].empty()) continue;
    size_t next_estimate = 0;
    for (EdgePart& part : parts[j]) {
      if (LengthOnly(*part.report, needs_clearance)) {
        part.report = &estimated[j][next_estimate++];
      }
    }
    joined[j] = JoinParts(parts[j]);
    edges[j] = &joined[j];
  }
  InputReport report = ReportInputPath(space, graph.path(p), edges, k);
  report.checked = checked;
  if (!checked) report.certified = false;
  return report;
}

}  // namespace hgraph
