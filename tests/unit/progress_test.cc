// ThrottledProgress (core/common/progress.h): which units of a parallel phase are reported, and
// what each report carries.
#include "core/common/progress.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <vector>

#include "core/common/error.h"

namespace hgraph {
namespace {

// The `done` of every report for units 1..total finished in order.
std::vector<int64_t> ReportedUnits(int64_t total) {
  std::vector<int64_t> reported;
  const ProgressCallback callback = [&](const Progress& p) { reported.push_back(p.done); };
  const ThrottledProgress progress(callback, "check", total, std::chrono::steady_clock::now());
  for (int64_t done = 1; done <= total; ++done) progress.Done(done, 0, 0);
  return reported;
}

TEST(ThrottledProgressTest, ReportsEveryUnitOfASmallPhase) {
  EXPECT_EQ(ReportedUnits(1), (std::vector<int64_t>{1}));
  EXPECT_EQ(ReportedUnits(5), (std::vector<int64_t>{1, 2, 3, 4, 5}));
  EXPECT_EQ(ReportedUnits(100).size(), 100u);
}

TEST(ThrottledProgressTest, ReportsAboutEveryPercentAndTheLastUnit) {
  // 301 units: a step of 3, so units 3, 6, ..., 300, and 301 because it is the last.
  const std::vector<int64_t> reported = ReportedUnits(301);
  ASSERT_EQ(reported.size(), 101u);
  for (size_t i = 0; i + 1 < reported.size(); ++i) {
    EXPECT_EQ(reported[i], 3 * static_cast<int64_t>(i + 1));
  }
  EXPECT_EQ(reported.back(), 301);
  EXPECT_EQ(ReportedUnits(250000).size(), 100u);
}

TEST(ThrottledProgressTest, AReportCarriesThePhaseTotalAndCounts) {
  std::vector<Progress> reports;
  const ProgressCallback callback = [&](const Progress& p) { reports.push_back(p); };
  // Elapsed time counts from the start the caller names (the call's), not from this object.
  const ThrottledProgress progress(callback, "inputs", 2,
                                   std::chrono::steady_clock::now() - std::chrono::seconds(5));
  progress.Done(2, 17, 5);
  ASSERT_EQ(reports.size(), 1u);
  EXPECT_EQ(reports[0].phase, "inputs");
  EXPECT_EQ(reports[0].done, 2);
  EXPECT_EQ(reports[0].total, 2);
  EXPECT_EQ(reports[0].collision_checks, 17);
  EXPECT_EQ(reports[0].distance_queries, 5);
  EXPECT_GE(reports[0].elapsed_ms, 5000);
  EXPECT_TRUE(std::isnan(reports[0].objective));
}

TEST(ThrottledProgressTest, WithoutACallbackDoneDoesNothing) {
  const ProgressCallback none;
  const ThrottledProgress progress(none, "check", 3, std::chrono::steady_clock::now());
  for (int64_t done = 1; done <= 3; ++done) EXPECT_NO_THROW(progress.Done(done, 1, 1));
}

// CancelToken::WithDeadline: the child stops when its parent is cancelled or its parent's deadline
// passes, and at its own deadline; neither its deadline nor its Cancel reaches the parent.
TEST(CancelTokenTest, AChildWithADeadlineStopsWithItsParentButNeverStopsIt) {
  const auto now = std::chrono::steady_clock::now();
  const CancelToken parent;
  const CancelToken passed = parent.WithDeadline(now - std::chrono::seconds(1));
  EXPECT_TRUE(passed.deadline_passed());
  EXPECT_FALSE(passed.cancelled());
  EXPECT_FALSE(parent.stopped());
  try {
    passed.ThrowIfStopped();
    ADD_FAILURE() << "a passed deadline did not throw";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kDeadlineExceeded);
  }
  const CancelToken later = parent.WithDeadline(now + std::chrono::hours(1));
  const CancelToken grandchild = later.WithDeadline(now + std::chrono::hours(2));
  EXPECT_FALSE(grandchild.stopped());
  grandchild.Cancel();
  EXPECT_TRUE(grandchild.cancelled());
  EXPECT_FALSE(later.stopped());
  EXPECT_FALSE(parent.stopped());
  parent.Cancel();
  EXPECT_TRUE(later.cancelled());
  try {
    later.ThrowIfStopped();
    ADD_FAILURE() << "a cancelled parent did not stop its child";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kCancelled);
  }
  // A parent's passed deadline stops a child whose own deadline is later.
  const CancelToken timed;
  timed.SetDeadline(now - std::chrono::seconds(1));
  EXPECT_TRUE(timed.WithDeadline(now + std::chrono::hours(1)).deadline_passed());
}

}  // namespace
}  // namespace hgraph
