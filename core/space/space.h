// Configuration spaces: R^n, SO(2), SO(3), SE(2), SE(3) and products of them, with a weighted
// metric, interpolation, bounds and validation (docs/design.md, "Core model").
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <random>
#include <string>
#include <vector>

namespace hgraph {

// How far from 1 a quaternion's norm may be before it is rejected rather than renormalised
// (configurations and poses alike).
inline constexpr double kQuaternionTolerance = 1e-3;

// A configuration; its layout is given by the Space (SE(3) = x y z qx qy qz qw).
using Config = Eigen::VectorXd;

enum class ComponentType {
  kRealVector,  // R^n: n coordinates
  kSO2,         // theta
  kSO3,         // qx qy qz qw (unit quaternion)
  kSE2,         // x y theta
  kSE3,         // x y z qx qy qz qw
};

// Returns "rn", "so2", "so3", "se2" or "se3".
const char* ComponentTypeName(ComponentType type);

// One factor of a product space. Plain struct; copyable.
struct ComponentSpec {
  ComponentType type = ComponentType::kRealVector;
  int dimension = 0;  // R^n only: n >= 1. Ignored for the other types.
  // Bounds of the translational coordinates (R^n: all n; SE(2): x y; SE(3): x y z). Required
  // for R^n, SE(2) and SE(3); rotations are unbounded.
  Eigen::VectorXd lower;
  Eigen::VectorXd upper;
  // Weight of the translational part of the distance (R^n, SE(2), SE(3)).
  double translation_weight = 1.0;
  // Weight of the rotational part (SO(2), SO(3), SE(2), SE(3)); negative means the default
  // that matches OMPL: 0.5 for SE(2), 1 otherwise.
  double rotation_weight = -1.0;
  std::string name;  // optional label, e.g. "wrench1"
};

// A product of components. Immutable after construction, so safe to share between threads.
// Copyable and movable.
class Space {
 public:
  // Throws InputError naming "space.components[i].<field>" on a bad spec.
  explicit Space(std::vector<ComponentSpec> components);

  // Convenience constructors for the common single-component spaces.
  static Space RealVector(const Eigen::VectorXd& lower, const Eigen::VectorXd& upper);
  static Space SE2(const Eigen::Vector2d& lower, const Eigen::Vector2d& upper);
  static Space SE3(const Eigen::Vector3d& lower, const Eigen::Vector3d& upper);

  // Number of coordinates of a configuration.
  int dimension() const { return dimension_; }
  // Degrees of freedom (SE(3) = 6).
  int degrees_of_freedom() const;
  int num_components() const { return static_cast<int>(components_.size()); }
  const ComponentSpec& component(int i) const { return components_[i]; }
  // Index of the first coordinate of component i, and its number of coordinates.
  int offset(int i) const { return offsets_[i]; }
  int size(int i) const;

  // Weighted distance: sum over components of translation_weight * Euclidean distance plus
  // rotation_weight * angle (SO(2): wrapped |dtheta|; SO(3): acos|<q1,q2>|).
  double Distance(const Config& a, const Config& b) const;
  double ComponentDistance(int i, const Config& a, const Config& b) const;
  // Point at parameter t in [0, 1] of the straight motion from a to b (slerp for SO(3), the
  // shorter arc for SO(2)). Interpolate(a, b, 0) == a and Interpolate(a, b, 1) == b.
  Config Interpolate(const Config& a, const Config& b, double t) const;

  // Euclidean distance travelled by the reference point of component i, and the angle (radians)
  // by which its frame turns, along the straight motion from a to b. Used to bound how far any
  // point of a body moves (the clearance certificate of core/motion).
  double TranslationDistance(int i, const Config& a, const Config& b) const;
  double RotationAngle(int i, const Config& a, const Config& b) const;

  // The straight motion from a to b of the frame of a body driven by component i (Pose): at
  // parameter t of Interpolate, a point p of the body, in the frame's coordinates at a, is at
  //   t * translation + AngleAxis(t * angle, axis) * p
  // up to rounding (Eigen's slerp turns at a steady rate about one axis fixed in the frame; 2D
  // components turn about z). angle in [0, pi] (RotationAngle); axis a unit vector, z when the
  // frame does not turn.
  struct FrameMotion {
    Eigen::Vector3d translation = Eigen::Vector3d::Zero();
    Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
    double angle = 0;
  };
  FrameMotion Motion(int i, const Config& a, const Config& b) const;

  // A run of coordinates that moves on its own: a component's translation or its rotation.
  struct Part {
    int offset = 0;  // first coordinate
    int size = 0;    // number of coordinates
  };
  // The parts of a configuration, in coordinate order. Distance is the sum of the parts'
  // distances, so a motion that changes one part only costs that part's distance, and
  // interpolating a part depends on that part alone.
  std::vector<Part> Parts() const;

  // Throws InputError naming `field` if q has the wrong dimension, a NaN or infinite
  // coordinate, or a quaternion whose norm differs from 1 by more than 1e-3.
  void Validate(const Config& q, const std::string& field) const;
  // Renormalises quaternions and wraps SO(2) angles into [-pi, pi). Call after Validate.
  Config Normalize(const Config& q) const;
  // True when every translational coordinate lies within its bounds.
  bool InBounds(const Config& q) const;
  // Length of the longest straight motion in the space (as OMPL's getMaximumExtent): the sum
  // over components of weighted bound diagonals and maximal rotation distances.
  double MaxExtent() const;
  // A uniformly random configuration within the bounds (uniform rotations).
  Config Sample(std::mt19937_64& rng) const;

  // True if a rigid body can be driven by component i: R^2, R^3, SO(2), SO(3), SE(2), SE(3).
  bool CanDriveBody(int i) const;
  // Pose of a body driven by component i (2D components move in the XY plane, rotating about Z).
  Eigen::Isometry3d Pose(int i, const Config& q) const;

 private:
  double RotationWeight(int i) const;

  std::vector<ComponentSpec> components_;
  std::vector<int> offsets_;
  int dimension_ = 0;
};

}  // namespace hgraph
