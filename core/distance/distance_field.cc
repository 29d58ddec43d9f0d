#include "core/distance/distance_field.h"

#include <algorithm>
#include <limits>
#include <string>

#include "core/common/error.h"
#include "core/common/limits.h"
#include "core/common/parallel.h"

namespace hgraph {

DistanceField::DistanceField(const CollisionWorld& world, const Eigen::AlignedBox3d& box,
                             double cell_size, int64_t max_cells, int threads)
    : origin_(box.min()), cell_size_(cell_size) {
  if (!std::isfinite(cell_size) || cell_size <= 0) {
    throw InputError("cell_size", "must be positive and finite, got " + limits::Num(cell_size));
  }
  HGRAPH_CHECK(!box.isEmpty());
  inverse_cell_ = 1 / cell_size;
  double total = 1;
  for (int d = 0; d < 3; ++d) {
    const double n = std::floor(box.sizes()[d] / cell_size) + 2;
    total *= n;
    if (!(total <= static_cast<double>(max_cells))) {
      throw InputError("max_cells", "a grid of spacing " + limits::Num(cell_size) +
                                        " over a box of " + limits::Num(box.sizes().maxCoeff()) +
                                        " needs more than " + limits::Num(max_cells) + " points");
    }
    counts_[d] = static_cast<int>(n);
  }
  stride_ = {int64_t{counts_[1]} * counts_[2], counts_[2], 1};
  values_.resize(static_cast<size_t>(total));
  // One row of k per task, each task with its own query context (contexts are per thread).
  const size_t rows = static_cast<size_t>(counts_[0]) * counts_[1];
  constexpr size_t kRowsPerTask = 16;
  const size_t tasks = (rows + kRowsPerTask - 1) / kRowsPerTask;
  ParallelFor(threads > 0 ? threads : DefaultConcurrency(), tasks, [&](size_t task) {
    std::unique_ptr<CollisionContext> context = world.MakeContext();
    const size_t end = std::min(rows, (task + 1) * kRowsPerTask);
    for (size_t row = task * kRowsPerTask; row < end; ++row) {
      const int64_t i = static_cast<int64_t>(row) / counts_[1];
      const int64_t j = static_cast<int64_t>(row) % counts_[1];
      for (int64_t k = 0; k < counts_[2]; ++k) {
        const double d = std::max(0.0, context->ObstacleDistance(Point(i, j, k)));
        // Rounded down: the stored value must never exceed the distance.
        float f =
            static_cast<float>(std::min(d, static_cast<double>(std::numeric_limits<float>::max())));
        if (static_cast<double>(f) > d) f = std::nextafter(f, 0.0f);
        values_[i * stride_[0] + j * stride_[1] + k] = f;
      }
    }
  });
}

}  // namespace hgraph
