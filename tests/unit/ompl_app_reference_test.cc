// The product against OMPL.app's own conventions on every OMPL.app problem in tests/data (every
// .cfg below it). The reference here shares nothing with the product's loader: it reads the
// meshes as OMPL.app's RigidBodyGeometry does (assimp's default settings with OMPL.app's
// post-processing steps, up axis converted, node transforms applied, every mesh), shifts the
// robot by OMPL.app's reference point (the mean of those vertices, z = 0 for 2D problems), places
// it from OMPL's SE(2)/SE(3) states as OMPL.app's FCL checker does and collides the triangles
// with FCL. On random states the product's CheckPaths must agree with it everywhere; merged
// paths must be valid under it at OMPL's resolution (DiscreteMotionValidator at 0.01 of the
// space's extent).
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <fcl/geometry/bvh/BVH_model.h>
#include <fcl/math/bv/OBBRSS.h>
#include <fcl/narrowphase/collision.h>
#include <gtest/gtest.h>
#include <ompl/base/SpaceInformation.h>
#include <ompl/base/spaces/SE2StateSpace.h>
#include <ompl/base/spaces/SE3StateSpace.h>
#include <ompl/util/Console.h>

#include <algorithm>
#include <assimp/Importer.hpp>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "core/adapter/ompl_cfg.h"
#include "core/adapter/path_io.h"
#include "core/adapter/scene_proto.h"
#include "core/collision/collision_world.h"
#include "core/merge/merge.h"
#include "core/merge/path_check.h"
#include "core/motion/local_planner.h"

namespace hgraph {
namespace {

namespace fs = std::filesystem;
namespace ob = ompl::base;
using Model = fcl::BVHModel<fcl::OBBRSSd>;

constexpr int kStates = 10000;

std::vector<std::string> OmplAppProblems() {
  std::vector<std::string> cfgs;
  for (const auto& entry : fs::recursive_directory_iterator(HGRAPH_TEST_DATA_DIR)) {
    if (entry.path().extension() == ".cfg") cfgs.push_back(entry.path().string());
  }
  std::sort(cfgs.begin(), cfgs.end());
  return cfgs;
}

std::map<std::string, std::string> ProblemKeys(const std::string& cfg) {
  std::ifstream in(cfg);
  std::map<std::string, std::string> keys;
  std::string line;
  std::string section;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    if (line[0] == '[') {
      section = line.substr(1, line.find(']') - 1);
      continue;
    }
    const size_t eq = line.find('=');
    if (section != "problem" || eq == std::string::npos) continue;
    auto trim = [](std::string s) {
      s.erase(0, s.find_first_not_of(" \t"));
      s.erase(s.find_last_not_of(" \t\r") + 1);
      return s;
    };
    keys[trim(line.substr(0, eq))] = trim(line.substr(eq + 1));
  }
  return keys;
}

// A mesh file as OMPL.app's RigidBodyGeometry::addRobotMesh / addEnvironmentMesh import it.
struct AppMesh {
  std::vector<aiVector3D> vertices;   // scene::extractVertices
  std::vector<aiVector3D> triangles;  // scene::extractTriangles: three corners per triangle
};

void Extract(const aiScene& scene, const aiNode& node, aiMatrix4x4 transform, AppMesh* out) {
  transform *= node.mTransformation;
  for (unsigned i = 0; i < node.mNumMeshes; ++i) {
    const aiMesh& mesh = *scene.mMeshes[node.mMeshes[i]];
    for (unsigned k = 0; k < mesh.mNumVertices; ++k) {
      out->vertices.push_back(transform * mesh.mVertices[k]);
    }
    for (unsigned f = 0; f < mesh.mNumFaces; ++f) {
      if (mesh.mFaces[f].mNumIndices != 3) continue;
      for (int c = 0; c < 3; ++c) {
        out->triangles.push_back(transform * mesh.mVertices[mesh.mFaces[f].mIndices[c]]);
      }
    }
  }
  for (unsigned c = 0; c < node.mNumChildren; ++c) {
    Extract(scene, *node.mChildren[c], transform, out);
  }
}

AppMesh ImportAsOmplApp(const std::string& path) {
  Assimp::Importer importer;
  const aiScene* scene = importer.ReadFile(
      path, aiProcess_GenNormals | aiProcess_Triangulate | aiProcess_JoinIdenticalVertices |
                aiProcess_SortByPType | aiProcess_OptimizeGraph);
  AppMesh mesh;
  if (scene == nullptr || !scene->HasMeshes()) {
    ADD_FAILURE() << path << ": " << importer.GetErrorString();
    return mesh;
  }
  Extract(*scene, *scene->mRootNode, aiMatrix4x4(), &mesh);
  return mesh;
}

std::shared_ptr<Model> FclModel(const std::vector<aiVector3D>& corners, const aiVector3D& shift) {
  std::vector<fcl::Vector3d> points;
  std::vector<fcl::Triangle> triangles;
  for (size_t j = 0; j < corners.size(); ++j) {
    const aiVector3D p = corners[j] - shift;
    points.emplace_back(p.x, p.y, p.z);
  }
  for (size_t j = 0; j + 2 < corners.size(); j += 3) triangles.emplace_back(j, j + 1, j + 2);
  auto model = std::make_shared<Model>();
  model->beginModel();
  model->addSubModel(points, triangles);
  model->endModel();
  model->computeLocalAABB();
  return model;
}

// OMPL.app's problem: its space (SE(2) or SE(3) with the .cfg's volume), its robot and world,
// and a state validity checker as FCLStateValidityChecker: in bounds and not in collision.
class ReferenceProblem {
 public:
  explicit ReferenceProblem(const std::string& cfg) {
    const auto keys = ProblemKeys(cfg);
    const fs::path dir = fs::path(cfg).parent_path();
    three_d_ = keys.count("start.z") > 0 || keys.count("start.axis.x") > 0;
    const AppMesh robot = ImportAsOmplApp((dir / keys.at("robot")).string());
    const AppMesh world = ImportAsOmplApp((dir / keys.at("world")).string());
    // RigidBodyGeometry::getRobotCenter (scene::sceneCenter), z dropped for 2D problems.
    aiVector3D center(0, 0, 0);
    for (const aiVector3D& v : robot.vertices) center += v;
    center /= static_cast<float>(robot.vertices.size());
    if (!three_d_) center.z = 0;
    center_ = Eigen::Vector3d(center.x, center.y, center.z);
    robot_ = FclModel(robot.triangles, center);
    world_ = FclModel(world.triangles, aiVector3D(0, 0, 0));
    for (const aiVector3D& v : world.vertices) {
      world_points_.emplace_back(v.x, v.y, v.z);
    }
    for (const aiVector3D& v : robot.vertices) {
      robot_radius_ = std::max(robot_radius_, (Eigen::Vector3d(v.x, v.y, v.z) - center_).norm());
    }

    const int dims = three_d_ ? 3 : 2;
    ob::RealVectorBounds bounds(dims);
    const char* axes[] = {"x", "y", "z"};
    for (int k = 0; k < dims; ++k) {
      bounds.setLow(k, std::stod(keys.at(std::string("volume.min.") + axes[k])));
      bounds.setHigh(k, std::stod(keys.at(std::string("volume.max.") + axes[k])));
    }
    if (three_d_) {
      auto space = std::make_shared<ob::SE3StateSpace>();
      space->setBounds(bounds);
      space_ = space;
    } else {
      auto space = std::make_shared<ob::SE2StateSpace>();
      space->setBounds(bounds);
      space_ = space;
    }
    si_ = std::make_shared<ob::SpaceInformation>(space_);
    si_->setStateValidityChecker([this](const ob::State* s) { return IsValid(s); });
    si_->setStateValidityCheckingResolution(0.01);
    si_->setup();
  }

  bool three_d() const { return three_d_; }
  const Eigen::Vector3d& center() const { return center_; }
  const ob::SpaceInformationPtr& si() const { return si_; }
  const std::vector<Eigen::Vector3d>& world_points() const { return world_points_; }
  double robot_radius() const { return robot_radius_; }

  // FCLStateValidityChecker::isValid.
  bool IsValid(const ob::State* state) const {
    return si_->satisfiesBounds(state) && CollisionFree(state);
  }

  // Our configuration layout (x y theta; x y z qx qy qz qw) into an OMPL state.
  void ToState(const Config& q, ob::State* state) const {
    if (three_d_) {
      auto* s = state->as<ob::SE3StateSpace::StateType>();
      s->setXYZ(q[0], q[1], q[2]);
      s->rotation().x = q[3];
      s->rotation().y = q[4];
      s->rotation().z = q[5];
      s->rotation().w = q[6];
    } else {
      auto* s = state->as<ob::SE2StateSpace::StateType>();
      s->setXY(q[0], q[1]);
      s->setYaw(q[2]);
    }
  }

 private:
  // OMPL.app's pose callbacks: 2D (x, y, 0) turned about Z by the yaw; 3D the SO(3) quaternion.
  bool CollisionFree(const ob::State* state) const {
    fcl::Transform3d pose = fcl::Transform3d::Identity();
    if (three_d_) {
      const auto* s = state->as<ob::SE3StateSpace::StateType>();
      const auto& r = s->rotation();
      pose.linear() = fcl::Quaterniond(r.w, r.x, r.y, r.z).toRotationMatrix();
      pose.translation() = fcl::Vector3d(s->getX(), s->getY(), s->getZ());
    } else {
      const auto* s = state->as<ob::SE2StateSpace::StateType>();
      pose.linear() = Eigen::AngleAxisd(s->getYaw(), Eigen::Vector3d::UnitZ()).toRotationMatrix();
      pose.translation() = fcl::Vector3d(s->getX(), s->getY(), 0);
    }
    fcl::CollisionRequestd request;
    fcl::CollisionResultd result;
    fcl::collide(robot_.get(), pose, world_.get(), fcl::Transform3d::Identity(), request, result);
    return !result.isCollision();
  }

  bool three_d_ = false;
  Eigen::Vector3d center_;
  std::shared_ptr<Model> robot_;
  std::shared_ptr<Model> world_;
  std::vector<Eigen::Vector3d> world_points_;
  double robot_radius_ = 0;
  ob::StateSpacePtr space_;
  ob::SpaceInformationPtr si_;
};

// The product's checker on the problem, as `hgraph check` builds it.
struct ProductProblem {
  explicit ProductProblem(const std::string& cfg)
      : proto(ReadOmplAppProblem(cfg)),
        scene(SceneFromProto(proto, fs::path(cfg).parent_path().string(), BlobResolver())),
        world(std::make_shared<const CollisionWorld>(scene)),
        planner(world, LocalPlannerOptions{}) {}
  v1::Scene proto;
  std::shared_ptr<const Scene> scene;
  std::shared_ptr<const CollisionWorld> world;
  LocalPlanner planner;
};

// Half the states uniform in the space, half with the reference point within the robot's
// radius of a world vertex, where the robot touches obstacles and the two frames matter.
std::vector<Config> RandomStates(const Space& space, const ReferenceProblem& reference,
                                 uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0, 1);
  const ComponentSpec& c = space.component(0);
  const int dims = reference.three_d() ? 3 : 2;
  std::vector<Config> states;
  for (int i = 0; i < kStates; ++i) {
    Config q(reference.three_d() ? 7 : 3);
    Eigen::Vector3d p;
    if (i % 2 == 0) {
      for (int k = 0; k < dims; ++k) p[k] = c.lower[k] + unit(rng) * (c.upper[k] - c.lower[k]);
    } else {
      const auto& points = reference.world_points();
      p = points[static_cast<size_t>(unit(rng) * points.size()) % points.size()];
      for (int k = 0; k < dims; ++k) {
        p[k] += (2 * unit(rng) - 1) * reference.robot_radius();
        p[k] = std::clamp(p[k], c.lower[k], c.upper[k]);
      }
    }
    for (int k = 0; k < dims; ++k) q[k] = p[k];
    if (reference.three_d()) {
      // Uniform rotation (Shoemake).
      const double u1 = unit(rng), u2 = 2 * M_PI * unit(rng), u3 = 2 * M_PI * unit(rng);
      const double a = std::sqrt(1 - u1), b = std::sqrt(u1);
      q.tail<4>() << a * std::sin(u2), a * std::cos(u2), b * std::sin(u3), b * std::cos(u3);
    } else {
      q[2] = -M_PI + 2 * M_PI * unit(rng);
    }
    states.push_back(q);
  }
  return states;
}

class OmplAppReferenceTest : public testing::Test {
 protected:
  static void SetUpTestSuite() { ompl::msg::setLogLevel(ompl::msg::LOG_WARN); }
};

TEST_F(OmplAppReferenceTest, FindsTheOmplAppProblems) {
  const auto cfgs = OmplAppProblems();
  EXPECT_GE(cfgs.size(), 3u);
  for (const std::string& cfg : cfgs) {
    EXPECT_TRUE(fs::exists(fs::path(cfg).replace_extension(".paths.json")))
        << cfg << " needs input paths for the merge check";
  }
}

// Every state: the product's CheckPaths (a one-waypoint path, sampled and certified) says valid
// exactly when OMPL.app would.
TEST_F(OmplAppReferenceTest, CheckPathsAgreesWithOmplAppOnRandomStates) {
  for (const std::string& cfg : OmplAppProblems()) {
    SCOPED_TRACE(cfg);
    const ReferenceProblem reference(cfg);
    const ProductProblem product(cfg);
    const std::vector<Config> states = RandomStates(product.scene->space, reference, 25);
    std::vector<InputPath> paths;
    for (const Config& q : states) paths.push_back(InputPath{.waypoints = {q}});
    const PathCheckResult sampled =
        CheckPaths(product.planner, {.paths = paths, .mode = CheckMode::kSampled});
    const PathCheckResult certified =
        CheckPaths(product.planner, {.paths = paths, .mode = CheckMode::kCertified});
    ASSERT_EQ(sampled.paths.size(), states.size());
    ASSERT_EQ(certified.paths.size(), states.size());
    ob::State* state = reference.si()->allocState();
    int valid = 0;
    int disagree_sampled = 0;
    int disagree_certified = 0;
    for (size_t i = 0; i < states.size(); ++i) {
      reference.ToState(states[i], state);
      const bool expected = reference.IsValid(state);
      valid += expected ? 1 : 0;
      if (sampled.paths[i].valid != expected) {
        if (++disagree_sampled <= 3) {
          ADD_FAILURE() << "state " << states[i].transpose() << ": OMPL.app says "
                        << (expected ? "valid" : "invalid") << ", CheckPaths (sampled) not";
        }
      }
      disagree_certified += certified.paths[i].valid != expected ? 1 : 0;
    }
    reference.si()->freeState(state);
    std::printf("%s: %d states, %d valid under OMPL.app; disagreements: sampled %d, certified %d\n",
                fs::path(cfg).filename().c_str(), kStates, valid, disagree_sampled,
                disagree_certified);
    EXPECT_EQ(disagree_sampled, 0);
    EXPECT_EQ(disagree_certified, 0);
    // Both answers are common, so a frame error would show.
    EXPECT_GT(valid, kStates / 5);
    EXPECT_LT(valid, kStates - kStates / 5);
  }
}

// The merge of the committed inputs (defaults) is valid where OMPL.app checks it: every waypoint
// and every motion under OMPL's DiscreteMotionValidator at 0.01 of the extent.
TEST_F(OmplAppReferenceTest, MergedPathsAreValidUnderOmplApp) {
  for (const std::string& cfg : OmplAppProblems()) {
    SCOPED_TRACE(cfg);
    const ReferenceProblem reference(cfg);
    const ProductProblem product(cfg);
    const std::string inputs_file = fs::path(cfg).replace_extension(".paths.json").string();
    const std::vector<InputPath> inputs = LoadPathsFile(inputs_file, product.scene->space);
    ASSERT_GE(inputs.size(), 2u);
    const MergeResult merged = Merge(product.planner, MergeRequest{.paths = inputs});
    const auto& waypoints = merged.path.waypoints;
    ASSERT_GE(waypoints.size(), 2u);
    const ob::SpaceInformationPtr& si = reference.si();
    ob::State* a = si->allocState();
    ob::State* b = si->allocState();
    int invalid_states = 0;
    int invalid_motions = 0;
    for (size_t i = 0; i < waypoints.size(); ++i) {
      reference.ToState(waypoints[i], b);
      invalid_states += si->isValid(b) ? 0 : 1;
      if (i > 0 && !si->checkMotion(a, b)) {
        ++invalid_motions;
        ADD_FAILURE() << "motion " << i - 1 << " -> " << i << " collides under OMPL.app";
      }
      si->copyState(a, b);
    }
    si->freeState(a);
    si->freeState(b);
    EXPECT_EQ(invalid_states, 0);
    EXPECT_EQ(invalid_motions, 0);
    std::printf("%s: merged path of %zu waypoints, %d invalid states, %d invalid motions\n",
                fs::path(cfg).filename().c_str(), waypoints.size(), invalid_states,
                invalid_motions);
  }
}

}  // namespace
}  // namespace hgraph
