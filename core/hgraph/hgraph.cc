#include "core/hgraph/hgraph.h"

#include <cmath>
#include <cstdio>

#include "core/common/client_text.h"
#include "core/common/error.h"
#include "core/common/limits.h"

namespace hgraph {

HGraph::HGraph(const Space& space, std::vector<InputPath> paths, double endpoint_tolerance,
               double max_node_spacing)
    : paths_(std::move(paths)) {
  if (!std::isfinite(endpoint_tolerance) || endpoint_tolerance < 0) {
    throw InputError("options.endpoint_tolerance", "must be finite and >= 0");
  }
  if (!std::isfinite(max_node_spacing) || max_node_spacing < 0) {
    throw InputError("options.max_node_spacing", "must be finite and >= 0 (0 = off)");
  }
  if (paths_.empty()) throw InputError("paths", "at least one input path is required");
  for (size_t p = 0; p < paths_.size(); ++p) {
    PrepareWaypoints(space, static_cast<int>(p), "paths[" + std::to_string(p) + "]", paths_[p]);
  }
  const Config& start = paths_[0].waypoints.front();
  const Config& goal = paths_[0].waypoints.back();
  for (size_t p = 1; p < paths_.size(); ++p) {
    const InputPath& path = paths_[p];
    const std::string field = "paths[" + std::to_string(p) + "]";
    const double ds = space.Distance(path.waypoints.front(), start);
    if (ds > endpoint_tolerance) {
      throw InputError(field + ".waypoints[0]",
                       "path '" + ClientText(path.name) + "' starts " + std::to_string(ds) +
                           " away from the start of path '" + ClientText(paths_[0].name) +
                           "' (tolerance " + std::to_string(endpoint_tolerance) + ")");
    }
    const double dg = space.Distance(path.waypoints.back(), goal);
    if (dg > endpoint_tolerance) {
      throw InputError(field + ".waypoints[" + std::to_string(path.waypoints.size() - 1) + "]",
                       "path '" + ClientText(path.name) + "' ends " + std::to_string(dg) +
                           " away from the goal of path '" + ClientText(paths_[0].name) +
                           "' (tolerance " + std::to_string(endpoint_tolerance) + ")");
    }
  }

  nodes_.push_back(HNode{.q = start, .path = 0, .index = 0});
  nodes_.push_back(
      HNode{.q = goal, .path = 0, .index = static_cast<int>(paths_[0].waypoints.size()) - 1});
  adjacency_.resize(2);
  for (int p = 0; p < num_paths(); ++p) AppendPath(space, p, max_node_spacing);
}

void HGraph::PrepareWaypoints(const Space& space, int index, const std::string& field,
                              InputPath& path) {
  if (path.name.empty()) path.name = "path" + std::to_string(index);
  if (path.waypoints.size() < 2) {
    throw InputError(field + ".waypoints", "path '" + ClientText(path.name) + "' has " +
                                               std::to_string(path.waypoints.size()) +
                                               " waypoint(s); at least 2 are required");
  }
  for (size_t j = 0; j < path.waypoints.size(); ++j) {
    space.Validate(path.waypoints[j], field + ".waypoints[" + std::to_string(j) + "]");
    path.waypoints[j] = space.Normalize(path.waypoints[j]);
  }
}

int HGraph::AddPath(const Space& space, InputPath path, double endpoint_tolerance,
                    double max_node_spacing, const std::string& field) {
  path = CheckedPath(space, std::move(path), endpoint_tolerance, field);
  paths_.push_back(std::move(path));
  AppendPath(space, num_paths() - 1, max_node_spacing);
  return num_paths() - 1;
}

InputPath HGraph::CheckedPath(const Space& space, InputPath path, double endpoint_tolerance,
                              const std::string& field) const {
  PrepareWaypoints(space, num_paths(), field, path);
  const double ds = space.Distance(path.waypoints.front(), node(start_id()).q);
  if (ds > endpoint_tolerance) {
    throw InputError(field + ".waypoints[0]", "path '" + ClientText(path.name) + "' starts " +
                                                  std::to_string(ds) +
                                                  " away from the H-Graph's start (tolerance " +
                                                  std::to_string(endpoint_tolerance) + ")");
  }
  const double dg = space.Distance(path.waypoints.back(), node(goal_id()).q);
  if (dg > endpoint_tolerance) {
    throw InputError(field + ".waypoints[" + std::to_string(path.waypoints.size() - 1) + "]",
                     "path '" + ClientText(path.name) + "' ends " + std::to_string(dg) +
                         " away from the H-Graph's goal (tolerance " +
                         std::to_string(endpoint_tolerance) + ")");
  }
  return path;
}

double HGraph::EdgeParts(const Space& space, const InputPath& path, size_t j,
                         double max_node_spacing) {
  const double length = space.Distance(path.waypoints[j], path.waypoints[j + 1]);
  const double parts = std::ceil(length / max_node_spacing);
  // A bound on the parts keeps a tiny spacing from exhausting memory; the message says how
  // to stay under it.
  if (parts > kMaxPartsPerEdge) {
    char text[200];
    std::snprintf(text, sizeof(text),
                  "%g would cut edge %zu of path '%.60s' (length %g) into more than %d parts",
                  max_node_spacing, j, path.name.c_str(), length, kMaxPartsPerEdge);
    throw InputError("options.max_node_spacing", text);
  }
  return parts;
}

void HGraph::CheckNodeCount(double nodes, double max_node_spacing) {
  if (nodes > limits::kMaxNodes) {
    throw InputError("options.max_node_spacing",
                     limits::Num(max_node_spacing) + " would give the H-Graph more than " +
                         std::to_string(limits::kMaxNodes) +
                         " nodes; use a larger spacing (or 0 = no subdivision)");
  }
}

int64_t HGraph::CheckNewPaths(const Space& space, const std::vector<InputPath>& paths,
                              double endpoint_tolerance, double max_node_spacing,
                              const std::string& field) const {
  double nodes = num_nodes();
  for (size_t i = 0; i < paths.size(); ++i) {
    const InputPath path =
        CheckedPath(space, paths[i], endpoint_tolerance, field + "[" + std::to_string(i) + "]");
    const size_t n = path.waypoints.size();
    nodes += n >= 2 ? static_cast<double>(n - 2) : 0.0;
    for (size_t j = 0; max_node_spacing > 0 && j + 1 < n; ++j) {
      nodes += EdgeParts(space, path, j, max_node_spacing) - 1;
    }
    CheckNodeCount(nodes, max_node_spacing);
  }
  return static_cast<int64_t>(nodes) - num_nodes();
}

void HGraph::AppendPath(const Space& space, int p, double max_node_spacing) {
  path_nodes_.resize(paths_.size());
  path_edges_.resize(paths_.size());
  {
    const auto& waypoints = paths_[p].waypoints;
    std::vector<int>& ids = path_nodes_[p];
    const auto add_node = [&](HNode node) {
      ids.push_back(num_nodes());
      nodes_.push_back(std::move(node));
      adjacency_.emplace_back();
    };
    ids.push_back(start_id());
    for (size_t j = 0; j + 1 < waypoints.size(); ++j) {
      const int index = static_cast<int>(j);
      if (j > 0) add_node(HNode{.q = waypoints[j], .path = p, .index = index});
      if (max_node_spacing <= 0) continue;
      const double parts = EdgeParts(space, paths_[p], j, max_node_spacing);
      CheckNodeCount(num_nodes() + parts, max_node_spacing);
      for (int k = 1; k < static_cast<int>(parts); ++k) {
        const double t = k / parts;
        add_node(HNode{.q = space.Interpolate(waypoints[j], waypoints[j + 1], t),
                       .path = p,
                       .index = index,
                       .t = t});
      }
    }
    ids.push_back(goal_id());
    for (size_t j = 1; j < ids.size(); ++j) {
      // A path may revisit the start or repeat a node; a self-loop adds nothing to any search.
      if (ids[j - 1] == ids[j]) continue;
      path_edges_[p].push_back(AddEdge(ids[j - 1], ids[j], /*input=*/true));
    }
  }
}

int HGraph::AddNode(const Config& q, int path, int index, double t) {
  HGRAPH_CHECK(path < num_paths());
  nodes_.push_back(HNode{.q = q, .path = path, .index = path < 0 ? -1 : index, .t = t});
  adjacency_.emplace_back();
  return num_nodes() - 1;
}

void HGraph::Truncate(int nodes, int edges) {
  HGRAPH_CHECK(nodes >= 2 && nodes <= num_nodes() && edges >= 0 && edges <= num_edges());
  for (const std::vector<int>& ids : path_nodes_) {
    for (int n : ids) HGRAPH_CHECK(n < nodes);
  }
  for (const std::vector<int>& ids : path_edges_) {
    for (int e : ids) HGRAPH_CHECK(e < edges);
  }
  nodes_.resize(static_cast<size_t>(nodes));
  edges_.resize(static_cast<size_t>(edges));
  adjacency_.resize(static_cast<size_t>(nodes));
  // Each list holds its edges in the order they were added, so the dropped ones are at its end.
  for (auto& list : adjacency_) {
    while (!list.empty() && list.back().second >= edges) list.pop_back();
  }
}

int HGraph::AddEdge(int u, int v, bool input) {
  HGRAPH_CHECK(u != v && u >= 0 && v >= 0 && u < num_nodes() && v < num_nodes());
  const int existing = FindEdge(u, v);
  if (existing >= 0) {
    edges_[existing].input = edges_[existing].input || input;
    return existing;
  }
  const int id = num_edges();
  edges_.push_back(HEdge{.u = u, .v = v, .input = input});
  adjacency_[u].emplace_back(v, id);
  adjacency_[v].emplace_back(u, id);
  return id;
}

int HGraph::FindEdge(int u, int v) const {
  // Scan the shorter list; degrees stay small for every variant but all-pairs.
  const auto& a = adjacency_[u].size() <= adjacency_[v].size() ? adjacency_[u] : adjacency_[v];
  const int other = adjacency_[u].size() <= adjacency_[v].size() ? v : u;
  for (const auto& [n, e] : a) {
    if (n == other) return e;
  }
  return -1;
}

}  // namespace hgraph
