// Bridge-candidate strategies (paper, "H-Graph Variants"): which pairs of nodes the local planner
// is asked to connect.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "core/common/progress.h"
#include "core/hgraph/hgraph.h"

namespace hgraph {

enum class Variant {
  kAllPairs,                  // every pair of nodes, between and within paths
  kNeighborhood,              // pairs closer than radius D
  kKNearest,                  // each node to its phi nearest nodes
  kEditDistance,              // gaps and matches of the alignment of each pair of paths
  kEditDistanceNeighborhood,  // edit-distance pairs closer than radius D
};

// "all-pairs", "neighborhood", "knn", "edit-distance", "edit-distance-neighborhood".
const char* VariantName(Variant variant);
// Parses the names above; throws InputError naming `field` otherwise.
Variant ParseVariant(const std::string& name, const std::string& field);

struct CandidateOptions {
  Variant variant = Variant::kEditDistance;
  // Neighbourhood threshold D; <= 0 means 2 x the mean input edge length.
  double radius = -1;
  // Neighbours per node (k-nearest); >= 1.
  int phi = 5;
  // Alignment gap penalties; < 0 means GAP_ext = mean input edge length, GAP_init = 2 x GAP_ext.
  double gap_init = -1;
  double gap_extend = -1;
};

// Throws InputError naming "options.<field>" for a bad value (negative radius given explicitly
// is caught by the caller before the auto rule applies; phi < 1).
void ValidateCandidateOptions(const CandidateOptions& options);

// Node pairs (u < v) to check, in a deterministic order, without pairs already joined by an
// edge and without duplicates. Also returns the parameters actually used.
struct CandidateSet {
  std::vector<std::pair<int, int>> pairs;
  double radius = 0;
  double gap_init = 0;
  double gap_extend = 0;
  int alignments = 0;  // pairs of paths aligned (edit-distance variants)
};
// With `since` (AddPaths: the nodes and paths the H-Graph held before), only the pairs that
// involve a node or path added since, with the parameters given (pass the build's resolved ones,
// CandidateSet's, so that they do not drift with the new inputs): the candidates merging every
// input at once would hold beyond those already in the H-Graph (for k-nearest, a superset: the
// pairs of old nodes that new ones push out of the k nearest stay).
struct CandidatesSince {
  int nodes = 0;
  int paths = 0;
};
// `cancel` (may be null) is polled once per node or per pair of paths: all-pairs over a dense
// H-Graph makes millions of pairs.
CandidateSet BridgeCandidates(const HGraph& graph, const Space& space,
                              const CandidateOptions& options, CandidatesSince since = {},
                              const CancelToken* cancel = nullptr);
// The options with the parameters `set` resolved (radius, gaps) made explicit.
CandidateOptions Resolved(const CandidateOptions& options, const CandidateSet& set);

// Mean length of the edges between the inputs' waypoints (the scale of the automatic
// parameters).
double MeanInputEdgeLength(const HGraph& graph, const Space& space);

// How far bridges reach from a node added after the build (AddPaths' nodes, the
// post-optimization's shortcut points): the H-Graph's `radius` (CandidateSet::radius), or twice
// its mean input edge length where that is 0.
double NewNodeReach(const HGraph& graph, const Space& space, double radius);

}  // namespace hgraph
