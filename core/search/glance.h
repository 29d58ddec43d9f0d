// The lazy sum search's cheaper first look at an edge (FindBestPathLazy with a glance): a
// lower bound that costs less than the edge's bound, so that the many edges into nodes the
// search settles early are never bounded precisely. Internal to core/merge's search.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "core/search/search.h"

namespace hgraph {

// A lower bound on an edge's value that costs less than `see` (a sum search's first look at an
// edge): never above see(e).value (NaN or +inf: the edge is not placed); nullopt when `see`
// costs no more (the edge was seen, is exact, or the measure has no cheaper bound).
using GlanceFn = std::function<std::optional<double>(int edge)>;

struct GlanceStats {
  int64_t glanced = 0;  // entries placed by the glance
  int64_t refined = 0;  // of those, seen through `see` before their node was settled
};

// FindBestPathLazy (core/search/search.h), whose sum searches place an entry at an edge's first
// look with its glance, and see the edge through `see` only if the entry comes out before its
// node is settled. A glance is at most the key that `see` gives, and such an entry comes out
// before every entry of equal key, so it comes out no later than it would with its key from
// `see`: the search settles the same nodes through the same edges, checks the same edges in the
// same batches and returns the same path as without the glance. Widest searches, and sums that
// need no clearance (LazySP, whose bounds cost nothing), do not glance.
SearchResult FindBestPathLazy(const HGraph& graph, const Measure& measure, const SearchEdgeFn& see,
                              const ExactFn& exact, const EvaluateFn& evaluate,
                              const std::vector<double>* cost_to_go,
                              const std::vector<double>* length_to_go, int batch,
                              LazySearchStats* stats, const GlanceFn& glance,
                              GlanceStats* glance_stats);

}  // namespace hgraph
