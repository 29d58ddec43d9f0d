#include "core/space/space.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <utility>
#include <vector>

#include "core/common/error.h"

namespace hgraph {
namespace {

constexpr double kPi = std::numbers::pi;

Config V(std::initializer_list<double> values) {
  Config q(static_cast<Eigen::Index>(values.size()));
  int k = 0;
  for (double v : values) q[k++] = v;
  return q;
}

Space MakeSE3() { return Space::SE3(Eigen::Vector3d(-10, -10, -10), Eigen::Vector3d(10, 10, 10)); }

TEST(SpaceTest, SE2DistanceMatchesOmplDefault) {
  const Space space = Space::SE2(Eigen::Vector2d(0, 0), Eigen::Vector2d(10, 10));
  // |dxy| + 0.5 |dtheta|, with the angle wrapped.
  EXPECT_NEAR(space.Distance(V({0, 0, 0}), V({3, 4, 1})), 5.0 + 0.5, 1e-12);
  EXPECT_NEAR(space.Distance(V({0, 0, 3.0}), V({0, 0, -3.0})), 0.5 * (2 * kPi - 6.0), 1e-12);
}

TEST(SpaceTest, SE3DistanceMatchesOmplDefault) {
  const Space space = MakeSE3();
  const Eigen::Quaterniond r(Eigen::AngleAxisd(1.0, Eigen::Vector3d::UnitZ()));
  const Config a = V({0, 0, 0, 0, 0, 0, 1});
  const Config b = V({1, 2, 2, r.x(), r.y(), r.z(), r.w()});
  // |dxyz| + acos|<q1,q2>| = 3 + 0.5 (half the rotation angle).
  EXPECT_NEAR(space.Distance(a, b), 3.0 + 0.5, 1e-9);
  // q and -q are the same rotation.
  const Config c = V({1, 2, 2, -r.x(), -r.y(), -r.z(), -r.w()});
  EXPECT_NEAR(space.Distance(a, c), 3.5, 1e-9);
  EXPECT_NEAR(space.RotationAngle(0, a, b), 1.0, 1e-9);
}

TEST(SpaceTest, WeightsScaleComponents) {
  const Space space({ComponentSpec{.type = ComponentType::kSE2,
                                   .lower = Eigen::Vector2d(0, 0),
                                   .upper = Eigen::Vector2d(1, 1),
                                   .translation_weight = 2.0,
                                   .rotation_weight = 0.1}});
  EXPECT_NEAR(space.Distance(V({0, 0, 0}), V({1, 0, 1})), 2.0 + 0.1, 1e-12);
}

TEST(SpaceTest, ProductOfTwoSE3HasTwelveDegreesOfFreedom) {
  ComponentSpec se3{.type = ComponentType::kSE3,
                    .lower = Eigen::Vector3d(-1, -1, -1),
                    .upper = Eigen::Vector3d(1, 1, 1)};
  const Space space({se3, se3});
  EXPECT_EQ(space.dimension(), 14);
  EXPECT_EQ(space.degrees_of_freedom(), 12);
  EXPECT_EQ(space.offset(1), 7);
  Config a = V({0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 1});
  Config b = a;
  b[7] = 1;
  b[0] = 0.5;
  EXPECT_NEAR(space.Distance(a, b), 1.5, 1e-12);
}

TEST(SpaceTest, InterpolationEndsAndMidpoint) {
  const Space space = MakeSE3();
  const Eigen::Quaterniond r(Eigen::AngleAxisd(2.0, Eigen::Vector3d::UnitX()));
  const Config a = V({0, 0, 0, 0, 0, 0, 1});
  const Config b = V({2, 0, 0, r.x(), r.y(), r.z(), r.w()});
  EXPECT_TRUE(space.Interpolate(a, b, 0).isApprox(a));
  EXPECT_TRUE(space.Interpolate(a, b, 1).isApprox(b));
  const Config mid = space.Interpolate(a, b, 0.5);
  EXPECT_NEAR(mid[0], 1.0, 1e-12);
  EXPECT_NEAR(space.RotationAngle(0, a, mid), 1.0, 1e-9);
  EXPECT_NEAR(space.Distance(a, mid) + space.Distance(mid, b), space.Distance(a, b), 1e-9);
}

TEST(SpaceTest, SO2InterpolationTakesTheShorterArc) {
  const Space space = Space::SE2(Eigen::Vector2d(0, 0), Eigen::Vector2d(1, 1));
  const Config mid = space.Interpolate(V({0, 0, 3.0}), V({0, 0, -3.0}), 0.5);
  EXPECT_NEAR(std::abs(mid[2]), kPi, 1e-9);
}

TEST(SpaceTest, ValidateNamesTheProblem) {
  const Space space = MakeSE3();
  try {
    space.Validate(V({0, 0, 0}), "paths[1].waypoints[2]");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "paths[1].waypoints[2]: expected 7 coordinates, got 3");
  }
  try {
    space.Validate(V({0, NAN, 0, 0, 0, 0, 1}), "q");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "q[1]");
    EXPECT_NE(std::string(e.what()).find("not finite"), std::string::npos);
  }
  try {
    space.Validate(V({0, 0, 0, 0, 0, 0, 2}), "q");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("quaternion is not unit"), std::string::npos);
  }
  EXPECT_NO_THROW(space.Validate(V({0, 0, 0, 0, 0, 0, 1.0001}), "q"));
}

TEST(SpaceTest, BadSpecsAreRejected) {
  EXPECT_THROW(Space(std::vector<ComponentSpec>{}), InputError);
  EXPECT_THROW(Space::RealVector(Eigen::Vector2d(1, 0), Eigen::Vector2d(0, 1)), InputError);
  EXPECT_THROW(Space({ComponentSpec{.type = ComponentType::kSE2}}), InputError);
}

TEST(SpaceTest, SamplesStayInBoundsAndAreReproducible) {
  const Space space = MakeSE3();
  std::mt19937_64 rng1(7), rng2(7);
  for (int i = 0; i < 100; ++i) {
    const Config q = space.Sample(rng1);
    EXPECT_TRUE(space.InBounds(q));
    EXPECT_NEAR(q.tail<4>().norm(), 1.0, 1e-12);
    EXPECT_TRUE(q.isApprox(space.Sample(rng2)));
  }
}

// The parts (a component's translation, its rotation) cover every coordinate once, and the
// distance is the sum of what each part alone moves: a motion of one part costs that part only,
// and interpolating the whole moves each part as interpolating it alone would.
TEST(SpaceTest, PartsCoverTheCoordinatesAndTheirDistancesAddUp) {
  const ComponentSpec se3{.type = ComponentType::kSE3,
                          .lower = Eigen::Vector3d(-1, -1, -1),
                          .upper = Eigen::Vector3d(1, 1, 1)};
  const ComponentSpec se2{.type = ComponentType::kSE2,
                          .lower = Eigen::Vector2d(0, 0),
                          .upper = Eigen::Vector2d(2, 2),
                          .translation_weight = 2.0};
  const ComponentSpec rn{.type = ComponentType::kRealVector,
                         .dimension = 3,
                         .lower = Eigen::Vector3d(0, 0, 0),
                         .upper = Eigen::Vector3d(1, 1, 1)};
  const ComponentSpec so3{.type = ComponentType::kSO3};
  for (const auto& [components, expected] :
       std::vector<std::pair<std::vector<ComponentSpec>, std::vector<std::pair<int, int>>>>{
           {{se3}, {{0, 3}, {3, 4}}},
           {{se2}, {{0, 2}, {2, 1}}},
           {{rn}, {{0, 3}}},
           {{se2, rn, so3, se3}, {{0, 2}, {2, 1}, {3, 3}, {6, 4}, {10, 3}, {13, 4}}}}) {
    const Space space(components);
    std::vector<std::pair<int, int>> parts;
    for (const Space::Part& part : space.Parts()) parts.emplace_back(part.offset, part.size);
    EXPECT_EQ(parts, expected) << "components: " << components.size();
    std::mt19937_64 rng(5);
    for (int i = 0; i < 50; ++i) {
      const Config a = space.Sample(rng);
      const Config b = space.Sample(rng);
      double sum = 0;
      for (const Space::Part& part : space.Parts()) {
        Config moved = a;
        moved.segment(part.offset, part.size) = b.segment(part.offset, part.size);
        sum += space.Distance(a, moved);
        // Halfway along, the part is where interpolating it alone puts it.
        Config half = space.Interpolate(a, moved, 0.5);
        EXPECT_TRUE(half.segment(part.offset, part.size)
                        .isApprox(space.Interpolate(a, b, 0.5).segment(part.offset, part.size)));
      }
      // acos near 1 costs sqrt(machine epsilon) where a part does not turn.
      EXPECT_NEAR(sum, space.Distance(a, b), 1e-6);
    }
  }
}

TEST(SpaceTest, MaxExtentSumsComponents) {
  const Space space = Space::SE2(Eigen::Vector2d(0, 0), Eigen::Vector2d(3, 4));
  EXPECT_NEAR(space.MaxExtent(), 5.0 + 0.5 * kPi, 1e-12);
}

TEST(SpaceTest, PoseOfSE2BodyRotatesAboutZ) {
  const Space space = Space::SE2(Eigen::Vector2d(-5, -5), Eigen::Vector2d(5, 5));
  const Eigen::Isometry3d pose = space.Pose(0, V({1, 2, kPi / 2}));
  const Eigen::Vector3d p = pose * Eigen::Vector3d(1, 0, 0);
  EXPECT_NEAR(p.x(), 1.0, 1e-12);
  EXPECT_NEAR(p.y(), 3.0, 1e-12);
}

}  // namespace
}  // namespace hgraph
