// The report on one input of a stored H-Graph under a measure, from the check reports on the
// H-Graph edges its edges were cut into (HGraph's node subdivision): what the merge's checks have
// established of it, nothing more. Internal to core/merge.
#pragma once

#include <vector>

#include "core/hgraph/hgraph.h"
#include "core/merge/path_check.h"
#include "core/space/space.h"

namespace hgraph {

// Input p's report (ReportInputPath over its edges' joined reports), with edge_length[e] the
// length of H-Graph edge e. An input edge that is unchecked, or under a measure that
// `needs_clearance` valid without a profile, is known by its length only: the report is then not
// `checked` and not certified.
InputReport ReportStoredInput(const HGraph& graph, const Space& space,
                              const std::vector<double>& edge_length, int p, bool needs_clearance,
                              double k);

}  // namespace hgraph
