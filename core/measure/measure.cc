#include "core/measure/measure.h"

#include <algorithm>
#include <cmath>
#include <optional>

#include "core/common/client_text.h"
#include "core/common/error.h"
#include "core/measure/glance.h"

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
  throw InputError(field, "unknown measure '" + ClientText(name) +
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

namespace {

// x^n, n >= 0 small, by multiplication.
double NaturalPower(double x, int n) {
  double r = 1;
  for (int i = 0; i < n; ++i) r *= x;
  return r;
}

// Integral of x^-k over [a, b], 0 < a <= b. For a whole k from 2 to 8 (3 by default: the lower
// bound of every unchecked edge in every search takes a few of these) without pow:
// (a^-m - b^-m) / m with m = k - 1, a^-m - b^-m = (b^m - a^m) / (a^m b^m), and b^m - a^m =
// (b - a) times a sum of positive terms, which keeps its precision when a and b are close (a
// difference of two pows loses it).
double PowerIntegral(double a, double b, double k) {
  if (b <= a) return 0;
  if (k == 1) return std::log(b / a);
  if (k >= 2 && k <= 8 && k == std::floor(k)) {
    const int m = static_cast<int>(k) - 1;
    double sum = 0;  // b^m - a^m = (b - a) * sum over i < m of b^i a^(m-1-i)
    double b_power = 1;
    for (int i = 0; i < m; ++i) {
      sum += b_power * NaturalPower(a, m - 1 - i);
      b_power *= b;
    }
    const double denominator = NaturalPower(a, m) * b_power * m;
    if (std::isnormal(denominator) && std::isfinite(sum)) return (b - a) * sum / denominator;
  }
  return (std::pow(b, 1 - k) - std::pow(a, 1 - k)) / (1 - k);
}

// The smallest clearance known on an unchecked edge: at its ends and its probed points.
double MinKnownClearance(const EdgeBoundInput& edge) {
  double c = std::min(edge.clearance_from, edge.clearance_to);
  if (edge.interior != nullptr) {
    for (const ClearanceSample& sample : *edge.interior) c = std::min(c, sample.clearance);
  }
  return c;
}

// Inverse clearance's bound of an unchecked edge where no integral is needed: infinity for a
// point in contact (the edge cannot be valid), 0 for an edge of no length or with an end or a
// motion bound not known; nullopt otherwise (EdgeBound and EdgeGlance integrate).
std::optional<double> FixedInverseClearanceBound(const EdgeBoundInput& edge) {
  if (!(MinKnownClearance(edge) > 0)) return kInf;
  if (edge.length <= 0) return 0.0;
  if (!std::isfinite(edge.clearance_from) || !std::isfinite(edge.clearance_to) ||
      !std::isfinite(edge.motion_bound)) {
    return 0.0;
  }
  return std::nullopt;
}

// Calls f(t, c) for the probed points and the ceilings in order of t, interior points only, the
// smaller value where both have one.
template <typename F>
void ForEachInteriorCeiling(const EdgeBoundInput& edge, F&& f) {
  static const std::vector<ClearanceSample> kNone;
  const std::vector<ClearanceSample>& a = edge.interior != nullptr ? *edge.interior : kNone;
  const std::vector<ClearanceSample>& b = edge.ceiling != nullptr ? *edge.ceiling : kNone;
  size_t i = 0;
  size_t j = 0;
  while (i < a.size() || j < b.size()) {
    if (j == b.size() || (i < a.size() && a[i].t < b[j].t)) {
      f(a[i].t, a[i].clearance);
      ++i;
    } else if (i == a.size() || b[j].t < a[i].t) {
      f(b[j].t, b[j].clearance);
      ++j;
    } else {
      f(a[i].t, std::min(a[i].clearance, b[j].clearance));
      ++i;
      ++j;
    }
  }
}

}  // namespace

double ClearanceFloor(const EdgeBoundInput& edge) {
  if (!std::isfinite(edge.clearance_from) || !std::isfinite(edge.clearance_to) ||
      !std::isfinite(edge.motion_bound)) {
    return -kInf;
  }
  double floor = std::min(edge.clearance_from, edge.clearance_to);
  ClearanceSample a{.t = 0, .clearance = edge.clearance_from};
  const auto piece = [&](const ClearanceSample& b) {
    floor = std::min({floor, b.clearance, StretchFloor(a, b, edge.motion_bound)});
    a = b;
  };
  if (edge.interior != nullptr) {
    for (const ClearanceSample& sample : *edge.interior) piece(sample);
  }
  piece({.t = 1.0, .clearance = edge.clearance_to});
  return floor;
}

namespace {

// The motion bound with the slack of the certified local planner's steps
// (core/motion/local_planner.cc), for rounding.
double SlackBound(double motion_bound) { return motion_bound / 0.999; }

}  // namespace

double StretchFloor(const ClearanceSample& a, const ClearanceSample& b, double motion_bound) {
  return 0.5 * (a.clearance + b.clearance - SlackBound(motion_bound) * (b.t - a.t));
}

double ReachFloor(const ClearanceSample& a, double t, double motion_bound) {
  return a.clearance - SlackBound(motion_bound) * std::abs(t - a.t);
}

namespace {

class LengthMeasure final : public Measure {
 public:
  explicit LengthMeasure(const MeasureSpec& spec) : Measure(spec) {}
  Combine combine() const override { return Combine::kSum; }
  bool needs_clearance() const override { return false; }
  double EdgeValue(const EdgeReport& report) const override { return report.length; }
  // Exact for a valid edge: a lazy length search returns the exhaustive optimum.
  double EdgeBound(const EdgeBoundInput& edge) const override { return edge.length; }
  double cost_per_distance() const override { return 1; }
  double Objective(const PathQuality& quality) const override { return quality.length; }
};

class InverseClearanceMeasure final : public Measure {
 public:
  explicit InverseClearanceMeasure(const MeasureSpec& spec) : Measure(spec) {}
  Combine combine() const override { return Combine::kSum; }
  bool needs_clearance() const override { return spec().k != 0; }
  bool uses_ceilings() const override { return spec().k != 0; }
  double EdgeValue(const EdgeReport& report) const override {
    return InverseClearanceIntegral(report, spec().k);
  }
  double cost_per_distance() const override { return spec().k == 0 ? 1 : 0; }
  // Clearance changes no faster than robot points move, so between two grid points with known
  // clearances or ceilings (c0 at t0, c1 at t1; the ends, the probed points, the ceilings) it is
  // at most u(t) = min(c0 + D (t - t0), c1 + D (t1 - t)), D the motion bound. The profile's
  // samples lie under u, its grid holds t0 and t1, and u^-k is convex between them (a convex
  // decreasing function of a concave one), so the trapezoid sum over the profile is at least
  // length * integral of u^-k.
  double EdgeBound(const EdgeBoundInput& edge) const override {
    const double k = spec().k;
    if (k == 0) return edge.length;
    if (const std::optional<double> fixed = FixedInverseClearanceBound(edge)) return *fixed;
    const double d = edge.motion_bound;
    double integral = 0;
    double t0 = 0;
    double c0 = edge.clearance_from;
    const auto piece = [&](double t1, double c1) {
      const double w = t1 - t0;
      if (w <= 0) return;
      const double dw = d * w;
      if (dw <= 1e-12 * std::max(c0, c1)) {
        integral += w * std::pow(std::min(c0, c1), -k);
      } else {
        // u peaks where the two lines meet.
        const double peak = std::clamp((c1 - c0 + dw) / (2 * dw), 0.0, 1.0);
        integral +=
            (PowerIntegral(c0, c0 + dw * peak, k) + PowerIntegral(c1, c1 + dw * (1 - peak), k)) / d;
      }
      t0 = t1;
      c0 = c1;
    };
    ForEachInteriorCeiling(edge, piece);
    piece(1.0, edge.clearance_to);
    // A little slack for rounding: the bound must never exceed the checked cost.
    return edge.length * integral * (1 - 1e-9);
  }
  double Objective(const PathQuality& quality) const override {
    return spec().k == 0 ? quality.length : quality.inverse_clearance;
  }
};

class BottleneckMeasure final : public Measure {
 public:
  explicit BottleneckMeasure(const MeasureSpec& spec) : Measure(spec) {}
  Combine combine() const override { return Combine::kBottleneck; }
  bool needs_clearance() const override { return true; }
  double EdgeValue(const EdgeReport& report) const override { return MinClearance(report); }
  // The profile starts and ends at the edge's end configurations and holds the probed points, so
  // its minimum is at most theirs.
  double EdgeBound(const EdgeBoundInput& edge) const override { return MinKnownClearance(edge); }
  // Every sample of the profile lies above the clearance floor.
  double EdgeFloor(const EdgeBoundInput& edge) const override {
    const double floor = ClearanceFloor(edge);
    return floor > 0 ? floor : std::numeric_limits<double>::quiet_NaN();
  }
  double Objective(const PathQuality& quality) const override { return -quality.min_clearance; }
};

class SafeLengthMeasure final : public Measure {
 public:
  explicit SafeLengthMeasure(const MeasureSpec& spec) : Measure(spec) {}
  Combine combine() const override { return Combine::kSum; }
  bool needs_clearance() const override { return spec().safety > 0; }
  double EdgeValue(const EdgeReport& report) const override {
    if (spec().safety > 0 && MinClearance(report) < spec().safety) return kInf;
    return report.length;
  }
  // An edge with an end or a probed point closer than C to an obstacle is unusable without a
  // check.
  double EdgeBound(const EdgeBoundInput& edge) const override {
    if (spec().safety > 0 && MinKnownClearance(edge) < spec().safety) {
      return kInf;
    }
    return edge.length;
  }
  // An edge whose clearance floor reaches C is usable at its length.
  double EdgeFloor(const EdgeBoundInput& edge) const override {
    if (spec().safety > 0 && ClearanceFloor(edge) >= spec().safety) return edge.length;
    return std::numeric_limits<double>::quiet_NaN();
  }
  double clearance_target() const override {
    return spec().safety > 0 ? spec().safety : std::numeric_limits<double>::quiet_NaN();
  }
  double cost_per_distance() const override { return 1; }
  double Objective(const PathQuality& quality) const override {
    if (spec().safety > 0 && quality.min_clearance < spec().safety) return kInf;
    return quality.length;
  }
};

}  // namespace

// Over each piece of InverseClearanceMeasure::EdgeBound, u is at most where its two lines would
// meet, (c0 + c1 + D w) / 2, so w times that to the -k is at most the piece's integral: no pow
// and no log, one division per piece. Only for the whole k that PowerIntegral computes in closed
// form (relative error about 1e-15): the slack of 1e-6 keeps the glance under EdgeBound's value
// as computed, not only as it would be exactly.
std::optional<double> EdgeGlance(const Measure& measure, const EdgeBoundInput& edge) {
  const double k = measure.spec().k;
  if (measure.spec().type != MeasureType::kInverseClearance ||
      !(k >= 1 && k <= 8 && k == std::floor(k))) {
    return std::nullopt;
  }
  if (const std::optional<double> fixed = FixedInverseClearanceBound(edge)) return fixed;
  const double d = edge.motion_bound;
  const int n = static_cast<int>(k);
  double sum = 0;
  double t0 = 0;
  double c0 = edge.clearance_from;
  const auto piece = [&](double t1, double c1) {
    const double w = t1 - t0;
    if (w <= 0) return;
    sum += w / NaturalPower(0.5 * (c0 + c1 + d * w), n);
    t0 = t1;
    c0 = c1;
  };
  ForEachInteriorCeiling(edge, piece);
  piece(1.0, edge.clearance_to);
  return edge.length * sum * (1 - 1e-6);
}

std::unique_ptr<const Measure> Measure::Make(const MeasureSpec& spec) {
  ValidateMeasure(spec);
  switch (spec.type) {
    case MeasureType::kLength: return std::make_unique<LengthMeasure>(spec);
    case MeasureType::kInverseClearance: return std::make_unique<InverseClearanceMeasure>(spec);
    case MeasureType::kBottleneckClearance: return std::make_unique<BottleneckMeasure>(spec);
    case MeasureType::kSafeLength: return std::make_unique<SafeLengthMeasure>(spec);
  }
  throw InputError("measure.type", "unknown measure");
}

bool Measure::Better(const PathQuality& a, const PathQuality& b) const {
  const double oa = Objective(a);
  const double ob = Objective(b);
  if (oa != ob) return oa < ob;
  if (combine() == Combine::kBottleneck) return a.length < b.length;
  return false;
}

double AdditiveEdgeCost(const MeasureSpec& spec, const EdgeReport& report) {
  const auto measure = Measure::Make(spec);
  HGRAPH_CHECK(measure->combine() == Measure::Combine::kSum);
  return measure->EdgeValue(report);
}

double Objective(const MeasureSpec& spec, const PathQuality& quality) {
  return Measure::Make(spec)->Objective(quality);
}

bool Better(const MeasureSpec& spec, const PathQuality& a, const PathQuality& b) {
  return Measure::Make(spec)->Better(a, b);
}

bool NeedsClearance(const MeasureSpec& spec) { return Measure::Make(spec)->needs_clearance(); }

}  // namespace hgraph
