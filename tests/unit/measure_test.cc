#include "core/measure/measure.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/common/error.h"

namespace hgraph {
namespace {

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
