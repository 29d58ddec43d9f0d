#include "core/measure/measure.h"

#include <algorithm>
#include <cmath>

#include "core/common/error.h"

namespace hgraph {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

double InversePower(double clearance, double k) {
  if (k == 0) return 1.0;
  if (clearance <= 0) return kInf;
  return std::pow(clearance, -k);
}

}  // namespace

const char* MeasureTypeName(MeasureType type) {
  switch (type) {
    case MeasureType::kLength: return "length";
    case MeasureType::kInverseClearance: return "inverse-clearance";
    case MeasureType::kBottleneckClearance: return "bottleneck-clearance";
    case MeasureType::kSafeLength: return "safe-length";
  }
  return "?";
}

MeasureType ParseMeasureType(const std::string& name, const std::string& field) {
  for (MeasureType t : {MeasureType::kLength, MeasureType::kInverseClearance,
                        MeasureType::kBottleneckClearance, MeasureType::kSafeLength}) {
    if (name == MeasureTypeName(t)) return t;
  }
  throw InputError(field, "unknown measure '" + name +
                              "' (expected length, inverse-clearance, bottleneck-clearance or "
                              "safe-length)");
}

void ValidateMeasure(const MeasureSpec& spec) {
  if (!std::isfinite(spec.k) || spec.k < 0) {
    throw InputError("measure.k", "must be finite and >= 0, got " + std::to_string(spec.k));
  }
  if (!std::isfinite(spec.safety) || spec.safety < 0) {
    throw InputError("measure.safety",
                     "must be finite and >= 0, got " + std::to_string(spec.safety));
  }
}

bool NeedsClearance(const MeasureSpec& spec) {
  switch (spec.type) {
    case MeasureType::kLength: return false;
    case MeasureType::kInverseClearance: return spec.k != 0;
    case MeasureType::kBottleneckClearance: return true;
    case MeasureType::kSafeLength: return spec.safety > 0;
  }
  return true;
}

double InverseClearanceIntegral(const EdgeReport& report, double k) {
  if (k == 0) return report.length;
  HGRAPH_CHECK(report.has_clearance && report.profile.size() >= 2);
  double sum = 0;
  for (size_t s = 1; s < report.profile.size(); ++s) {
    const ClearanceSample& a = report.profile[s - 1];
    const ClearanceSample& b = report.profile[s];
    const double ds = (b.t - a.t) * report.length;
    if (ds <= 0) {
      // Zero-length stretches add nothing, but a contact anywhere still makes the cost infinite.
      if (a.clearance <= 0 || b.clearance <= 0) return kInf;
      continue;
    }
    sum += 0.5 * ds * (InversePower(a.clearance, k) + InversePower(b.clearance, k));
  }
  return sum;
}

double ClearanceIntegral(const EdgeReport& report) {
  HGRAPH_CHECK(report.has_clearance && report.profile.size() >= 2);
  double sum = 0;
  for (size_t s = 1; s < report.profile.size(); ++s) {
    const ClearanceSample& a = report.profile[s - 1];
    const ClearanceSample& b = report.profile[s];
    sum += 0.5 * (b.t - a.t) * report.length * (a.clearance + b.clearance);
  }
  return sum;
}

double MinClearance(const EdgeReport& report) {
  HGRAPH_CHECK(report.has_clearance);
  double m = kInf;
  for (const ClearanceSample& s : report.profile) m = std::min(m, s.clearance);
  return m;
}

void QualityAccumulator::Add(const EdgeReport& report) {
  ++edges_;
  quality_.length += report.length;
  if (!report.has_clearance) {
    all_have_clearance_ = false;
    return;
  }
  quality_.min_clearance = std::min(quality_.min_clearance, MinClearance(report));
  clearance_integral_ += ClearanceIntegral(report);
  quality_.inverse_clearance += InverseClearanceIntegral(report, quality_.k);
  if (edges_ == 1 || quality_.length == 0) {
    // Remember a clearance for paths of zero length, whose average is the point's clearance.
    quality_.avg_clearance = report.profile.front().clearance;
  }
}

PathQuality QualityAccumulator::Finish() const {
  PathQuality q = quality_;
  q.has_clearance = all_have_clearance_ && edges_ > 0;
  if (!q.has_clearance) {
    q.min_clearance = 0;
    q.avg_clearance = 0;
    q.inverse_clearance = q.k == 0 ? q.length : 0;
    return q;
  }
  if (q.length > 0) q.avg_clearance = clearance_integral_ / q.length;
  return q;
}

double AdditiveEdgeCost(const MeasureSpec& spec, const EdgeReport& report) {
  switch (spec.type) {
    case MeasureType::kLength: return report.length;
    case MeasureType::kInverseClearance: return InverseClearanceIntegral(report, spec.k);
    case MeasureType::kSafeLength:
      if (spec.safety > 0 && MinClearance(report) < spec.safety) return kInf;
      return report.length;
    case MeasureType::kBottleneckClearance: break;
  }
  HGRAPH_CHECK(false && "bottleneck clearance is not additive");
  return kInf;
}

double Objective(const MeasureSpec& spec, const PathQuality& quality) {
  switch (spec.type) {
    case MeasureType::kLength: return quality.length;
    case MeasureType::kInverseClearance:
      return spec.k == 0 ? quality.length : quality.inverse_clearance;
    case MeasureType::kBottleneckClearance: return -quality.min_clearance;
    case MeasureType::kSafeLength:
      if (spec.safety > 0 && quality.min_clearance < spec.safety) return kInf;
      return quality.length;
  }
  return kInf;
}

bool Better(const MeasureSpec& spec, const PathQuality& a, const PathQuality& b) {
  const double oa = Objective(spec, a);
  const double ob = Objective(spec, b);
  if (oa != ob) return oa < ob;
  if (spec.type == MeasureType::kBottleneckClearance) return a.length < b.length;
  return false;
}

}  // namespace hgraph
