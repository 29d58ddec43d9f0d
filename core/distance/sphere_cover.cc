#include "core/distance/sphere_cover.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>

#include "core/common/error.h"

namespace hgraph {
namespace {

// Radii grow by this fraction (and an absolute sliver) so that rounding in the centre's
// computation never leaves a vertex outside its sphere.
constexpr double kRadiusSlack = 1e-12;

// A sphere holding the three points: the smallest one (the longest edge's midpoint for a right
// or obtuse triangle, else the circumcentre), with the radius measured to the points, so that
// it holds them even where the centre's formula loses precision.
CoverSphere TriangleSphere(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                           const Eigen::Vector3d& c) {
  const Eigen::Vector3d* p[3] = {&a, &b, &c};
  // Longest edge p[i]p[j], opposite vertex p[k].
  int i = 0, j = 1, k = 2;
  double longest = (a - b).squaredNorm();
  if ((b - c).squaredNorm() > longest) {
    longest = (b - c).squaredNorm();
    i = 1, j = 2, k = 0;
  }
  if ((c - a).squaredNorm() > longest) i = 2, j = 0, k = 1;
  Eigen::Vector3d centre = 0.5 * (*p[i] + *p[j]);
  const Eigen::Vector3d u = b - a;
  const Eigen::Vector3d v = c - a;
  const Eigen::Vector3d w = u.cross(v);
  if ((*p[i] - *p[k]).dot(*p[j] - *p[k]) > 0 && w.squaredNorm() > 0) {
    centre =
        a + (u.squaredNorm() * v.cross(w) + v.squaredNorm() * w.cross(u)) / (2 * w.squaredNorm());
  }
  const double r = std::max({(a - centre).norm(), (b - centre).norm(), (c - centre).norm()});
  return CoverSphere{.centre = centre, .radius = r * (1 + kRadiusSlack) + kRadiusSlack};
}

void CoverTriangle(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                   double max_radius, int pieces_left, std::vector<CoverSphere>& out) {
  const CoverSphere s = TriangleSphere(a, b, c);
  if (s.radius <= max_radius || pieces_left < 2) {
    out.push_back(s);
    return;
  }
  // Two halves through the longest edge's midpoint: slivers (most of a rod's triangles) shrink
  // at the rate of quartering at half its spheres.
  const double ab = (a - b).squaredNorm(), bc = (b - c).squaredNorm(), ca = (c - a).squaredNorm();
  const int each = pieces_left / 2;
  if (ab >= bc && ab >= ca) {
    const Eigen::Vector3d m = 0.5 * (a + b);
    CoverTriangle(a, m, c, max_radius, each, out);
    CoverTriangle(m, b, c, max_radius, each, out);
  } else if (bc >= ca) {
    const Eigen::Vector3d m = 0.5 * (b + c);
    CoverTriangle(a, b, m, max_radius, each, out);
    CoverTriangle(a, m, c, max_radius, each, out);
  } else {
    const Eigen::Vector3d m = 0.5 * (c + a);
    CoverTriangle(a, b, m, max_radius, each, out);
    CoverTriangle(m, b, c, max_radius, each, out);
  }
}

void CoverBox(const Eigen::Vector3d& size, double max_radius, int max_pieces,
              std::vector<CoverSphere>& out) {
  // Cubes of side 2 r / sqrt(3) have half-diagonal r.
  const double side = 2 * max_radius / std::sqrt(3.0);
  Eigen::Vector3i n;
  for (int d = 0; d < 3; ++d) {
    n[d] = std::max(1, static_cast<int>(std::ceil(size[d] / side)));
  }
  while (static_cast<int64_t>(n[0]) * n[1] * n[2] > max_pieces) {
    int widest = 0;
    for (int d = 1; d < 3; ++d) {
      if (n[d] > n[widest]) widest = d;
    }
    n[widest] = std::max(1, n[widest] / 2);
  }
  const Eigen::Vector3d piece = size.cwiseQuotient(n.cast<double>());
  const double radius = 0.5 * piece.norm() * (1 + kRadiusSlack) + kRadiusSlack;
  for (int x = 0; x < n[0]; ++x) {
    for (int y = 0; y < n[1]; ++y) {
      for (int z = 0; z < n[2]; ++z) {
        const Eigen::Vector3d centre =
            -0.5 * size + piece.cwiseProduct(Eigen::Vector3d(x + 0.5, y + 0.5, z + 0.5));
        out.push_back({.centre = centre, .radius = radius});
      }
    }
  }
}

// Builds nodes over spheres[order[begin..end)) and returns the node's index.
int BuildTree(SphereCover& cover, std::vector<int>& order, int begin, int end) {
  const int at = static_cast<int>(cover.nodes.size());
  cover.nodes.emplace_back();
  if (end - begin == 1) {
    cover.nodes[at].sphere = cover.spheres[order[begin]];
    cover.nodes[at].index = order[begin];
    return at;
  }
  Eigen::AlignedBox3d box;
  for (int i = begin; i < end; ++i) box.extend(cover.spheres[order[i]].centre);
  int axis = 0;
  box.sizes().maxCoeff(&axis);
  const int mid = begin + (end - begin) / 2;
  std::nth_element(
      order.begin() + begin, order.begin() + mid, order.begin() + end,
      [&](int x, int y) { return cover.spheres[x].centre[axis] < cover.spheres[y].centre[axis]; });
  const int left = BuildTree(cover, order, begin, mid);
  const int right = BuildTree(cover, order, mid, end);
  const Eigen::Vector3d centre = box.center();
  double radius = 0;
  for (int i = begin; i < end; ++i) {
    const CoverSphere& s = cover.spheres[order[i]];
    radius = std::max(radius, (s.centre - centre).norm() + s.radius);
  }
  SphereCover::Node& node = cover.nodes[at];
  node.sphere = {.centre = centre, .radius = radius * (1 + kRadiusSlack) + kRadiusSlack};
  node.left = left;
  node.right = right;
  return at;
}

double PairBound(const SphereCover& a, const Eigen::Isometry3d& pa, int na, const SphereCover& b,
                 const Eigen::Isometry3d& pb, int nb, double best) {
  const SphereCover::Node& x = a.nodes[na];
  const SphereCover::Node& y = b.nodes[nb];
  const double bound =
      (pa * x.sphere.centre - pb * y.sphere.centre).norm() - x.sphere.radius - y.sphere.radius;
  if (bound >= best) return best;
  const bool x_leaf = x.left < 0;
  const bool y_leaf = y.left < 0;
  if (x_leaf && y_leaf) return bound;
  // Descend the larger node.
  if (y_leaf || (!x_leaf && x.sphere.radius >= y.sphere.radius)) {
    best = PairBound(a, pa, x.left, b, pb, nb, best);
    return PairBound(a, pa, x.right, b, pb, nb, best);
  }
  best = PairBound(a, pa, na, b, pb, y.left, best);
  return PairBound(a, pa, na, b, pb, y.right, best);
}

}  // namespace

SphereCover CoverShape(const Shape& shape, double max_radius, int max_pieces) {
  if (!std::isfinite(max_radius) || max_radius <= 0) {
    throw InputError("max_radius",
                     "must be positive and finite, got " + std::to_string(max_radius));
  }
  SphereCover cover;
  switch (shape.type) {
    case ShapeType::kSphere: cover.spheres.push_back({.radius = shape.radius}); break;
    case ShapeType::kBox: CoverBox(shape.box_size, max_radius, max_pieces, cover.spheres); break;
    case ShapeType::kCylinder: {
      // Slabs along the axis, each in the sphere through its rims.
      const double slab = 2 * std::max(shape.radius, max_radius);
      const int n = std::clamp(static_cast<int>(std::ceil(shape.length / slab)), 1, max_pieces);
      const double half = 0.5 * shape.length / n;
      const double radius = std::hypot(shape.radius, half) * (1 + kRadiusSlack) + kRadiusSlack;
      for (int i = 0; i < n; ++i) {
        cover.spheres.push_back(
            {.centre = Eigen::Vector3d(0, 0, -0.5 * shape.length + (2 * i + 1) * half),
             .radius = radius});
      }
      break;
    }
    case ShapeType::kMesh:
      HGRAPH_CHECK(shape.mesh != nullptr);
      for (const Eigen::Vector3i& t : shape.mesh->triangles) {
        CoverTriangle(shape.mesh->vertices[t[0]], shape.mesh->vertices[t[1]],
                      shape.mesh->vertices[t[2]], max_radius, max_pieces, cover.spheres);
      }
      break;
  }
  if (cover.spheres.empty()) return cover;
  std::vector<int> order(cover.spheres.size());
  std::iota(order.begin(), order.end(), 0);
  cover.nodes.reserve(2 * cover.spheres.size());
  BuildTree(cover, order, 0, static_cast<int>(order.size()));
  return cover;
}

double CoverDistanceLowerBound(const SphereCover& a, const Eigen::Isometry3d& pa,
                               const SphereCover& b, const Eigen::Isometry3d& pb, double best) {
  if (a.nodes.empty() || b.nodes.empty()) return best;
  return PairBound(a, pa, 0, b, pb, 0, best);
}

}  // namespace hgraph
