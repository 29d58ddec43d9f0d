// How a merge's search sees its H-Graph's edges (core/search's SearchEdgeFn and ExactFn): invalid
// ones not at all, checked ones (with a profile where the measure needs one) by their value, the
// others by the measure's bound (LazyEdgeEvaluator::BoundInput). Internal to core/merge.
#pragma once

#include <optional>
#include <vector>

#include "core/hgraph/hgraph.h"
#include "core/measure/measure.h"
#include "core/merge/edge_evaluator.h"
#include "core/merge/evidence.h"
#include "core/merge/path_check.h"
#include "core/search/glance.h"
#include "core/search/search.h"

namespace hgraph {

// What it saw of an edge is kept until a check changes what is known of it (Forget): a search
// looks at an edge once per node it settles next to it, and a bound scans the edge's probes.
// Lives for one search of an H-Graph that does not grow meanwhile; not copyable (the functions
// it hands out point to it); not thread safe.
// Whether a search may take the motion: usable (EdgeReport::usable, or usable_at_samples with
// CheckMode::kSampled), and with `refuse_stalled` not a motion whose advancement stalled.
bool UsableBy(const EdgeReport& report, CheckMode check_mode, bool refuse_stalled);

class SearchView {
 public:
  // With CheckMode::kSampled a profile without a certificate is usable
  // (EdgeReport::usable_at_samples). With `refuse_stalled` (a search finished with
  // EdgeProof::kCertificateOrGiveUp) a motion whose advancement stalled is not, whatever a
  // profile found for another query says (UsableBy).
  SearchView(const HGraph& graph, const EdgeEvidence& evidence, const Measure& measure,
             LazyEdgeEvaluator evaluator, CheckMode check_mode, bool refuse_stalled = false);
  SearchView(const SearchView&) = delete;
  SearchView& operator=(const SearchView&) = delete;

  ExactFn exact() const {
    return [this](int e) { return Exact(e); };
  }
  SearchEdgeFn see();
  // The measure's cheaper bound (EdgeGlance, core/measure/glance.h) of an edge not seen yet that
  // is usable and not exact; nullopt otherwise (see() then costs no more).
  GlanceFn glance() {
    return [this](int e) { return Glance(e); };
  }
  // The edges were checked: they are looked at again.
  void Forget(const std::vector<int>& edges);

 private:
  bool Usable(const EdgeReport& report) const;
  bool Exact(int e) const;
  SearchEdge Look(int e);
  std::optional<double> Glance(int e);

  const HGraph& graph_;
  const EdgeEvidence& evidence_;
  const Measure& measure_;
  LazyEdgeEvaluator evaluator_;
  CheckMode check_mode_;
  bool refuse_stalled_;
  std::vector<SearchEdge> seen_;
  std::vector<char> seen_now_;
};

}  // namespace hgraph
