// Global alignment of two discrete paths with affine gaps (paper, Algorithm "MatchPaths", after
// Enosh et al.). A gap of L consecutive nodes costs GAP_init + L * GAP_ext; aligning p_i with q_j
// costs Delta(p_i, q_j), the configuration distance.
//
// The recurrence implemented (Gotoh's three-state form, 1-based, m = |p|, n = |q|):
//   M[i][j] = Delta(p_i, q_j) + min(M[i-1][j-1], X[i-1][j-1], Y[i-1][j-1])
//   X[i][j] = min(M[i-1][j] + GAP_init + GAP_ext, X[i-1][j] + GAP_ext,
//                 Y[i-1][j] + GAP_init + GAP_ext)          (p_i against a gap)
//   Y[i][j] = min(M[i][j-1] + GAP_init + GAP_ext, Y[i][j-1] + GAP_ext,
//                 X[i][j-1] + GAP_init + GAP_ext)          (q_j against a gap)
//   M[0][0] = 0; X[0][0] = Y[0][0] = inf; M[i][0] = M[0][j] = inf for i, j > 0;
//   X[i][0] = GAP_init + i GAP_ext; Y[0][j] = GAP_init + j GAP_ext; X[0][j] = Y[i][0] = inf;
//   cost = min(M[m][n], X[m][n], Y[m][n]).
// The paper's printed recurrence also takes min(..., 0), which with non-negative prices makes
// every entry 0 and the alignment meaningless (it is the local-alignment form); we drop it.
#pragma once

#include <functional>
#include <vector>

namespace hgraph {

struct AlignmentColumn {
  int i = -1;  // index into p, or -1 for a gap
  int j = -1;  // index into q, or -1 for a gap
};

struct Alignment {
  double cost = 0;
  std::vector<AlignmentColumn> columns;  // left to right
};

// Delta(i, j): price of aligning p_i with q_j; must be >= 0.
using AlignmentDelta = std::function<double(int i, int j)>;

// Optimal global alignment of p (m nodes) and q (n nodes); m, n >= 1. O(mn) time and memory.
Alignment AlignPaths(int m, int n, const AlignmentDelta& delta, double gap_init, double gap_extend);

// Cost of a given alignment under the same prices (used to check the dynamic program).
double AlignmentCost(const std::vector<AlignmentColumn>& columns, const AlignmentDelta& delta,
                     double gap_init, double gap_extend);

}  // namespace hgraph
