#include "core/adapter/ompl_cfg.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <optional>
#include <sstream>

#include "core/adapter/json_io.h"
#include "core/common/error.h"
#include "core/scene/mesh_loader.h"

namespace hgraph {
namespace {

namespace fs = std::filesystem;

std::string Trim(const std::string& s) {
  size_t b = 0;
  size_t e = s.size();
  while (b < e && std::isspace(static_cast<unsigned char>(s[b]))) ++b;
  while (e > b && std::isspace(static_cast<unsigned char>(s[e - 1]))) --e;
  return s.substr(b, e - b);
}

// The key = value lines of the [problem] section. Other sections ([benchmark], [planner]) are
// for OMPL's benchmark tool and are skipped.
class ProblemSection {
 public:
  ProblemSection(const std::string& text, std::string source) : source_(std::move(source)) {
    std::istringstream in(text);
    std::string line;
    std::string section;
    bool seen = false;
    while (std::getline(in, line)) {
      line = Trim(line);
      if (line.empty() || line[0] == '#' || line[0] == ';') continue;
      if (line.front() == '[') {
        section = Trim(line.substr(1, line.find(']') - 1));
        seen = seen || section == "problem";
        continue;
      }
      if (section != "problem") continue;
      const size_t eq = line.find('=');
      if (eq == std::string::npos) {
        throw InputError(source_ + ": [problem]", "expected 'key = value', got '" + line + "'");
      }
      values_[Trim(line.substr(0, eq))] = Trim(line.substr(eq + 1));
    }
    if (!seen) throw InputError(source_, "no [problem] section (not an OMPL.app problem file)");
  }

  std::string Field(const std::string& key) const { return source_ + ": [problem]." + key; }
  bool Has(const std::string& key) const { return values_.count(key) > 0; }

  std::string String(const std::string& key) const {
    const auto it = values_.find(key);
    if (it == values_.end() || it->second.empty()) throw InputError(Field(key), "is missing");
    return it->second;
  }

  double Number(const std::string& key, std::optional<double> fallback = std::nullopt) const {
    const auto it = values_.find(key);
    if (it == values_.end()) {
      if (fallback) return *fallback;
      throw InputError(Field(key), "is missing");
    }
    size_t used = 0;
    double v = 0;
    try {
      v = std::stod(it->second, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != it->second.size() || !std::isfinite(v)) {
      throw InputError(Field(key), "must be a finite number, got '" + it->second + "'");
    }
    return v;
  }

 private:
  std::string source_;
  std::map<std::string, std::string> values_;
};

// Assimp's default COLLADA import turns a file's up axis into Y (assimp's convention) by a
// rotation of the root node; our mesh loader skips that (its scenes are Z-up by definition), so
// the rotation is put back here as a pose. The matrices are assimp's ColladaLoader ones.
Eigen::Matrix3d AssimpUpAxisRotation(const std::string& mesh_path) {
  std::string ext = fs::path(mesh_path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  if (ext != ".dae") return Eigen::Matrix3d::Identity();
  const std::string text = ReadTextFile(mesh_path);
  const size_t open = text.find("<up_axis>");
  const size_t close = text.find("</up_axis>", open);
  if (open == std::string::npos || close == std::string::npos) return Eigen::Matrix3d::Identity();
  const std::string axis = Trim(text.substr(open + 9, close - open - 9));
  Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
  if (axis == "Z_UP") {
    r << 1, 0, 0, 0, 0, 1, 0, -1, 0;  // (x, y, z) -> (x, z, -y)
  } else if (axis == "X_UP") {
    r << 0, -1, 0, 1, 0, 0, 0, 0, 1;  // (x, y, z) -> (-y, x, z)
  }
  return r;
}

// -0 becomes 0. Proto3 JSON writes -0 but reads it back as 0, so a scene holding -0 would get
// another digest once written to a file and read again (a session opened on the imported problem
// would not match its own --out file).
double NoNegativeZero(double v) { return v + 0.0; }

void SetPose(const Eigen::Isometry3d& pose, v1::Pose* proto) {
  const Eigen::Quaterniond q(pose.linear());
  proto->clear_position();
  proto->clear_orientation();
  for (int k = 0; k < 3; ++k) proto->add_position(NoNegativeZero(pose.translation()[k]));
  for (double v : {q.x(), q.y(), q.z(), q.w()}) proto->add_orientation(NoNegativeZero(v));
}

// The mesh file named by `key`, as written and as found (relative to the .cfg's folder).
struct MeshFile {
  std::string as_written;
  std::string resolved;
};

MeshFile FindMesh(const ProblemSection& problem, const std::string& key, const fs::path& dir) {
  MeshFile mesh{.as_written = problem.String(key)};
  const fs::path p(mesh.as_written);
  mesh.resolved = (p.is_absolute() ? p : dir / p).string();
  std::error_code ec;
  if (!fs::exists(mesh.resolved, ec)) {
    throw Error(ErrorCode::kNotFound, problem.Field(key),
                "mesh file '" + mesh.resolved + "' does not exist");
  }
  return mesh;
}

void AddConfig(const ProblemSection& problem, const std::string& prefix, bool three_d,
               v1::Configuration* out) {
  const double theta = problem.Number(prefix + ".theta", 0.0);
  out->add_values(NoNegativeZero(problem.Number(prefix + ".x")));
  out->add_values(NoNegativeZero(problem.Number(prefix + ".y")));
  if (!three_d) {
    out->add_values(NoNegativeZero(theta));
    return;
  }
  out->add_values(NoNegativeZero(problem.Number(prefix + ".z")));
  Eigen::Vector3d axis(problem.Number(prefix + ".axis.x", 0.0),
                       problem.Number(prefix + ".axis.y", 0.0),
                       problem.Number(prefix + ".axis.z", 0.0));
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  if (axis.norm() > 1e-12) {
    q = Eigen::Quaterniond(Eigen::AngleAxisd(theta, axis.normalized()));
  } else if (std::abs(theta) > 1e-12) {
    throw InputError(problem.Field(prefix + ".axis.x"),
                     "the rotation axis is zero but " + prefix + ".theta is not");
  }
  for (double v : {q.x(), q.y(), q.z(), q.w()}) out->add_values(NoNegativeZero(v));
}

}  // namespace

v1::Scene ReadOmplAppProblem(const std::string& cfg_path) {
  const ProblemSection problem(ReadTextFile(cfg_path), cfg_path);
  const fs::path dir = fs::path(cfg_path).parent_path();
  // OMPL.app tells 2D from 3D problems by the coordinates given.
  const bool three_d = problem.Has("start.z") || problem.Has("start.axis.x");

  const MeshFile world = FindMesh(problem, "world", dir);
  const MeshFile robot = FindMesh(problem, "robot", dir);
  const auto world_mesh =
      LoadMeshFile(world.resolved, {.apply_node_transforms = true}, problem.Field("world"));
  const auto robot_mesh =
      LoadMeshFile(robot.resolved, {.apply_node_transforms = true, .ompl_app_center = true},
                   problem.Field("robot"));
  const Eigen::Matrix3d world_up = AssimpUpAxisRotation(world.resolved);
  const Eigen::Matrix3d robot_up = AssimpUpAxisRotation(robot.resolved);

  // OMPL.app's reference point, not the mean of our vertices: the two differ whenever corners
  // are shared by faces of different normals (mesh_loader.h), and a configuration must place the
  // robot where OMPL.app places it.
  Eigen::Vector3d centroid = robot_up * robot_mesh->ompl_app_center.value();
  if (!three_d) centroid.z() = 0;  // OMPL.app's 2D robots keep their own height

  v1::Scene scene;
  const std::string name = problem.Has("name") ? problem.String("name") : "";
  scene.set_name(name.empty() ? fs::path(cfg_path).stem().string() : name);
  scene.set_description("OMPL.app problem " + fs::path(cfg_path).filename().string());

  v1::Obstacle* obstacle = scene.add_obstacles();
  obstacle->set_name("world");
  obstacle->mutable_shape()->mutable_mesh()->set_path(world.as_written);
  Eigen::Isometry3d world_pose = Eigen::Isometry3d::Identity();
  world_pose.linear() = world_up;
  SetPose(world_pose, obstacle->mutable_pose());

  v1::RobotBody* body = scene.add_robot();
  body->set_name("robot");
  body->mutable_shape()->mutable_mesh()->set_path(robot.as_written);
  body->set_component(0);
  Eigen::Isometry3d offset = Eigen::Isometry3d::Identity();
  offset.linear() = robot_up;
  offset.translation() = -centroid;
  SetPose(offset, body->mutable_offset());

  // Bounds of the reference point: the volume if given, else the world's box widened by 5%.
  const int dims = three_d ? 3 : 2;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const Eigen::Vector3d& v : world_mesh->vertices) {
    lo = lo.cwiseMin(world_up * v);
    hi = hi.cwiseMax(world_up * v);
  }
  const Eigen::Vector3d widen = 0.05 * (hi - lo);
  lo -= widen;
  hi += widen;
  v1::Component* component = scene.mutable_space()->add_components();
  component->set_type(three_d ? v1::Component::TYPE_SE3 : v1::Component::TYPE_SE2);
  component->set_name("robot");
  const char* axes[] = {"x", "y", "z"};
  for (int k = 0; k < dims; ++k) {
    const double low = problem.Number(std::string("volume.min.") + axes[k], lo[k]);
    const double high = problem.Number(std::string("volume.max.") + axes[k], hi[k]);
    if (!(low < high)) {
      throw InputError(problem.Field(std::string("volume.max.") + axes[k]),
                       "must exceed volume.min." + std::string(axes[k]));
    }
    component->add_lower(NoNegativeZero(low));
    component->add_upper(NoNegativeZero(high));
  }
  AddConfig(problem, "start", three_d, scene.mutable_start());
  AddConfig(problem, "goal", three_d, scene.mutable_goal());
  return scene;
}

void RebaseMeshPaths(const std::string& from_dir, const std::string& to_dir, v1::Scene* scene) {
  const fs::path from = fs::absolute(from_dir.empty() ? "." : from_dir).lexically_normal();
  const fs::path to = fs::absolute(to_dir.empty() ? "." : to_dir).lexically_normal();
  auto rebase = [&](v1::Shape* shape) {
    if (!shape->has_mesh() || !shape->mesh().has_path()) return;
    const fs::path p(shape->mesh().path());
    if (p.is_absolute()) return;
    shape->mutable_mesh()->set_path((from / p).lexically_normal().lexically_relative(to).string());
  };
  for (v1::Obstacle& obstacle : *scene->mutable_obstacles()) rebase(obstacle.mutable_shape());
  for (v1::RobotBody& body : *scene->mutable_robot()) rebase(body.mutable_shape());
}

bool LooksLikeOmplStatePrint(const std::string& text) {
  return text.find("State [") != std::string::npos;
}

std::vector<InputPath> ParseOmplStatePrint(const std::string& text, const std::string& source,
                                           const Space& space) {
  std::vector<InputPath> paths;
  InputPath path;
  std::istringstream in(text);
  std::string line;
  std::vector<double> state;
  int depth = 0;
  int line_no = 0;
  int state_line = 0;
  auto finish = [&] {
    if (static_cast<int>(state.size()) != space.dimension()) {
      throw InputError(source + ":" + std::to_string(state_line),
                       "state has " + std::to_string(state.size()) + " numbers, the space " +
                           std::to_string(space.dimension()));
    }
    path.waypoints.push_back(Eigen::Map<const Eigen::VectorXd>(state.data(), state.size()));
    state.clear();
  };
  while (std::getline(in, line)) {
    ++line_no;
    line = Trim(line);
    const size_t open = line.find('[');
    if (open == std::string::npos) {
      if (line == "]" && depth > 0 && --depth == 0) finish();
      // Each PathGeometric::print starts with this line; other lines without states are skipped.
      if (depth == 0 && line.starts_with("Geometric path with") && !path.waypoints.empty()) {
        paths.push_back(std::move(path));
        path = InputPath();
      }
      continue;
    }
    if (depth == 0) state_line = line_no;
    const size_t close = line.rfind(']');
    if (close == std::string::npos || close < open) {
      ++depth;  // "Compound state ["
      continue;
    }
    std::istringstream numbers(line.substr(open + 1, close - open - 1));
    std::string token;
    while (numbers >> token) {
      size_t used = 0;
      double v = 0;
      try {
        v = std::stod(token, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used != token.size() || !std::isfinite(v)) {
        throw InputError(source + ":" + std::to_string(line_no),
                         "not a finite number: '" + token + "'");
      }
      state.push_back(v);
    }
    if (depth == 0) finish();
  }
  if (!path.waypoints.empty()) paths.push_back(std::move(path));
  if (paths.empty()) throw InputError(source, "no states found");
  const std::string stem = fs::path(source).stem().string();
  for (size_t i = 0; i < paths.size(); ++i) {
    paths[i].name = paths.size() == 1 ? stem : stem + "-" + std::to_string(i);
  }
  return paths;
}

namespace {

// Shortest decimal text that reads back as the same double.
std::string Exact(double v) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), v);
  return std::string(buffer, result.ptr);
}

// "<Name>State [a b c]\n", as RealVectorStateSpace, SO2StateSpace and SO3StateSpace print.
void PrintLeaf(const char* name, const Config& q, int first, int count, std::string& out) {
  out += name;
  out += "State [";
  for (int k = 0; k < count; ++k) {
    if (k > 0) out += ' ';
    out += Exact(q[first + k]);
  }
  out += "]\n";
}

void PrintComponent(const ComponentSpec& c, const Config& q, int first, std::string& out) {
  switch (c.type) {
    case ComponentType::kRealVector: PrintLeaf("RealVector", q, first, c.dimension, out); return;
    case ComponentType::kSO2: PrintLeaf("SO2", q, first, 1, out); return;
    case ComponentType::kSO3: PrintLeaf("SO3", q, first, 4, out); return;
    case ComponentType::kSE2:
      out += "Compound state [\n";
      PrintLeaf("RealVector", q, first, 2, out);
      PrintLeaf("SO2", q, first + 2, 1, out);
      out += "]\n";
      return;
    case ComponentType::kSE3:
      out += "Compound state [\n";
      PrintLeaf("RealVector", q, first, 3, out);
      PrintLeaf("SO3", q, first + 3, 4, out);
      out += "]\n";
      return;
  }
}

}  // namespace

std::string OmplStatePrint(const std::vector<InputPath>& paths, const Space& space) {
  std::string out;
  for (const InputPath& path : paths) {
    out += "Geometric path with " + std::to_string(path.waypoints.size()) + " states\n";
    for (const Config& q : path.waypoints) {
      if (q.size() != space.dimension()) {
        throw InputError(path.name, "waypoint has " + std::to_string(q.size()) +
                                        " numbers, the space " + std::to_string(space.dimension()));
      }
      if (space.num_components() == 1) {
        PrintComponent(space.component(0), q, 0, out);
        continue;
      }
      out += "Compound state [\n";
      for (int i = 0; i < space.num_components(); ++i) {
        PrintComponent(space.component(i), q, space.offset(i), out);
      }
      out += "]\n";
    }
    out += "\n";  // PathGeometric::print ends with an empty line
  }
  return out;
}

}  // namespace hgraph
