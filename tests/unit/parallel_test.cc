// ParallelFor (core/common/parallel.h) on the backend this tree was configured with: every index
// once, exceptions reach the caller, nested and concurrent loops finish. Under ThreadSanitizer
// (std backend) these also show that the helper pool's hand-offs are race free.
#include "core/common/parallel.h"

#include <gtest/gtest.h>

#include <atomic>
#include <stdexcept>
#include <thread>
#include <vector>

namespace hgraph {
namespace {

std::vector<int> CountVisits(int threads, size_t n) {
  std::vector<std::atomic<int>> visits(n);
  ParallelFor(threads, n, [&](size_t i) { visits[i].fetch_add(1); });
  std::vector<int> counts;
  for (const auto& v : visits) counts.push_back(v.load());
  return counts;
}

TEST(ParallelForTest, VisitsEveryIndexOnce) {
  for (const int threads : {1, 2, 3, 8}) {
    for (const size_t n : {size_t{0}, size_t{1}, size_t{2}, size_t{7}, size_t{1000}}) {
      EXPECT_EQ(CountVisits(threads, n), std::vector<int>(n, 1))
          << "threads " << threads << ", n " << n;
    }
  }
}

TEST(ParallelForTest, WritesOfTheBodyAreSeenByTheCaller) {
  // Plain (non-atomic) writes, one slot per index: the caller reads them after the loop.
  std::vector<double> squares(500, -1);
  ParallelFor(4, squares.size(), [&](size_t i) { squares[i] = static_cast<double>(i * i); });
  for (size_t i = 0; i < squares.size(); ++i) EXPECT_EQ(squares[i], static_cast<double>(i * i));
}

TEST(ParallelForTest, AnExceptionOfTheBodyReachesTheCaller) {
  std::atomic<int> calls{0};
  EXPECT_THROW(ParallelFor(4, 200,
                           [&](size_t i) {
                             calls.fetch_add(1);
                             if (i == 37) throw std::runtime_error("index 37");
                           }),
               std::runtime_error);
  EXPECT_GE(calls.load(), 1);
  EXPECT_LE(calls.load(), 200);
  // The pool still works afterwards.
  EXPECT_EQ(CountVisits(4, 100), std::vector<int>(100, 1));
}

TEST(ParallelForTest, NestedLoopsFinish) {
  std::vector<std::atomic<int>> visits(20 * 30);
  ParallelFor(4, 20, [&](size_t i) {
    ParallelFor(3, 30, [&](size_t j) { visits[i * 30 + j].fetch_add(1); });
  });
  for (const auto& v : visits) EXPECT_EQ(v.load(), 1);
}

TEST(ParallelForTest, LoopsOfSeveralCallersAtOnceFinish) {
  constexpr int kCallers = 6;
  std::vector<std::vector<int>> results(kCallers);
  std::vector<std::thread> callers;
  for (int c = 0; c < kCallers; ++c) {
    callers.emplace_back([&results, c] { results[c] = CountVisits(2 + c % 3, 300); });
  }
  for (auto& t : callers) t.join();
  for (const auto& r : results) EXPECT_EQ(r, std::vector<int>(300, 1));
}

// RunBeside runs both halves once and returns after both; without `beside` in order, in the
// calling thread; an exception of either reaches the caller.
TEST(RunBesideTest, RunsBothHalves) {
  for (const bool beside : {false, true}) {
    for (int round = 0; round < 200; ++round) {
      std::atomic<int> first{0};
      std::atomic<int> second{0};
      std::vector<int> order;
      RunBeside(
          beside,
          [&] {
            first.fetch_add(1);
            if (!beside) order.push_back(1);
          },
          [&] {
            second.fetch_add(1);
            if (!beside) order.push_back(2);
          });
      ASSERT_EQ(first.load(), 1);
      ASSERT_EQ(second.load(), 1);
      if (!beside) {
        EXPECT_EQ(order, (std::vector<int>{1, 2}));
      }
    }
  }
}

TEST(RunBesideTest, AnExceptionOfEitherHalfReachesTheCaller) {
  for (const bool beside : {false, true}) {
    std::atomic<bool> second_done{false};
    EXPECT_THROW(
        RunBeside(
            beside, [] { throw std::runtime_error("first"); }, [&] { second_done = true; }),
        std::runtime_error);
    EXPECT_THROW(RunBeside(
                     beside, [] {}, [] { throw std::runtime_error("second"); }),
                 std::runtime_error);
  }
  // Inside a loop's body, as a local planner's check runs.
  std::vector<std::atomic<int>> halves(64);
  ParallelFor(2, 32, [&](size_t i) {
    RunBeside(
        true, [&] { halves[2 * i].fetch_add(1); }, [&] { halves[2 * i + 1].fetch_add(1); });
  });
  for (const auto& h : halves) EXPECT_EQ(h.load(), 1);
}

}  // namespace
}  // namespace hgraph
