// How a merge's search sees its H-Graph's edges (core/search's SearchEdgeFn and ExactFn): invalid
// ones not at all, checked ones (with a profile where the measure needs one) by their value, the
// others by the measure's bound (LazyEdgeEvaluator::BoundInput). Internal to core/merge.
#pragma once

#include <vector>

#include "core/hgraph/hgraph.h"
#include "core/measure/measure.h"
#include "core/merge/edge_evaluator.h"
#include "core/merge/evidence.h"
#include "core/merge/path_check.h"
#include "core/search/search.h"

namespace hgraph {

// What it saw of an edge is kept until a check changes what is known of it (Forget): a search
// looks at an edge once per node it settles next to it, and a bound scans the edge's probes.
// Lives for one search of an H-Graph that does not grow meanwhile; not copyable (the functions
// it hands out point to it); not thread safe.
class SearchView {
 public:
  // With CheckMode::kSampled a profile without a certificate is usable
  // (EdgeReport::usable_at_samples).
  SearchView(const HGraph& graph, const EdgeEvidence& evidence, const Measure& measure,
             LazyEdgeEvaluator evaluator, CheckMode check_mode);
  SearchView(const SearchView&) = delete;
  SearchView& operator=(const SearchView&) = delete;

  ExactFn exact() const {
    return [this](int e) { return Exact(e); };
  }
  SearchEdgeFn see();
  // The edges were checked: they are looked at again.
  void Forget(const std::vector<int>& edges);

 private:
  bool Usable(const EdgeReport& report) const;
  bool Exact(int e) const;
  SearchEdge Look(int e);

  const HGraph& graph_;
  const EdgeEvidence& evidence_;
  const Measure& measure_;
  LazyEdgeEvaluator evaluator_;
  CheckMode check_mode_;
  std::vector<SearchEdge> seen_;
  std::vector<char> seen_now_;
};

}  // namespace hgraph
