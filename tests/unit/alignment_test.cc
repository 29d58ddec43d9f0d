#include "core/hgraph/alignment.h"

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <limits>
#include <random>
#include <vector>

namespace hgraph {
namespace {

// Minimum cost over every alignment of p (m) and q (n), by enumeration.
double BruteForce(int m, int n, const AlignmentDelta& delta, double gi, double ge) {
  double best = std::numeric_limits<double>::infinity();
  std::vector<AlignmentColumn> columns;
  std::function<void(int, int)> walk = [&](int i, int j) {
    if (i == m && j == n) {
      best = std::min(best, AlignmentCost(columns, delta, gi, ge));
      return;
    }
    if (i < m && j < n) {
      columns.push_back({i, j});
      walk(i + 1, j + 1);
      columns.pop_back();
    }
    if (i < m) {
      columns.push_back({i, -1});
      walk(i + 1, j);
      columns.pop_back();
    }
    if (j < n) {
      columns.push_back({-1, j});
      walk(i, j + 1);
      columns.pop_back();
    }
  };
  walk(0, 0);
  return best;
}

bool IsValidAlignment(const std::vector<AlignmentColumn>& columns, int m, int n) {
  int i = 0, j = 0;
  for (const AlignmentColumn& c : columns) {
    if (c.i < 0 && c.j < 0) return false;
    if (c.i >= 0 && c.i != i++) return false;
    if (c.j >= 0 && c.j != j++) return false;
  }
  return i == m && j == n;
}

TEST(AlignmentTest, MatchesBruteForceOnSmallRandomPaths) {
  std::mt19937_64 rng(20261123);
  std::uniform_real_distribution<double> coord(0, 10), price(0, 4);
  std::uniform_int_distribution<int> size(1, 6);
  for (int trial = 0; trial < 300; ++trial) {
    const int m = size(rng), n = size(rng);
    std::vector<Eigen::Vector2d> p(m), q(n);
    for (auto& v : p) v = {coord(rng), coord(rng)};
    for (auto& v : q) v = {coord(rng), coord(rng)};
    const double gi = trial % 3 == 0 ? 0.0 : price(rng);
    const double ge = price(rng);
    const AlignmentDelta delta = [&](int i, int j) { return (p[i] - q[j]).norm(); };
    const Alignment a = AlignPaths(m, n, delta, gi, ge);
    ASSERT_TRUE(IsValidAlignment(a.columns, m, n)) << "trial " << trial;
    EXPECT_NEAR(a.cost, AlignmentCost(a.columns, delta, gi, ge), 1e-9) << "trial " << trial;
    EXPECT_NEAR(a.cost, BruteForce(m, n, delta, gi, ge), 1e-9) << "trial " << trial;
  }
}

TEST(AlignmentTest, IdenticalPathsAlignDiagonally) {
  const std::vector<double> p = {0, 1, 2, 3, 4};
  const AlignmentDelta delta = [&](int i, int j) { return std::abs(p[i] - p[j]); };
  const Alignment a = AlignPaths(5, 5, delta, 1.0, 1.0);
  EXPECT_DOUBLE_EQ(a.cost, 0.0);
  ASSERT_EQ(a.columns.size(), 5u);
  for (int k = 0; k < 5; ++k) {
    EXPECT_EQ(a.columns[k].i, k);
    EXPECT_EQ(a.columns[k].j, k);
  }
}

TEST(AlignmentTest, DetourBecomesOneGap) {
  // q takes a far detour between its first and last two nodes; p goes straight.
  const std::vector<double> p = {0, 1, 2, 3};
  const std::vector<double> q = {0, 1, 50, 60, 50, 2, 3};
  const AlignmentDelta delta = [&](int i, int j) { return std::abs(p[i] - q[j]); };
  const Alignment a = AlignPaths(4, 7, delta, 2.0, 0.5);
  // One gap of three: 2 + 3 * 0.5.
  EXPECT_DOUBLE_EQ(a.cost, 3.5);
  int gaps = 0;
  for (const AlignmentColumn& c : a.columns) gaps += c.i < 0;
  EXPECT_EQ(gaps, 3);
}

TEST(AlignmentTest, GapInitFavoursFewerGapRuns) {
  // With a high opening price two separate single gaps cost more than one double gap, and the
  // optimum uses one run when the match prices allow it.
  const AlignmentDelta delta = [](int i, int j) { return i == j ? 0.0 : 0.1; };
  const Alignment cheap_open = AlignPaths(3, 5, delta, 0.0, 1.0);
  const Alignment dear_open = AlignPaths(3, 5, delta, 10.0, 1.0);
  EXPECT_DOUBLE_EQ(cheap_open.cost, 2.0);
  EXPECT_DOUBLE_EQ(dear_open.cost, 12.0);
}

}  // namespace
}  // namespace hgraph
