#include "core/measure/measure.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <random>
#include <vector>

#include "core/common/error.h"
#include "core/measure/glance.h"

namespace hgraph {
namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

EdgeReport Edge(double length, std::vector<double> clearances) {
  EdgeReport r{.state = EdgeState::kValid, .length = length, .has_clearance = true};
  for (size_t s = 0; s < clearances.size(); ++s) {
    r.profile.push_back({static_cast<double>(s) / (clearances.size() - 1), clearances[s]});
  }
  return r;
}

TEST(MeasureTest, KZeroIsLength) {
  const EdgeReport e = Edge(4.0, {0.2, 0.7, 0.1});
  EXPECT_DOUBLE_EQ(InverseClearanceIntegral(e, 0), 4.0);
  EXPECT_DOUBLE_EQ(AdditiveEdgeCost({.type = MeasureType::kInverseClearance, .k = 0}, e), 4.0);
  EXPECT_FALSE(NeedsClearance({.type = MeasureType::kInverseClearance, .k = 0}));
  EXPECT_TRUE(NeedsClearance({.type = MeasureType::kInverseClearance, .k = 3}));
}

TEST(MeasureTest, ContactMakesInverseClearanceInfinite) {
  EXPECT_TRUE(std::isinf(InverseClearanceIntegral(Edge(1.0, {1.0, 0.0, 1.0}), 3)));
}

TEST(MeasureTest, ConstantClearanceIntegratesExactly) {
  const EdgeReport e = Edge(2.0, {0.5, 0.5, 0.5, 0.5});
  EXPECT_NEAR(InverseClearanceIntegral(e, 3), 2.0 * 8.0, 1e-12);
  EXPECT_NEAR(ClearanceIntegral(e), 1.0, 1e-12);
  EXPECT_DOUBLE_EQ(MinClearance(e), 0.5);
}

TEST(MeasureTest, AccumulatorSumsEdges) {
  QualityAccumulator acc(1.0);
  acc.Add(Edge(1.0, {1.0, 1.0}));
  acc.Add(Edge(3.0, {0.5, 0.5}));
  const PathQuality q = acc.Finish();
  EXPECT_DOUBLE_EQ(q.length, 4.0);
  EXPECT_DOUBLE_EQ(q.min_clearance, 0.5);
  EXPECT_DOUBLE_EQ(q.avg_clearance, (1.0 + 1.5) / 4.0);
  EXPECT_DOUBLE_EQ(q.inverse_clearance, 1.0 + 6.0);
  EXPECT_TRUE(q.has_clearance);
}

TEST(MeasureTest, BottleneckPrefersWiderThenShorter) {
  const MeasureSpec spec{.type = MeasureType::kBottleneckClearance};
  const PathQuality narrow{.length = 1, .min_clearance = 0.1};
  const PathQuality wide_long{.length = 5, .min_clearance = 0.4};
  const PathQuality wide_short{.length = 3, .min_clearance = 0.4};
  EXPECT_TRUE(Better(spec, wide_long, narrow));
  EXPECT_TRUE(Better(spec, wide_short, wide_long));
  EXPECT_FALSE(Better(spec, wide_long, wide_short));
}

TEST(MeasureTest, SafeLengthRejectsTightPaths) {
  const MeasureSpec spec{.type = MeasureType::kSafeLength, .safety = 0.3};
  EXPECT_TRUE(std::isinf(AdditiveEdgeCost(spec, Edge(1.0, {0.5, 0.2, 0.5}))));
  EXPECT_DOUBLE_EQ(AdditiveEdgeCost(spec, Edge(1.0, {0.5, 0.3, 0.5})), 1.0);
}

// The glance (core/measure/glance.h) is at most the bound as computed, +inf where a known point
// is in contact, and close to the bound where clearance varies little along a piece; none for
// the measures and exponents it does not serve. Random edges with probes, ceilings, contact and
// tiny pieces.
TEST(MeasureTest, GlanceNeverExceedsTheBound) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> unit(0, 1);
  const auto clearance = [&]() { return unit(rng) < 0.02 ? 0.0 : std::exp(6 * unit(rng) - 4); };
  for (const double k : {1.0, 2.0, 3.0, 8.0}) {
    const auto measure = Measure::Make({.type = MeasureType::kInverseClearance, .k = k});
    for (int i = 0; i < 20000; ++i) {
      std::vector<ClearanceSample> probes, ceiling;
      const int stretches = 1 + static_cast<int>(unit(rng) * 80);
      for (int s = 1; s < stretches; ++s) {
        const double t = static_cast<double>(s) / stretches;
        if (unit(rng) < 0.1) probes.push_back({t, clearance()});
        if (unit(rng) < 0.8) ceiling.push_back({t, unit(rng) < 0.05 ? kInfinity : clearance()});
      }
      const EdgeBoundInput edge{.length = unit(rng) < 0.02 ? 0.0 : 10 * unit(rng),
                                .clearance_from = unit(rng) < 0.02 ? kInfinity : clearance(),
                                .clearance_to = clearance(),
                                .motion_bound = unit(rng) < 0.2 ? 1e-9 * unit(rng) : 5 * unit(rng),
                                .interior = probes.empty() ? nullptr : &probes,
                                .ceiling = ceiling.empty() ? nullptr : &ceiling};
      const double bound = measure->EdgeBound(edge);
      const std::optional<double> glance = EdgeGlance(*measure, edge);
      ASSERT_TRUE(glance.has_value());
      ASSERT_LE(*glance, bound) << "k " << k << ", edge " << i;
      const bool contact = !(std::min(edge.clearance_from, edge.clearance_to) > 0) ||
                           std::any_of(probes.begin(), probes.end(),
                                       [](const ClearanceSample& p) { return p.clearance <= 0; });
      ASSERT_EQ(std::isinf(*glance), contact) << "k " << k << ", edge " << i;
    }
  }
  // Clearance 1 at the ends and at 64 ceiling points, robot points moving 0.1: within 1%.
  std::vector<ClearanceSample> ceiling;
  for (int s = 1; s <= 64; ++s) ceiling.push_back({s / 65.0, 1.0});
  const EdgeBoundInput even{.length = 2,
                            .clearance_from = 1,
                            .clearance_to = 1,
                            .motion_bound = 0.1,
                            .ceiling = &ceiling};
  const auto cubed = Measure::Make({.type = MeasureType::kInverseClearance, .k = 3});
  EXPECT_GE(*EdgeGlance(*cubed, even), 0.99 * cubed->EdgeBound(even));
  EXPECT_LE(*EdgeGlance(*cubed, even), cubed->EdgeBound(even));
  for (const MeasureSpec& spec : {MeasureSpec{.type = MeasureType::kLength},
                                  MeasureSpec{.type = MeasureType::kInverseClearance, .k = 0},
                                  MeasureSpec{.type = MeasureType::kInverseClearance, .k = 2.5},
                                  MeasureSpec{.type = MeasureType::kBottleneckClearance},
                                  MeasureSpec{.type = MeasureType::kSafeLength, .safety = 1}}) {
    EXPECT_FALSE(EdgeGlance(*Measure::Make(spec), EdgeBoundInput{.length = 1}).has_value())
        << MeasureTypeName(spec.type);
  }
}

TEST(MeasureTest, BadValuesNameTheField) {
  try {
    ValidateMeasure({.type = MeasureType::kInverseClearance, .k = -1});
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "measure.k");
  }
  try {
    ValidateMeasure({.type = MeasureType::kSafeLength, .safety = NAN});
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "measure.safety");
  }
  EXPECT_THROW(ParseMeasureType("speed", "measure"), InputError);
  EXPECT_EQ(ParseMeasureType("safe-length", "measure"), MeasureType::kSafeLength);
}

}  // namespace
}  // namespace hgraph
