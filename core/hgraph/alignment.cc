#include "core/hgraph/alignment.h"

#include <algorithm>
#include <limits>

#include "core/common/error.h"

namespace hgraph {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// The three states of the affine-gap recurrence (see alignment.h).
enum State : uint8_t { kMatch = 0, kGapP = 1, kGapQ = 2 };

}  // namespace

Alignment AlignPaths(int m, int n, const AlignmentDelta& delta, double gap_init,
                     double gap_extend) {
  HGRAPH_CHECK(m >= 1 && n >= 1);
  const int w = n + 1;
  auto at = [w](int i, int j) { return static_cast<size_t>(i) * w + j; };
  const size_t cells = static_cast<size_t>(m + 1) * w;
  // Cost matrices and, per state, the state the optimum came from (the trace-back matrix).
  std::vector<double> cost[3] = {std::vector<double>(cells, kInf), std::vector<double>(cells, kInf),
                                 std::vector<double>(cells, kInf)};
  std::vector<uint8_t> from[3] = {std::vector<uint8_t>(cells, 0), std::vector<uint8_t>(cells, 0),
                                  std::vector<uint8_t>(cells, 0)};
  const double open = gap_init + gap_extend;
  cost[kMatch][at(0, 0)] = 0;
  for (int i = 1; i <= m; ++i) {
    cost[kGapP][at(i, 0)] = gap_init + i * gap_extend;
    from[kGapP][at(i, 0)] = i == 1 ? kMatch : kGapP;
  }
  for (int j = 1; j <= n; ++j) {
    cost[kGapQ][at(0, j)] = gap_init + j * gap_extend;
    from[kGapQ][at(0, j)] = j == 1 ? kMatch : kGapQ;
  }
  // Picks the cheapest predecessor; ties prefer match, then the gap continuing its own state.
  auto best_of = [](double a, double b, double c, uint8_t sa, uint8_t sb, uint8_t sc,
                    uint8_t* state) {
    double best = a;
    *state = sa;
    if (b < best) best = b, *state = sb;
    if (c < best) best = c, *state = sc;
    return best;
  };
  for (int i = 1; i <= m; ++i) {
    for (int j = 1; j <= n; ++j) {
      const size_t d = at(i - 1, j - 1), u = at(i - 1, j), l = at(i, j - 1), c = at(i, j);
      uint8_t s;
      const double diag =
          best_of(cost[kMatch][d], cost[kGapP][d], cost[kGapQ][d], kMatch, kGapP, kGapQ, &s);
      cost[kMatch][c] = diag + delta(i - 1, j - 1);
      from[kMatch][c] = s;
      cost[kGapP][c] = best_of(cost[kGapP][u] + gap_extend, cost[kMatch][u] + open,
                               cost[kGapQ][u] + open, kGapP, kMatch, kGapQ, &s);
      from[kGapP][c] = s;
      cost[kGapQ][c] = best_of(cost[kGapQ][l] + gap_extend, cost[kMatch][l] + open,
                               cost[kGapP][l] + open, kGapQ, kMatch, kGapP, &s);
      from[kGapQ][c] = s;
    }
  }
  Alignment result;
  uint8_t state;
  result.cost = best_of(cost[kMatch][at(m, n)], cost[kGapP][at(m, n)], cost[kGapQ][at(m, n)],
                        kMatch, kGapP, kGapQ, &state);
  int i = m, j = n;
  while (i > 0 || j > 0) {
    const uint8_t prev = from[state][at(i, j)];
    switch (state) {
      case kMatch:
        result.columns.push_back({i - 1, j - 1});
        --i;
        --j;
        break;
      case kGapP:
        result.columns.push_back({i - 1, -1});
        --i;
        break;
      case kGapQ:
        result.columns.push_back({-1, j - 1});
        --j;
        break;
    }
    state = prev;
  }
  std::reverse(result.columns.begin(), result.columns.end());
  return result;
}

double AlignmentCost(const std::vector<AlignmentColumn>& columns, const AlignmentDelta& delta,
                     double gap_init, double gap_extend) {
  double total = 0;
  int previous = kMatch;
  for (const AlignmentColumn& c : columns) {
    HGRAPH_CHECK(c.i >= 0 || c.j >= 0);
    const int state = c.i >= 0 && c.j >= 0 ? kMatch : (c.j < 0 ? kGapP : kGapQ);
    if (state == kMatch) {
      total += delta(c.i, c.j);
    } else {
      total += gap_extend + (state != previous ? gap_init : 0.0);
    }
    previous = state;
  }
  return total;
}

}  // namespace hgraph
