#include "core/merge/search_view.h"

#include <limits>

#include "core/measure/glance.h"

namespace hgraph {

SearchView::SearchView(const HGraph& graph, const EdgeEvidence& evidence, const Measure& measure,
                       LazyEdgeEvaluator evaluator, CheckMode check_mode, bool refuse_stalled)
    : graph_(graph),
      evidence_(evidence),
      measure_(measure),
      evaluator_(evaluator),
      check_mode_(check_mode),
      refuse_stalled_(refuse_stalled),
      seen_(graph.num_edges()),
      seen_now_(graph.num_edges(), 0) {}

SearchEdgeFn SearchView::see() {
  return [this](int e) {
    if (!seen_now_[e]) {
      seen_[e] = Look(e);
      seen_now_[e] = 1;
    }
    return seen_[e];
  };
}

void SearchView::Forget(const std::vector<int>& edges) {
  for (int e : edges) seen_now_[e] = 0;
}

bool UsableBy(const EdgeReport& report, CheckMode check_mode, bool refuse_stalled) {
  if (refuse_stalled && report.advancement == Advancement::kStalled) return false;
  return check_mode == CheckMode::kSampled ? report.usable_at_samples() : report.usable();
}

bool SearchView::Usable(const EdgeReport& report) const {
  return UsableBy(report, check_mode_, refuse_stalled_);
}

bool SearchView::Exact(int e) const {
  const EdgeReport& report = graph_.edge(e).report;
  return !Usable(report) || (report.state == EdgeState::kValid &&
                             (!measure_.needs_clearance() || report.has_clearance));
}

std::optional<double> SearchView::Glance(int e) {
  if (seen_now_[e] || Exact(e)) return std::nullopt;
  return EdgeGlance(measure_, evaluator_.BoundInput(e, measure_.uses_ceilings()));
}

SearchEdge SearchView::Look(int e) {
  const EdgeReport& report = graph_.edge(e).report;
  const double length = evidence_.edge_length[e];
  if (!Usable(report)) {
    return SearchEdge{.value = std::numeric_limits<double>::quiet_NaN(), .length = length};
  }
  if (Exact(e)) {
    const double value = measure_.EdgeValue(report);
    return SearchEdge{.value = value, .length = length, .floor = value, .checked = true};
  }
  const EdgeBoundInput input = evaluator_.BoundInput(e, measure_.uses_ceilings());
  return SearchEdge{.value = measure_.EdgeBound(input),
                    .length = length,
                    .floor = measure_.EdgeFloor(input),
                    .checked = report.state == EdgeState::kValid};
}

}  // namespace hgraph
