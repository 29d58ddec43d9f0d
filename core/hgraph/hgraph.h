// The Hybridization Graph (paper, "Hybridization Graph between Multiple Motion Paths"): the
// union of the input paths (start and goal shared), plus bridge edges between and within paths.
// Edges keep their local-planner report, never a cost for one measure, so a stored H-Graph can be
// searched again under any measure.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "core/motion/motion_checker.h"
#include "core/path/path.h"
#include "core/space/space.h"

namespace hgraph {

// A node: a configuration and where it came from. The shared start and goal come from path 0.
// A node added by subdivision lies on the input edge (index, index + 1) at fraction t in (0, 1);
// an input waypoint has t = 0.
struct HNode {
  Config q;
  int path = 0;
  int index = 0;
  double t = 0;
};

// An edge and what the local planner found about it (state kUnchecked until checked).
struct HEdge {
  int u = 0;
  int v = 0;
  bool input = false;  // an edge of an input path (else a bridge)
  EdgeReport report;
};

// Copyable and movable; not thread safe for writes (edges are filled in by the builder, which
// writes each edge's report from exactly one worker).
class SessionSnapshot;  // core/merge/snapshot.cc

class HGraph {
 public:
  // The most nodes subdivision puts on one input edge.
  static constexpr int kMaxPartsPerEdge = 10000;

  // Validates every waypoint against the space (InputError naming "paths[i].waypoints[j]"),
  // requires at least one path of at least two waypoints, and shared endpoints: a path whose
  // first (last) waypoint is farther than endpoint_tolerance from path 0's is rejected with an
  // InputError naming it. Quaternions are normalised. Adds every input edge, unchecked.
  //
  // max_node_spacing > 0 subdivides every input edge longer than it into equal parts no longer
  // than it (nodes on the input's own straight motion, so the inputs are unchanged as motions):
  // bridges can then leave an input in the middle of a long edge, not only at its waypoints.
  // 0 keeps the waypoints only.
  HGraph(const Space& space, std::vector<InputPath> paths, double endpoint_tolerance,
         double max_node_spacing = 0);

  // Adds one more path through the H-Graph's start and goal (validated as the constructor
  // validates its paths; errors name `field`), its nodes subdivided as the constructor's, and
  // its edges, unchecked. Returns its index. Bridges to it are the caller's.
  int AddPath(const Space& space, InputPath path, double endpoint_tolerance,
              double max_node_spacing, const std::string& field);
  // The path as AddPath would add it (named, waypoints validated and normalised, endpoints
  // checked), without adding it. Throws as AddPath does, but for the subdivision limits.
  InputPath CheckedPath(const Space& space, InputPath path, double endpoint_tolerance,
                        const std::string& field) const;

  // Validates paths to be added with AddPath (as AddPath would, subdivision limits included,
  // errors naming `field`[i]) without changing the H-Graph; returns the nodes they would add.
  int64_t CheckNewPaths(const Space& space, const std::vector<InputPath>& paths,
                        double endpoint_tolerance, double max_node_spacing,
                        const std::string& field) const;

  // Adds a node outside the input paths' node lists (the post-optimization's shortcut points)
  // and returns its id. `path`, `index` and `t` say where it lies on an input, as HNode does
  // for a subdivision node (index is then the input edge (index, index + 1), t in [0, 1)); path
  // -1 for a point on no input (a partial shortcut's, or one on a bridge).
  int AddNode(const Config& q, int path = -1, int index = -1, double t = 0);
  // Drops the nodes from `nodes` on and the edges from `edges` on, so that the H-Graph is what
  // it was when it held that many (a query's overlay). The input paths' nodes and edges must
  // all be kept.
  void Truncate(int nodes, int edges);

  int num_nodes() const { return static_cast<int>(nodes_.size()); }
  int num_edges() const { return static_cast<int>(edges_.size()); }
  int num_paths() const { return static_cast<int>(paths_.size()); }
  const HNode& node(int i) const { return nodes_[i]; }
  const HEdge& edge(int i) const { return edges_[i]; }
  HEdge& mutable_edge(int i) { return edges_[i]; }
  const InputPath& path(int p) const { return paths_[p]; }
  // Node ids along input path p, from the start node to the goal node (with the nodes added by
  // subdivision).
  const std::vector<int>& path_nodes(int p) const { return path_nodes_[p]; }
  // Edge ids along input path p.
  const std::vector<int>& path_edges(int p) const { return path_edges_[p]; }
  int start() const { return start_id(); }
  int goal() const { return goal_id(); }
  // (neighbour, edge id) pairs of node i.
  const std::vector<std::pair<int, int>>& neighbours(int i) const { return adjacency_[i]; }

  // Adds an undirected edge and returns its id; returns the existing edge's id if u and v are
  // already joined (an input edge stays an input edge). Requires u != v.
  int AddEdge(int u, int v, bool input);
  // The id of the edge joining u and v, or -1.
  int FindEdge(int u, int v) const;

 private:
  // A stored H-Graph is rebuilt from its parts (core/merge/snapshot.cc).
  friend class SessionSnapshot;
  HGraph() = default;
  // Names an unnamed path "path<index>", requires two waypoints, validates and normalises them
  // (errors name `field`).
  static void PrepareWaypoints(const Space& space, int index, const std::string& field,
                               InputPath& path);
  void AppendPath(const Space& space, int p, double max_node_spacing);
  // The parts edge j of the path is cut into at that spacing (> 0); throws past the limit.
  static double EdgeParts(const Space& space, const InputPath& path, size_t j,
                          double max_node_spacing);
  // Throws when an H-Graph of `nodes` nodes would be too large.
  static void CheckNodeCount(double nodes, double max_node_spacing);
  static constexpr int start_id() { return 0; }
  static constexpr int goal_id() { return 1; }

  std::vector<InputPath> paths_;
  std::vector<HNode> nodes_;
  std::vector<HEdge> edges_;
  std::vector<std::vector<int>> path_nodes_;
  std::vector<std::vector<int>> path_edges_;
  std::vector<std::vector<std::pair<int, int>>> adjacency_;
};

}  // namespace hgraph
