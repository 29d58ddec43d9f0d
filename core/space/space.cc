#include "core/space/space.h"

#include <cmath>
#include <numbers>

#include "core/common/error.h"
#include "core/common/limits.h"

namespace hgraph {
namespace {

constexpr double kPi = std::numbers::pi;

double WrapAngle(double a) {
  a = std::fmod(a + kPi, 2 * kPi);
  if (a < 0) a += 2 * kPi;
  return a - kPi;
}

int TranslationSize(const ComponentSpec& c) {
  switch (c.type) {
    case ComponentType::kRealVector: return c.dimension;
    case ComponentType::kSE2: return 2;
    case ComponentType::kSE3: return 3;
    default: return 0;
  }
}

// Offset of the rotation coordinates inside the component, or -1 if there are none.
int RotationOffset(ComponentType type) {
  switch (type) {
    case ComponentType::kSO2: return 0;
    case ComponentType::kSO3: return 0;
    case ComponentType::kSE2: return 2;
    case ComponentType::kSE3: return 3;
    default: return -1;
  }
}

bool IsSO3Like(ComponentType type) {
  return type == ComponentType::kSO3 || type == ComponentType::kSE3;
}
bool IsSO2Like(ComponentType type) {
  return type == ComponentType::kSO2 || type == ComponentType::kSE2;
}

Eigen::Quaterniond QuaternionAt(const Config& q, int at) {
  // Stored as x y z w.
  return Eigen::Quaterniond(q[at + 3], q[at], q[at + 1], q[at + 2]);
}

void PutQuaternion(const Eigen::Quaterniond& r, Config& q, int at) {
  q[at] = r.x();
  q[at + 1] = r.y();
  q[at + 2] = r.z();
  q[at + 3] = r.w();
}

double QuaternionDot(const Config& a, const Config& b, int at) {
  double d = 0;
  for (int k = 0; k < 4; ++k) d += a[at + k] * b[at + k];
  return std::min(1.0, std::abs(d));
}

}  // namespace

const char* ComponentTypeName(ComponentType type) {
  switch (type) {
    case ComponentType::kRealVector: return "rn";
    case ComponentType::kSO2: return "so2";
    case ComponentType::kSO3: return "so3";
    case ComponentType::kSE2: return "se2";
    case ComponentType::kSE3: return "se3";
  }
  return "?";
}

Space::Space(std::vector<ComponentSpec> components) : components_(std::move(components)) {
  if (components_.empty())
    throw InputError("space.components", "a space needs at least one component");
  for (int i = 0; i < num_components(); ++i) {
    const std::string field = "space.components[" + std::to_string(i) + "]";
    ComponentSpec& c = components_[i];
    if (c.type == ComponentType::kRealVector && c.dimension < 1) {
      throw InputError(field + ".dimension",
                       "R^n needs dimension >= 1, got " + std::to_string(c.dimension));
    }
    const int t = TranslationSize(c);
    if (t > 0) {
      if (c.lower.size() != t || c.upper.size() != t) {
        throw InputError(field + ".lower", "needs " + std::to_string(t) +
                                               " lower and upper bounds, got " +
                                               std::to_string(c.lower.size()) + " and " +
                                               std::to_string(c.upper.size()));
      }
      for (int k = 0; k < t; ++k) {
        if (!std::isfinite(c.lower[k]) || !std::isfinite(c.upper[k]) ||
            !(c.lower[k] < c.upper[k])) {
          throw InputError(field + ".upper[" + std::to_string(k) + "]",
                           "bounds must be finite with lower < upper, got [" +
                               std::to_string(c.lower[k]) + ", " + std::to_string(c.upper[k]) +
                               "]");
        }
        // Larger bounds overflow the extent (upper - lower), and with it every sample count.
        for (const auto& [name, v] : {std::pair{".lower[", c.lower[k]}, {".upper[", c.upper[k]}}) {
          if (std::abs(v) > limits::kMaxCoordinate) {
            throw InputError(field + name + std::to_string(k) + "]",
                             "must be in [-" + limits::Num(limits::kMaxCoordinate) + ", " +
                                 limits::Num(limits::kMaxCoordinate) + "], got " + limits::Num(v));
          }
        }
      }
    }
    limits::RequireRange(c.translation_weight, 0, limits::kMaxWeight,
                         field + ".translation_weight");
    if (c.rotation_weight < 0) c.rotation_weight = c.type == ComponentType::kSE2 ? 0.5 : 1.0;
    limits::RequireRange(c.rotation_weight, 0, limits::kMaxWeight, field + ".rotation_weight");
    offsets_.push_back(dimension_);
    dimension_ += size(i);
  }
  // A zero extent (every weight 0) makes every motion one sample long: nothing would be checked
  // between its ends.
  if (!(MaxExtent() > 0)) {
    throw InputError("space.components",
                     "the weighted extent of the space is 0: give a component a weight > 0");
  }
}

Space Space::RealVector(const Eigen::VectorXd& lower, const Eigen::VectorXd& upper) {
  return Space({ComponentSpec{.type = ComponentType::kRealVector,
                              .dimension = static_cast<int>(lower.size()),
                              .lower = lower,
                              .upper = upper}});
}

Space Space::SE2(const Eigen::Vector2d& lower, const Eigen::Vector2d& upper) {
  return Space({ComponentSpec{.type = ComponentType::kSE2, .lower = lower, .upper = upper}});
}

Space Space::SE3(const Eigen::Vector3d& lower, const Eigen::Vector3d& upper) {
  return Space({ComponentSpec{.type = ComponentType::kSE3, .lower = lower, .upper = upper}});
}

int Space::size(int i) const {
  const ComponentSpec& c = components_[i];
  switch (c.type) {
    case ComponentType::kRealVector: return c.dimension;
    case ComponentType::kSO2: return 1;
    case ComponentType::kSO3: return 4;
    case ComponentType::kSE2: return 3;
    case ComponentType::kSE3: return 7;
  }
  return 0;
}

int Space::degrees_of_freedom() const {
  int dof = 0;
  for (int i = 0; i < num_components(); ++i) {
    dof += IsSO3Like(components_[i].type) ? size(i) - 1 : size(i);
  }
  return dof;
}

double Space::RotationWeight(int i) const { return components_[i].rotation_weight; }

double Space::TranslationDistance(int i, const Config& a, const Config& b) const {
  const int t = TranslationSize(components_[i]);
  if (t == 0) return 0.0;
  return (a.segment(offsets_[i], t) - b.segment(offsets_[i], t)).norm();
}

double Space::RotationAngle(int i, const Config& a, const Config& b) const {
  const ComponentType type = components_[i].type;
  const int r = RotationOffset(type);
  if (r < 0) return 0.0;
  const int at = offsets_[i] + r;
  if (IsSO2Like(type)) return std::abs(WrapAngle(b[at] - a[at]));
  return 2.0 * std::acos(QuaternionDot(a, b, at));
}

Space::FrameMotion Space::Motion(int i, const Config& a, const Config& b) const {
  FrameMotion motion;
  const Eigen::Isometry3d from = Pose(i, a);
  motion.translation = from.linear().transpose() * (Pose(i, b).translation() - from.translation());
  const ComponentType type = components_[i].type;
  const int r = RotationOffset(type);
  if (r < 0) return motion;
  const int at = offsets_[i] + r;
  if (IsSO2Like(type)) {
    const double turn = WrapAngle(b[at] - a[at]);
    motion.angle = std::abs(turn);
    if (turn < 0) motion.axis = -Eigen::Vector3d::UnitZ();
    return motion;
  }
  // Slerp from qa towards qb, or -qb when that is the shorter arc: qa * relative^t.
  const Eigen::Quaterniond qa = QuaternionAt(a, at).normalized();
  Eigen::Quaterniond qb = QuaternionAt(b, at).normalized();
  if (qa.dot(qb) < 0) qb.coeffs() = -qb.coeffs();
  const Eigen::Quaterniond relative = qa.conjugate() * qb;
  const double sine = relative.vec().norm();
  motion.angle = 2 * std::atan2(sine, std::abs(relative.w()));
  if (sine > 0) motion.axis = (relative.w() < 0 ? -1.0 : 1.0) * relative.vec() / sine;
  return motion;
}

double Space::ComponentDistance(int i, const Config& a, const Config& b) const {
  const ComponentSpec& c = components_[i];
  double d = c.translation_weight * TranslationDistance(i, a, b);
  const int r = RotationOffset(c.type);
  if (r >= 0) {
    const int at = offsets_[i] + r;
    const double angle =
        IsSO2Like(c.type) ? std::abs(WrapAngle(b[at] - a[at])) : std::acos(QuaternionDot(a, b, at));
    d += RotationWeight(i) * angle;
  }
  return d;
}

double Space::Distance(const Config& a, const Config& b) const {
  double d = 0;
  for (int i = 0; i < num_components(); ++i) d += ComponentDistance(i, a, b);
  return d;
}

std::vector<Space::Part> Space::Parts() const {
  std::vector<Part> parts;
  for (int i = 0; i < num_components(); ++i) {
    const int t = TranslationSize(components_[i]);
    if (t > 0) parts.push_back(Part{.offset = offsets_[i], .size = t});
    const int r = RotationOffset(components_[i].type);
    if (r >= 0) parts.push_back(Part{.offset = offsets_[i] + r, .size = size(i) - r});
  }
  return parts;
}

Config Space::Interpolate(const Config& a, const Config& b, double t) const {
  if (t <= 0) return a;
  if (t >= 1) return b;
  Config q = a + t * (b - a);
  for (int i = 0; i < num_components(); ++i) {
    const ComponentType type = components_[i].type;
    const int r = RotationOffset(type);
    if (r < 0) continue;
    const int at = offsets_[i] + r;
    if (IsSO2Like(type)) {
      q[at] = WrapAngle(a[at] + t * WrapAngle(b[at] - a[at]));
    } else {
      const Eigen::Quaterniond qa = QuaternionAt(a, at);
      const Eigen::Quaterniond qb = QuaternionAt(b, at);
      // Eigen's slerp takes the shorter arc (it flips the sign of qb when <qa,qb> < 0).
      PutQuaternion(qa.slerp(t, qb).normalized(), q, at);
    }
  }
  return q;
}

void Space::Validate(const Config& q, const std::string& field) const {
  if (q.size() != dimension_) {
    throw InputError(field, "expected " + std::to_string(dimension_) + " coordinates, got " +
                                std::to_string(q.size()));
  }
  for (int k = 0; k < q.size(); ++k) {
    if (!std::isfinite(q[k])) {
      throw InputError(field + "[" + std::to_string(k) + "]", "coordinate is not finite");
    }
    // Farther coordinates make edge lengths (and sample counts) overflow.
    if (std::abs(q[k]) > limits::kMaxCoordinate) {
      throw InputError(field + "[" + std::to_string(k) + "]",
                       "coordinate must be in [-" + limits::Num(limits::kMaxCoordinate) + ", " +
                           limits::Num(limits::kMaxCoordinate) + "], got " + limits::Num(q[k]));
    }
  }
  for (int i = 0; i < num_components(); ++i) {
    if (!IsSO3Like(components_[i].type)) continue;
    const int at = offsets_[i] + RotationOffset(components_[i].type);
    const double norm = q.segment(at, 4).norm();
    if (std::abs(norm - 1.0) > kQuaternionTolerance) {
      throw InputError(field + "[" + std::to_string(at) + ":" + std::to_string(at + 4) + "]",
                       "quaternion is not unit (norm " + std::to_string(norm) + ")");
    }
  }
}

Config Space::Normalize(const Config& q) const {
  Config out = q;
  for (int i = 0; i < num_components(); ++i) {
    const ComponentType type = components_[i].type;
    const int r = RotationOffset(type);
    if (r < 0) continue;
    const int at = offsets_[i] + r;
    if (IsSO2Like(type)) {
      out[at] = WrapAngle(out[at]);
    } else {
      out.segment(at, 4).normalize();
    }
  }
  return out;
}

bool Space::InBounds(const Config& q) const {
  for (int i = 0; i < num_components(); ++i) {
    const ComponentSpec& c = components_[i];
    const int t = TranslationSize(c);
    for (int k = 0; k < t; ++k) {
      const double v = q[offsets_[i] + k];
      if (v < c.lower[k] || v > c.upper[k]) return false;
    }
  }
  return true;
}

double Space::MaxExtent() const {
  double e = 0;
  for (int i = 0; i < num_components(); ++i) {
    const ComponentSpec& c = components_[i];
    if (TranslationSize(c) > 0) e += c.translation_weight * (c.upper - c.lower).norm();
    if (IsSO2Like(c.type)) e += RotationWeight(i) * kPi;
    if (IsSO3Like(c.type)) e += RotationWeight(i) * kPi / 2;
  }
  return e;
}

Config Space::Sample(std::mt19937_64& rng) const {
  Config q(dimension_);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int i = 0; i < num_components(); ++i) {
    const ComponentSpec& c = components_[i];
    const int t = TranslationSize(c);
    for (int k = 0; k < t; ++k) {
      q[offsets_[i] + k] = c.lower[k] + unit(rng) * (c.upper[k] - c.lower[k]);
    }
    const int r = RotationOffset(c.type);
    if (r < 0) continue;
    const int at = offsets_[i] + r;
    if (IsSO2Like(c.type)) {
      q[at] = -kPi + 2 * kPi * unit(rng);
    } else {
      Eigen::Vector4d v;
      do {
        for (int k = 0; k < 4; ++k) v[k] = normal(rng);
      } while (v.norm() < 1e-9);
      q.segment(at, 4) = v.normalized();
    }
  }
  return q;
}

bool Space::CanDriveBody(int i) const {
  const ComponentSpec& c = components_[i];
  if (c.type == ComponentType::kRealVector) return c.dimension == 2 || c.dimension == 3;
  return true;
}

Eigen::Isometry3d Space::Pose(int i, const Config& q) const {
  const ComponentSpec& c = components_[i];
  const int at = offsets_[i];
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  switch (c.type) {
    case ComponentType::kRealVector:
      HGRAPH_CHECK(c.dimension == 2 || c.dimension == 3);
      pose.translation().head(c.dimension) = q.segment(at, c.dimension);
      break;
    case ComponentType::kSO2:
      pose.linear() = Eigen::AngleAxisd(q[at], Eigen::Vector3d::UnitZ()).toRotationMatrix();
      break;
    case ComponentType::kSO3:
      pose.linear() = QuaternionAt(q, at).normalized().toRotationMatrix();
      break;
    case ComponentType::kSE2:
      pose.translation().head<2>() = q.segment<2>(at);
      pose.linear() = Eigen::AngleAxisd(q[at + 2], Eigen::Vector3d::UnitZ()).toRotationMatrix();
      break;
    case ComponentType::kSE3:
      pose.translation() = q.segment<3>(at);
      pose.linear() = QuaternionAt(q, at + 3).normalized().toRotationMatrix();
      break;
  }
  return pose;
}

}  // namespace hgraph
