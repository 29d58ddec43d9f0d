#include "core/merge/evidence.h"

#include <limits>

namespace hgraph {
namespace {

template <typename T>
size_t NestedBytes(const std::vector<std::vector<T>>& v) {
  size_t bytes = v.capacity() * sizeof(std::vector<T>);
  for (const auto& inner : v) bytes += inner.capacity() * sizeof(T);
  return bytes;
}

}  // namespace

void EdgeEvidence::Grow(const HGraph& graph, const Space& space) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const Config& goal = graph.node(graph.goal()).q;
  for (int n = num_nodes(); n < graph.num_nodes(); ++n) {
    goal_distance.push_back(space.Distance(graph.node(n).q, goal));
    node_clearance.push_back(nan);
    node_valid.push_back(0);
    node_witness.emplace_back();
  }
  for (int e = num_edges(); e < graph.num_edges(); ++e) {
    const HEdge& edge = graph.edge(e);
    edge_length.push_back(space.Distance(graph.node(edge.u).q, graph.node(edge.v).q));
    motion_bound.push_back(nan);
    probes.emplace_back();
    probe_rounds.push_back(0);
    scanned.push_back(0);
    ceiling.emplace_back();
    ceiling_done.push_back(0);
    probe_witness.emplace_back();
  }
}

void EdgeEvidence::Truncate(int nodes, int edges) {
  const auto n = static_cast<size_t>(nodes);
  const auto m = static_cast<size_t>(edges);
  goal_distance.resize(n);
  node_clearance.resize(n);
  node_valid.resize(n);
  node_witness.resize(n);
  edge_length.resize(m);
  motion_bound.resize(m);
  probes.resize(m);
  probe_rounds.resize(m);
  scanned.resize(m);
  ceiling.resize(m);
  ceiling_done.resize(m);
  probe_witness.resize(m);
}

size_t EdgeEvidence::memory_bytes() const {
  return (goal_distance.capacity() + node_clearance.capacity() + edge_length.capacity() +
          motion_bound.capacity()) *
             sizeof(double) +
         node_valid.capacity() + probe_rounds.capacity() + scanned.capacity() +
         ceiling_done.capacity() + node_witness.capacity() * sizeof(ClearanceWitness) +
         NestedBytes(probes) + NestedBytes(ceiling) + NestedBytes(probe_witness);
}

}  // namespace hgraph
