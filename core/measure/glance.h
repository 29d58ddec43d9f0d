// A bound of the same kind as Measure::EdgeBound that costs less, for a lazy search's first look
// at an edge (core/search/glance.h). Internal to core/merge's search.
#pragma once

#include <optional>

#include "core/measure/measure.h"

namespace hgraph {

// At most measure.EdgeBound(edge) (+inf where EdgeBound finds a known point in contact); nullopt
// when EdgeBound costs no more (every measure but inverse clearance of a whole k from 1 to 8).
std::optional<double> EdgeGlance(const Measure& measure, const EdgeBoundInput& edge);

}  // namespace hgraph
