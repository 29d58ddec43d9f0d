#include "core/collision/collision_world.h"

#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/geometry/bvh/BVH_model.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/cylinder.h>
#include <fcl/geometry/shape/sphere.h>
#include <fcl/math/bv/OBBRSS.h>
#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/distance.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <utility>
#include <vector>

#include "core/collision/free_motion.h"
#include "core/common/error.h"

namespace hgraph {
namespace {

// OBBRSS only: FCL's traversal for the other BV types transforms the vertices of a shared model
// in place, which is both slower and a data race between threads.
using MeshModel = fcl::BVHModel<fcl::OBBRSSd>;
using GeometryPtr = std::shared_ptr<fcl::CollisionGeometryd>;

// Distances of primitive pairs without a closed form (box-box, box-cylinder, ...) go through GJK.
// FCL 0.7's libccd GJK returns distances off by up to 0.15 for a turned box against a box, while
// its own GJK (GST_INDEP) is right to the tolerance. Clearance feeds a certificate that sums and
// compares distances, so the tolerance is tighter than the default 1e-6.
constexpr fcl::GJKSolverType kDistanceSolver = fcl::GST_INDEP;
constexpr double kGjkDistanceTolerance = 1e-9;

std::shared_ptr<MeshModel> BuildMesh(const Mesh& mesh) {
  auto model = std::make_shared<MeshModel>();
  std::vector<fcl::Vector3d> points(mesh.vertices.begin(), mesh.vertices.end());
  std::vector<fcl::Triangle> triangles;
  triangles.reserve(mesh.triangles.size());
  for (const Eigen::Vector3i& t : mesh.triangles) triangles.emplace_back(t[0], t[1], t[2]);
  HGRAPH_CHECK(model->beginModel(static_cast<int>(triangles.size()),
                                 static_cast<int>(points.size())) == fcl::BVH_OK);
  HGRAPH_CHECK(model->addSubModel(points, triangles) == fcl::BVH_OK);
  HGRAPH_CHECK(model->endModel() == fcl::BVH_OK);
  return model;
}

// Meshes shared between objects (the same Mesh pointer) get one BVH.
class GeometryBuilder {
 public:
  GeometryPtr Build(const Shape& shape) {
    switch (shape.type) {
      case ShapeType::kBox:
        return std::make_shared<fcl::Boxd>(shape.box_size.x(), shape.box_size.y(),
                                           shape.box_size.z());
      case ShapeType::kSphere:
        // FCL's sphere code is analytic (sphere-box, sphere-cylinder, sphere-sphere, sphere-
        // triangle) and handles radius 0 exactly, so a point robot needs no stand-in radius.
        return std::make_shared<fcl::Sphered>(shape.radius);
      case ShapeType::kCylinder:
        return std::make_shared<fcl::Cylinderd>(shape.radius, shape.length);
      case ShapeType::kMesh: {
        auto [it, inserted] = meshes_.try_emplace(shape.mesh.get());
        if (inserted) {
          auto model = BuildMesh(*shape.mesh);
          bytes_ += static_cast<size_t>(model->memUsage(0));
          it->second = std::move(model);
        }
        return it->second;
      }
    }
    HGRAPH_CHECK(false);
    return nullptr;
  }
  size_t bytes() const { return bytes_; }

 private:
  std::map<const Mesh*, GeometryPtr> meshes_;
  size_t bytes_ = 0;
};

// Farthest point of the shape from `origin`, where origin is expressed in the shape's frame.
double FarthestDistance(const Shape& shape, const Eigen::Vector3d& origin) {
  switch (shape.type) {
    case ShapeType::kBox: {
      double best = 0;
      for (int corner = 0; corner < 8; ++corner) {
        const Eigen::Vector3d p(corner & 1 ? 0.5 : -0.5, corner & 2 ? 0.5 : -0.5,
                                corner & 4 ? 0.5 : -0.5);
        best = std::max(best, (p.cwiseProduct(shape.box_size) - origin).norm());
      }
      return best;
    }
    case ShapeType::kSphere: return origin.norm() + shape.radius;
    case ShapeType::kCylinder: {
      // The farthest point lies on a rim, on the side away from the origin's axis projection.
      const double radial = origin.head<2>().norm() + shape.radius;
      const double axial = std::abs(origin.z()) + shape.length / 2;
      return std::hypot(radial, axial);
    }
    case ShapeType::kMesh: {
      double best = 0;
      for (const Eigen::Vector3d& v : shape.mesh->vertices)
        best = std::max(best, (v - origin).norm());
      return best;
    }
  }
  HGRAPH_CHECK(false);
  return 0;
}

void SetPose(fcl::CollisionObjectd& object, const Eigen::Isometry3d& pose) {
  object.setTransform(pose.linear(), pose.translation());
  object.computeAABB();
}

struct CollideData {
  fcl::CollisionRequestd request;
  bool hit = false;
};

bool CollideCallback(fcl::CollisionObjectd* a, fcl::CollisionObjectd* b, void* data) {
  auto* d = static_cast<CollideData*>(data);
  if (d->hit) return true;
  fcl::CollisionResultd result;
  fcl::collide(a, b, d->request, result);
  d->hit = result.isCollision();
  return d->hit;
}

struct DistanceData {
  fcl::DistanceRequestd request;
  double min_distance = std::numeric_limits<double>::infinity();
  // With nearest points requested: the robot body queried against the obstacles, and the
  // nearest points (world frame) of the pair that gave min_distance, the body's first.
  const fcl::CollisionObjectd* body = nullptr;
  bool found = false;
  fcl::Vector3d nearest[2];
};

// The smaller of `bound` and the distance between a and b. FCL's traversal starts from the
// result's min_distance and prunes every bounding volume no nearer than it, so a pair farther
// than `bound` (the clearance found so far) costs a few volume tests instead of a whole
// traversal; a nearer pair's distance is found exactly as from infinity. With nearest points
// requested, a nearer pair's points (a's first) replace those in `nearest`.
double PairDistance(const fcl::CollisionObjectd* a, const fcl::CollisionObjectd* b,
                    const fcl::DistanceRequestd& request, double bound, bool* found = nullptr,
                    fcl::Vector3d* nearest = nullptr) {
  fcl::DistanceResultd result;
  // FCL's own start is the largest double.
  if (bound < result.min_distance) result.min_distance = bound;
  fcl::distance(a, b, request, result);
  if (request.enable_nearest_points && result.min_distance < bound) {
    *found = true;
    nearest[0] = result.nearest_points[0];
    nearest[1] = result.nearest_points[1];
  }
  // In collision FCL reports an implementation-defined value (-1 for GJK pairs).
  return std::max(0.0, std::min(bound, result.min_distance));
}

bool DistanceCallback(fcl::CollisionObjectd* a, fcl::CollisionObjectd* b, void* data,
                      double& dist) {
  auto* d = static_cast<DistanceData*>(data);
  // The body's nearest point first, whichever side the broad phase puts it on.
  const bool body_first = a == d->body;
  d->min_distance = PairDistance(body_first ? a : b, body_first ? b : a, d->request,
                                 d->min_distance, &d->found, d->nearest);
  // The broad phase prunes subtrees farther than `dist`.
  dist = d->min_distance;
  return d->min_distance <= 0;
}

}  // namespace

struct CollisionWorld::Impl {
  // Prototypes of the robot bodies' collision objects. A context copies them: FCL's
  // CollisionObject constructor rewrites the shared geometry's local AABB, which would race with
  // queries running in other threads, while a copy shares the geometry without touching it.
  std::vector<std::unique_ptr<fcl::CollisionObjectd>> body_prototypes;
  std::vector<int> body_component;
  std::vector<Eigen::Isometry3d> body_offset;
  std::vector<double> body_radius;
  // Bodies driven by the same component are one rigid body: never checked against each other.
  std::vector<std::pair<int, int>> self_pairs;

  // Declared before the manager, which holds raw pointers to them.
  std::vector<std::unique_ptr<fcl::CollisionObjectd>> obstacles;
  // Queries of one object against the manager (collide(obj, ...), distance(obj, ...)) are const
  // and only read the tree and the obstacle objects, so every thread shares this one.
  fcl::DynamicAABBTreeCollisionManagerd obstacle_manager;

  size_t memory_bytes = 0;
  // Every robot body and obstacle is a mesh: the nearest points FCL reports are those of two
  // triangles, exactly (ClearanceFrom starts from them). Between a triangle and a primitive GJK
  // finds them to its tolerance, and double_wrench's boxes showed witness pairs nearer than the
  // clearance FCL reported a moment later, so a scene with primitives starts every query afresh.
  bool meshes_only = true;
};

CollisionWorld::CollisionWorld(std::shared_ptr<const Scene> scene)
    : scene_(std::move(scene)), impl_(std::make_unique<Impl>()) {
  HGRAPH_CHECK(scene_ != nullptr);
  ValidateScene(*scene_);
  GeometryBuilder builder;
  Impl& w = *impl_;

  const int num_bodies = static_cast<int>(scene_->robot.size());
  for (int i = 0; i < num_bodies; ++i) {
    const RobotBody& body = scene_->robot[i];
    w.body_prototypes.push_back(std::make_unique<fcl::CollisionObjectd>(builder.Build(body.shape)));
    w.body_component.push_back(body.component);
    w.body_offset.push_back(body.offset);
    w.body_radius.push_back(FarthestDistance(body.shape, body.offset.inverse().translation()));
    w.meshes_only = w.meshes_only && body.shape.type == ShapeType::kMesh;
  }
  if (scene_->self_collision) {
    for (int i = 0; i < num_bodies; ++i) {
      for (int j = i + 1; j < num_bodies; ++j) {
        if (w.body_component[i] != w.body_component[j]) w.self_pairs.emplace_back(i, j);
      }
    }
  }

  std::vector<fcl::CollisionObjectd*> registered;
  for (const Obstacle& obstacle : scene_->obstacles) {
    w.obstacles.push_back(std::make_unique<fcl::CollisionObjectd>(
        builder.Build(obstacle.shape), obstacle.pose.linear(), obstacle.pose.translation()));
    registered.push_back(w.obstacles.back().get());
    w.meshes_only = w.meshes_only && obstacle.shape.type == ShapeType::kMesh;
  }
  w.obstacle_manager.registerObjects(registered);
  w.obstacle_manager.setup();

  // Objects and tree nodes (two per obstacle) beside the BVHs, counted coarsely.
  w.memory_bytes = sizeof(Impl) + builder.bytes() +
                   (w.obstacles.size() + w.body_prototypes.size()) *
                       (sizeof(fcl::CollisionObjectd) + sizeof(fcl::Boxd)) +
                   2 * w.obstacles.size() * 96;
}

CollisionWorld::~CollisionWorld() = default;

std::unique_ptr<CollisionContext> CollisionWorld::MakeContext() const {
  return std::make_unique<CollisionContext>(*this);
}

double CollisionWorld::BodyRadius(int body) const {
  HGRAPH_CHECK(body >= 0 && body < static_cast<int>(impl_->body_radius.size()));
  return impl_->body_radius[body];
}

const std::vector<std::pair<int, int>>& CollisionWorld::SelfPairs() const {
  return impl_->self_pairs;
}

bool CollisionWorld::CanAdvance() const {
  return impl_->meshes_only && impl_->self_pairs.empty() && !impl_->body_prototypes.empty();
}

size_t CollisionWorld::memory_bytes() const { return impl_->memory_bytes; }

namespace {

// A body's motion for FreeFraction: a screw in its mesh frame at the start, the screw's reach
// over the mesh, and the map from world to that frame.
struct BodyMotion {
  free_motion::Screw screw;
  double reach = 0;
  Eigen::Isometry3d to_mesh;
};

// The body, obstacle and pair of triangles that bounded the last FreeFraction.
struct AdvanceHint {
  int body = -1;
  int obstacle = -1;
  free_motion::TrianglePair pair;
};

}  // namespace

struct CollisionContext::Impl {
  std::vector<std::unique_ptr<fcl::CollisionObjectd>> bodies;
  CollideData collide;
  DistanceData distance;
  // A point (a sphere of radius 0, which FCL measures analytically against triangles and
  // primitives) for ObstacleDistance; its own geometry, so no other thread's object shares it.
  std::unique_ptr<fcl::CollisionObjectd> point;
  // FreeFraction's per-body motions, kept to reuse their storage.
  std::vector<BodyMotion> motions;
  AdvanceHint advance_hint;
};

CollisionContext::CollisionContext(const CollisionWorld& world)
    : world_(world), impl_(std::make_unique<Impl>()) {
  for (const auto& prototype : world.impl().body_prototypes) {
    impl_->bodies.push_back(std::make_unique<fcl::CollisionObjectd>(*prototype));
  }
  impl_->distance.request.distance_tolerance = kGjkDistanceTolerance;
  impl_->distance.request.gjk_solver_type = kDistanceSolver;
  impl_->point = std::make_unique<fcl::CollisionObjectd>(std::make_shared<fcl::Sphered>(0.0));
}

CollisionContext::~CollisionContext() = default;

namespace {

void PlaceBodies(const CollisionWorld& world,
                 std::vector<std::unique_ptr<fcl::CollisionObjectd>>& bodies, const Config& q) {
  const Space& space = world.space();
  HGRAPH_CHECK(q.size() == space.dimension());
  const CollisionWorld::Impl& w = world.impl();
  for (size_t i = 0; i < bodies.size(); ++i) {
    SetPose(*bodies[i], space.Pose(w.body_component[i], q) * w.body_offset[i]);
  }
}

}  // namespace

bool CollisionContext::Valid(const Config& q) {
  ++collision_checks_;
  if (!world_.space().InBounds(q)) return false;
  PlaceBodies(world_, impl_->bodies, q);
  const CollisionWorld::Impl& w = world_.impl();
  CollideData& data = impl_->collide;
  for (const auto& body : impl_->bodies) {
    data.hit = false;
    w.obstacle_manager.collide(body.get(), &data, CollideCallback);
    if (data.hit) return false;
  }
  for (const auto& [i, j] : w.self_pairs) {
    fcl::CollisionResultd result;
    fcl::collide(impl_->bodies[i].get(), impl_->bodies[j].get(), data.request, result);
    if (result.isCollision()) return false;
  }
  return true;
}

double CollisionContext::Clearance(const Config& q, ClearanceWitness* witness) {
  ++distance_queries_;
  if (witness != nullptr) *witness = ClearanceWitness{};
  if (!world_.space().InBounds(q)) return 0.0;
  PlaceBodies(world_, impl_->bodies, q);
  return Nearest(std::numeric_limits<double>::infinity(), witness);
}

double CollisionContext::ClearanceFrom(const Config& q, double cap, ClearanceWitness* hint) {
  HGRAPH_CHECK(cap > 0 && hint != nullptr);
  ++distance_queries_;
  if (!world_.space().InBounds(q)) return 0.0;
  PlaceBodies(world_, impl_->bodies, q);
  double start = cap;
  const int bodies = static_cast<int>(impl_->bodies.size());
  if (world_.impl().meshes_only && hint->body >= 0 && hint->body < bodies &&
      hint->other_body < bodies) {
    std::vector<Eigen::Isometry3d> poses(impl_->bodies.size());
    for (int b = 0; b < bodies; ++b) poses[b] = impl_->bodies[b]->getTransform();
    start = std::min(start, CollisionWorld::WitnessDistance(*hint, poses));
  }
  return std::min(cap, Nearest(start, hint));
}

double CollisionContext::Nearest(double start, ClearanceWitness* witness) {
  const CollisionWorld::Impl& w = world_.impl();
  DistanceData& data = impl_->distance;
  data.min_distance = start;
  data.request.enable_nearest_points = witness != nullptr;
  data.request.rel_err = 0;
  data.request.abs_err = 0;
  // Which bodies the nearest points found last belong to (-1: an obstacle).
  int near_body = -1;
  int near_other = -1;
  for (size_t i = 0; i < impl_->bodies.size(); ++i) {
    data.body = impl_->bodies[i].get();
    data.found = false;
    w.obstacle_manager.distance(impl_->bodies[i].get(), &data, DistanceCallback);
    if (data.min_distance <= 0) return 0.0;
    if (data.found) {
      near_body = static_cast<int>(i);
      near_other = -1;
    }
  }
  for (const auto& [i, j] : w.self_pairs) {
    data.found = false;
    data.min_distance = PairDistance(impl_->bodies[i].get(), impl_->bodies[j].get(), data.request,
                                     data.min_distance, &data.found, data.nearest);
    if (data.min_distance <= 0) return 0.0;
    if (data.found) {
      near_body = i;
      near_other = j;
    }
  }
  if (witness != nullptr && near_body >= 0) {
    const auto local = [&](int body, const fcl::Vector3d& p) -> Eigen::Vector3d {
      return impl_->bodies[body]->getTransform().inverse() * p;
    };
    witness->body = near_body;
    witness->point = local(near_body, data.nearest[0]);
    witness->other_body = near_other;
    witness->other_point = near_other >= 0 ? local(near_other, data.nearest[1]) : data.nearest[1];
  }
  return data.min_distance;
}

double CollisionContext::ClearanceLowerBound(const Config& q, double rel_err, double cap) {
  HGRAPH_CHECK(rel_err >= 0 && cap > 0);
  ++distance_queries_;
  if (!world_.space().InBounds(q)) return 0.0;
  PlaceBodies(world_, impl_->bodies, q);
  const CollisionWorld::Impl& w = world_.impl();
  DistanceData& data = impl_->distance;
  const double scale = 1 + rel_err;
  // Every distance FCL reports from here on is an actual one (at least the clearance) or the
  // start; what it pruned was at least 1 / scale of the running minimum. The absolute error
  // plays no part (FCL prunes when both tests pass).
  data.min_distance = cap * scale;
  data.request.enable_nearest_points = false;
  data.request.rel_err = rel_err;
  data.request.abs_err = std::numeric_limits<double>::infinity();
  data.found = false;
  for (const auto& body : impl_->bodies) {
    data.body = body.get();
    w.obstacle_manager.distance(body.get(), &data, DistanceCallback);
    if (data.min_distance <= 0) return 0.0;
  }
  for (const auto& [i, j] : w.self_pairs) {
    data.min_distance = PairDistance(impl_->bodies[i].get(), impl_->bodies[j].get(), data.request,
                                     data.min_distance);
    if (data.min_distance <= 0) return 0.0;
  }
  return std::min(cap, data.min_distance / scale);
}

namespace {

// Below this angle the turn's axis is not trusted: the turn is bounded by the distance from the
// frame's origin instead.
constexpr double kAxisMinAngle = 1e-4;

const free_motion::MeshModel& MeshOf(const fcl::CollisionObjectd& object) {
  return static_cast<const free_motion::MeshModel&>(*object.collisionGeometry());
}

}  // namespace

double CollisionContext::FreeFraction(const Config& q, const Config& to, double limit) {
  HGRAPH_CHECK(world_.CanAdvance() && limit >= 0);
  ++distance_queries_;
  const Space& space = world_.space();
  if (!space.InBounds(q)) return 0.0;
  const CollisionWorld::Impl& w = world_.impl();
  // Each body's motion in its mesh frame at q (the component's frame moved by the offset).
  const int bodies = static_cast<int>(impl_->bodies.size());
  std::vector<BodyMotion>& motions = impl_->motions;
  motions.resize(bodies);
  for (int i = 0; i < bodies; ++i) {
    const int c = w.body_component[i];
    const Space::FrameMotion motion = space.Motion(c, q, to);
    const Eigen::Isometry3d& offset = w.body_offset[i];
    const Eigen::Matrix3d back = offset.linear().transpose();
    free_motion::Screw& screw = motions[i].screw;
    screw.translation = back * motion.translation;
    screw.axis = back * motion.axis;
    screw.center = -(back * offset.translation());
    screw.angle = motion.angle;
    screw.radial = motion.angle < kAxisMinAngle;
    motions[i].reach = free_motion::MeshReach(MeshOf(*w.body_prototypes[i]), screw);
    motions[i].to_mesh = (space.Pose(c, q) * offset).inverse();
  }
  const auto obstacle_pose = [&](int i, int k) {
    return motions[i].to_mesh * w.obstacles[k]->getTransform();
  };
  // The pair that bounded the last query first: the traversals below then prune from its bound.
  double best = limit;
  AdvanceHint& hint = impl_->advance_hint;
  if (hint.body >= 0 && hint.body < bodies &&
      hint.obstacle < static_cast<int>(w.obstacles.size())) {
    best = free_motion::PairBound(MeshOf(*w.body_prototypes[hint.body]), motions[hint.body].screw,
                                  MeshOf(*w.obstacles[hint.obstacle]),
                                  obstacle_pose(hint.body, hint.obstacle), hint.pair, best);
  }
  for (int i = 0; i < bodies && best > 0; ++i) {
    const free_motion::MeshModel& mesh = MeshOf(*w.body_prototypes[i]);
    for (int k = 0; k < static_cast<int>(w.obstacles.size()) && best > 0; ++k) {
      free_motion::TrianglePair found;
      best = free_motion::AdvanceBound(mesh, motions[i].screw, motions[i].reach,
                                       MeshOf(*w.obstacles[k]), obstacle_pose(i, k), best, &found);
      if (found.mesh >= 0) hint = AdvanceHint{.body = i, .obstacle = k, .pair = found};
    }
  }
  return best;
}

double CollisionContext::ObstacleDistance(const Eigen::Vector3d& point) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = point;
  SetPose(*impl_->point, pose);
  DistanceData& data = impl_->distance;
  data.min_distance = std::numeric_limits<double>::infinity();
  data.request.enable_nearest_points = false;
  data.request.rel_err = 0;
  data.request.abs_err = 0;
  data.body = impl_->point.get();
  data.found = false;
  world_.impl().obstacle_manager.distance(impl_->point.get(), &data, DistanceCallback);
  return data.min_distance;
}

Eigen::Isometry3d CollisionWorld::BodyPose(int body, const Config& q) const {
  HGRAPH_CHECK(body >= 0 && body < static_cast<int>(impl_->body_offset.size()));
  return space().Pose(impl_->body_component[body], q) * impl_->body_offset[body];
}

double CollisionWorld::WitnessDistance(const ClearanceWitness& witness,
                                       const std::vector<Eigen::Isometry3d>& body_poses) {
  HGRAPH_CHECK(witness.body >= 0 && witness.body < static_cast<int>(body_poses.size()));
  const Eigen::Vector3d p = body_poses[witness.body] * witness.point;
  const Eigen::Vector3d o = witness.other_body < 0
                                ? witness.other_point
                                : body_poses[witness.other_body] * witness.other_point;
  // The points went through a frame change and back: allow for the rounding, and for GJK's
  // tolerance on the clearance a query reports.
  return (p - o).norm() + 1e-9 * (1 + p.norm() + o.norm());
}

}  // namespace hgraph
