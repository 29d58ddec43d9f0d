// Conversions between hgraph.v1 merge messages (merge.proto) and the core merge types. Unset
// optional fields take the core defaults; bad values are InputErrors naming "measure.<field>" or
// "options.<field>".
#pragma once

#include "core/merge/merge.h"
#include "hgraph/v1/merge.pb.h"
#include "hgraph/v1/scene.pb.h"

namespace hgraph {

MeasureSpec MeasureFromProto(const v1::Measure& proto);
v1::Measure MeasureToProto(const MeasureSpec& spec);

Variant VariantFromProto(v1::Variant variant);
v1::Variant VariantToProto(Variant variant);
// Unspecified is certified; an unknown value is an InputError naming options.check_mode.
CheckMode CheckModeFromProto(v1::CheckMode mode);
v1::CheckMode CheckModeToProto(CheckMode mode);
v1::OptimizeStop OptimizeStopToProto(OptimizeStop stop);
OptimizeStop OptimizeStopFromProto(v1::OptimizeStop stop);

// Everything of v1::MergeOptions but the resolution, which belongs to the local planner (see
// ResolutionFromProto).
MergeOptions MergeOptionsFromProto(const v1::MergeOptions& proto);
// The local-planner resolution: options.resolution if set, else the scene's, else 0.01.
double ResolutionFromProto(const v1::MergeOptions& options, const v1::Scene& scene);

v1::PathQuality QualityToProto(const PathQuality& quality);
PathQuality QualityFromProto(const v1::PathQuality& proto);
v1::InputReport InputReportToProto(const InputReport& report);
InputReport InputReportFromProto(const v1::InputReport& proto);
v1::MergeResult MergeResultToProto(const MergeResult& result);
// The inverse, for clients of the service that draw or post-process a result.
MergeResult MergeResultFromProto(const v1::MergeResult& proto);

}  // namespace hgraph
