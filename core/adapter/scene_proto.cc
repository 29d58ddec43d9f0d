#include "core/adapter/scene_proto.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <map>
#include <sstream>
#include <utility>

#include "core/adapter/json_io.h"
#include "core/adapter/ompl_cfg.h"
#include "core/common/error.h"
#include "core/common/limits.h"
#include "core/motion/motion_checker.h"
#include "core/scene/mesh_loader.h"

namespace hgraph {
namespace {

std::string Index(const std::string& field, int i) { return field + "[" + std::to_string(i) + "]"; }

std::string Num(double v) {
  std::ostringstream out;
  out << v;
  return out.str();
}

// The problem part of an Error's message, without the "field: " prefix the constructor added.
std::string Problem(const Error& e) {
  const std::string what = e.what();
  const std::string prefix = e.field() + ": ";
  if (!e.field().empty() && what.starts_with(prefix)) return what.substr(prefix.size());
  return what;
}

// Core code names fields relative to the object it checks ("space.components[0].lower",
// "robot[1].component"); callers of the adapter need the path from the proto root.
[[noreturn]] void RethrowUnder(const Error& e, const std::string& own_root,
                               const std::string& root) {
  std::string field = e.field();
  if (field.empty()) {
    field = root;
  } else if (field.starts_with(root) && (field.size() == root.size() || field[root.size()] == '.' ||
                                         field[root.size()] == '[')) {
    // Already rooted.
  } else if (!own_root.empty() && field.starts_with(own_root)) {
    field = root + field.substr(own_root.size());
  } else {
    field = root + "." + field;
  }
  throw Error(e.code(), field, Problem(e));
}

void RequireFinite(double v, const std::string& field) {
  if (!std::isfinite(v)) throw InputError(field, "must be finite, got " + Num(v));
}

// Sizes and positions stay within the coordinate range so that extents and distances are finite.
void RequirePositive(double v, const std::string& field) {
  limits::RequirePositiveUpTo(v, limits::kMaxCoordinate, field);
}

ComponentType ComponentTypeFromProto(v1::Component::Type type, const std::string& field) {
  switch (type) {
    case v1::Component::TYPE_RN: return ComponentType::kRealVector;
    case v1::Component::TYPE_SO2: return ComponentType::kSO2;
    case v1::Component::TYPE_SO3: return ComponentType::kSO3;
    case v1::Component::TYPE_SE2: return ComponentType::kSE2;
    case v1::Component::TYPE_SE3: return ComponentType::kSE3;
    default:
      throw InputError(field,
                       "must be one of TYPE_RN, TYPE_SO2, TYPE_SO3, TYPE_SE2, TYPE_SE3 (got " +
                           std::to_string(static_cast<int>(type)) + ")");
  }
}

v1::Component::Type ComponentTypeToProto(ComponentType type) {
  switch (type) {
    case ComponentType::kRealVector: return v1::Component::TYPE_RN;
    case ComponentType::kSO2: return v1::Component::TYPE_SO2;
    case ComponentType::kSO3: return v1::Component::TYPE_SO3;
    case ComponentType::kSE2: return v1::Component::TYPE_SE2;
    case ComponentType::kSE3: return v1::Component::TYPE_SE3;
  }
  return v1::Component::TYPE_UNSPECIFIED;
}

Eigen::VectorXd Vector(const google::protobuf::RepeatedField<double>& values) {
  Eigen::VectorXd v(values.size());
  for (int k = 0; k < values.size(); ++k) v[k] = values[k];
  return v;
}

std::string NormalizeFormat(const std::string& format) {
  std::string f = format;
  if (!f.empty() && f.front() == '.') f.erase(0, 1);
  for (char& c : f) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return f;
}

// Converts shapes, loading each distinct (mesh, scale) once: scenes often reuse one mesh for
// many obstacles, and assimp parsing dominates the load time.
class ShapeConverter {
 public:
  ShapeConverter(std::string base_dir, const BlobResolver& resolver,
                 const MeshBytesLoader& load_bytes)
      : base_dir_(std::move(base_dir)), resolver_(resolver), load_bytes_(load_bytes) {}

  Shape Convert(const v1::Shape& proto, const std::string& field) {
    const Eigen::Vector3d scale = Scale(proto, field + ".scale");
    Shape shape;
    switch (proto.geometry_case()) {
      case v1::Shape::kBox: {
        const std::string f = field + ".box.size";
        if (proto.box().size_size() != 3) {
          throw InputError(
              f, "expected 3 values (x y z), got " + std::to_string(proto.box().size_size()));
        }
        for (int k = 0; k < 3; ++k) RequirePositive(proto.box().size(k), Index(f, k));
        shape.type = ShapeType::kBox;
        shape.box_size = Vector(proto.box().size()).cwiseProduct(scale);
        RequireScaledSize(shape.box_size.maxCoeff(), field);
        break;
      }
      case v1::Shape::kSphere: {
        const double r = proto.sphere().radius();
        limits::RequireRange(r, 0, limits::kMaxCoordinate, field + ".sphere.radius");
        if (scale.x() != scale.y() || scale.x() != scale.z()) {
          throw InputError(field + ".scale", "a sphere needs a uniform scale");
        }
        shape.type = ShapeType::kSphere;
        shape.radius = r * scale.x();
        RequireScaledSize(shape.radius, field);
        break;
      }
      case v1::Shape::kCylinder: {
        RequirePositive(proto.cylinder().radius(), field + ".cylinder.radius");
        RequirePositive(proto.cylinder().length(), field + ".cylinder.length");
        if (scale.x() != scale.y()) {
          throw InputError(field + ".scale", "a cylinder needs the same scale along x and y");
        }
        shape.type = ShapeType::kCylinder;
        shape.radius = proto.cylinder().radius() * scale.x();
        shape.length = proto.cylinder().length() * scale.z();
        RequireScaledSize(std::max(shape.radius, shape.length), field);
        break;
      }
      case v1::Shape::kMesh:
        shape.type = ShapeType::kMesh;
        LoadMesh(proto.mesh(), scale, field + ".mesh", &shape);
        break;
      case v1::Shape::GEOMETRY_NOT_SET:
        throw InputError(field, "no geometry: set one of box, sphere, cylinder, mesh");
    }
    return shape;
  }

 private:
  static Eigen::Vector3d Scale(const v1::Shape& proto, const std::string& field) {
    for (int k = 0; k < proto.scale_size(); ++k) {
      limits::RequireRange(proto.scale(k), limits::kMinScale, limits::kMaxWeight, Index(field, k));
    }
    switch (proto.scale_size()) {
      case 0: return Eigen::Vector3d::Ones();
      case 1: return Eigen::Vector3d::Constant(proto.scale(0));
      case 3: return Eigen::Vector3d(proto.scale(0), proto.scale(1), proto.scale(2));
      default:
        throw InputError(field, "expected 1 value (uniform) or 3 (x y z), got " +
                                    std::to_string(proto.scale_size()));
    }
  }

  static void RequireScaledSize(double size, const std::string& field) {
    if (!(size <= limits::kMaxCoordinate)) {
      throw InputError(field,
                       "scaled size " + Num(size) + " exceeds " + Num(limits::kMaxCoordinate));
    }
  }

  // Mesh vertices, after scaling, lie within the coordinate range.
  static void RequireMeshInRange(const Mesh& mesh, const std::string& field) {
    for (const Eigen::Vector3d& v : mesh.vertices) {
      if (!(v.cwiseAbs().maxCoeff() <= limits::kMaxCoordinate)) {
        throw InputError(field, "a scaled mesh vertex lies outside [-" +
                                    Num(limits::kMaxCoordinate) + ", " +
                                    Num(limits::kMaxCoordinate) + "]");
      }
    }
  }

  void LoadMesh(const v1::MeshRef& mesh, const Eigen::Vector3d& scale, const std::string& field,
                Shape* shape) {
    const MeshLoadOptions options{.scale = scale};
    const std::string scale_key =
        "|" + Num(scale.x()) + "," + Num(scale.y()) + "," + Num(scale.z());
    switch (mesh.source_case()) {
      case v1::MeshRef::kPath: {
        const std::string f = field + ".path";
        if (mesh.path().empty()) throw InputError(f, "empty mesh path");
        std::filesystem::path file(mesh.path());
        if (file.is_relative() && !base_dir_.empty())
          file = std::filesystem::path(base_dir_) / file;
        const std::string resolved = file.lexically_normal().string();
        shape->source = resolved;
        auto& cached = cache_["file:" + resolved + scale_key];
        if (!cached) {
          cached = LoadMeshFile(resolved, options, f);
          RequireMeshInRange(*cached, f);
        }
        shape->mesh = cached;
        return;
      }
      case v1::MeshRef::kData: {
        const std::string format = RequireFormat(mesh, field, "inline data");
        if (mesh.data().empty()) throw InputError(field + ".data", "empty mesh data");
        shape->source =
            "inline " + format + " data (" + std::to_string(mesh.data().size()) + " bytes)";
        shape->mesh = LoadBytes(mesh.data(), format, options, field + ".data");
        return;
      }
      case v1::MeshRef::kDigest: {
        const std::string f = field + ".digest";
        if (!resolver_) {
          throw InputError(f,
                           "mesh digests refer to blobs uploaded to the service; give a path "
                           "or inline data instead");
        }
        if (mesh.digest().sha256().empty()) throw InputError(f + ".sha256", "empty digest");
        const std::string format = RequireFormat(mesh, field, "a digest");
        shape->source = "blob sha256:" + mesh.digest().sha256();
        auto& cached = cache_["blob:" + mesh.digest().sha256() + scale_key];
        if (!cached) {
          const std::optional<std::string> bytes = resolver_(mesh.digest());
          if (!bytes) {
            throw Error(ErrorCode::kNotFound, f,
                        "blob sha256:" + mesh.digest().sha256() + " has not been uploaded");
          }
          cached = LoadBytes(*bytes, format, options, f);
        }
        shape->mesh = cached;
        return;
      }
      case v1::MeshRef::SOURCE_NOT_SET:
        throw InputError(field, "no mesh source: set one of path, data, digest");
    }
  }

  std::shared_ptr<const Mesh> LoadBytes(const std::string& bytes, const std::string& format,
                                        const MeshLoadOptions& options, const std::string& field) {
    std::shared_ptr<const Mesh> loaded = load_bytes_ ? load_bytes_(bytes, format, options, field)
                                                     : LoadMeshBytes(bytes, format, options, field);
    RequireMeshInRange(*loaded, field);
    return loaded;
  }

  static std::string RequireFormat(const v1::MeshRef& mesh, const std::string& field,
                                   const std::string& what) {
    const std::string format = NormalizeFormat(mesh.format());
    if (format.empty()) {
      throw InputError(field + ".format",
                       "required for " + what + " (a file extension such as \"obj\")");
    }
    if (format.size() > 16 || !std::all_of(format.begin(), format.end(), [](char c) {
          return std::isalnum(static_cast<unsigned char>(c)) != 0;
        })) {
      throw InputError(field + ".format",
                       "must be a file extension of 1 to 16 letters and digits (such as \"obj\")");
    }
    return format;
  }

  std::string base_dir_;
  const BlobResolver& resolver_;
  const MeshBytesLoader& load_bytes_;
  std::map<std::string, std::shared_ptr<const Mesh>> cache_;
};

std::optional<Config> QueryConfig(const v1::Configuration& proto, const Space& space,
                                  const std::string& field) {
  const Config q = ConfigFromProto(proto);
  space.Validate(q, field);
  const Config normalized = space.Normalize(q);
  if (!space.InBounds(normalized)) throw InputError(field, "outside the space's bounds");
  return normalized;
}

}  // namespace

Space SpaceFromProto(const v1::Space& proto, const std::string& field) {
  std::vector<ComponentSpec> components;
  for (int i = 0; i < proto.components_size(); ++i) {
    const v1::Component& c = proto.components(i);
    const std::string f = Index(field + ".components", i);
    components.push_back(ComponentSpec{
        .type = ComponentTypeFromProto(c.type(), f + ".type"),
        .dimension = c.dimension(),
        .lower = Vector(c.lower()),
        .upper = Vector(c.upper()),
        .translation_weight = c.has_translation_weight() ? c.translation_weight() : 1.0,
        .rotation_weight = c.has_rotation_weight() ? c.rotation_weight() : -1.0,
        .name = c.name(),
    });
  }
  try {
    return Space(std::move(components));
  } catch (const Error& e) {
    RethrowUnder(e, "space", field);
  }
}

v1::Space SpaceToProto(const Space& space) {
  v1::Space proto;
  for (int i = 0; i < space.num_components(); ++i) {
    const ComponentSpec& c = space.component(i);
    v1::Component* out = proto.add_components();
    out->set_type(ComponentTypeToProto(c.type));
    if (c.type == ComponentType::kRealVector) out->set_dimension(c.dimension);
    for (Eigen::Index k = 0; k < c.lower.size(); ++k) out->add_lower(c.lower[k]);
    for (Eigen::Index k = 0; k < c.upper.size(); ++k) out->add_upper(c.upper[k]);
    out->set_translation_weight(c.translation_weight);
    if (c.rotation_weight >= 0) out->set_rotation_weight(c.rotation_weight);
    out->set_name(c.name);
  }
  return proto;
}

Config ConfigFromProto(const v1::Configuration& proto) { return Vector(proto.values()); }

v1::Configuration ConfigToProto(const Config& q) {
  v1::Configuration proto;
  proto.mutable_values()->Reserve(static_cast<int>(q.size()));
  for (Eigen::Index k = 0; k < q.size(); ++k) proto.add_values(q[k]);
  return proto;
}

Eigen::Isometry3d PoseFromProto(const v1::Pose& proto, const std::string& field) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  const std::string fp = field + ".position";
  const std::string fo = field + ".orientation";
  if (proto.position_size() != 0 && proto.position_size() != 3) {
    throw InputError(fp, "expected 3 values (x y z), got " + std::to_string(proto.position_size()));
  }
  if (proto.orientation_size() != 0 && proto.orientation_size() != 4) {
    throw InputError(fo, "expected 4 values (quaternion x y z w), got " +
                             std::to_string(proto.orientation_size()));
  }
  for (int k = 0; k < proto.position_size(); ++k) {
    limits::RequireRange(proto.position(k), -limits::kMaxCoordinate, limits::kMaxCoordinate,
                         Index(fp, k));
  }
  for (int k = 0; k < proto.orientation_size(); ++k) {
    RequireFinite(proto.orientation(k), Index(fo, k));
  }
  if (proto.position_size() == 3) {
    pose.translation() = Eigen::Vector3d(proto.position(0), proto.position(1), proto.position(2));
  }
  if (proto.orientation_size() == 4) {
    Eigen::Quaterniond q(proto.orientation(3), proto.orientation(0), proto.orientation(1),
                         proto.orientation(2));
    const double norm = q.norm();
    if (std::abs(norm - 1.0) > kQuaternionTolerance) {
      throw InputError(fo, "quaternion (x y z w) must have norm 1, got " + Num(norm));
    }
    pose.linear() = q.normalized().toRotationMatrix();
  }
  return pose;
}

std::shared_ptr<const Scene> SceneFromProto(const v1::Scene& proto, const std::string& base_dir,
                                            const BlobResolver& resolver,
                                            const MeshBytesLoader& load_bytes) {
  SceneResolution(proto);
  Scene scene{.name = proto.name(), .space = SpaceFromProto(proto.space(), "scene.space")};
  scene.self_collision = proto.self_collision();
  ShapeConverter shapes(base_dir, resolver, load_bytes);

  for (int i = 0; i < proto.obstacles_size(); ++i) {
    const v1::Obstacle& o = proto.obstacles(i);
    const std::string f = Index("scene.obstacles", i);
    scene.obstacles.push_back(Obstacle{
        .name = o.name().empty() ? "obstacles[" + std::to_string(i) + "]" : o.name(),
        .shape = shapes.Convert(o.shape(), f + ".shape"),
        .pose = PoseFromProto(o.pose(), f + ".pose"),
    });
  }

  if (proto.robot_size() == 0) throw InputError("scene.robot", "the robot needs at least one body");
  for (int i = 0; i < proto.robot_size(); ++i) {
    const v1::RobotBody& b = proto.robot(i);
    const std::string f = Index("scene.robot", i);
    if (b.component() < 0 || b.component() >= scene.space.num_components()) {
      throw InputError(f + ".component", "no component " + std::to_string(b.component()) +
                                             " in a space of " +
                                             std::to_string(scene.space.num_components()));
    }
    if (!scene.space.CanDriveBody(b.component())) {
      throw InputError(f + ".component",
                       std::string("a ") +
                           ComponentTypeName(scene.space.component(b.component()).type) +
                           " component cannot drive a rigid body (use R^2, R^3, SO(2), SO(3), "
                           "SE(2) or SE(3))");
    }
    scene.robot.push_back(RobotBody{
        .name = b.name().empty() ? "robot[" + std::to_string(i) + "]" : b.name(),
        .shape = shapes.Convert(b.shape(), f + ".shape"),
        .component = b.component(),
        .offset = PoseFromProto(b.offset(), f + ".offset"),
    });
  }

  if (proto.has_start()) scene.start = QueryConfig(proto.start(), scene.space, "scene.start");
  if (proto.has_goal()) scene.goal = QueryConfig(proto.goal(), scene.space, "scene.goal");

  try {
    ValidateScene(scene);
  } catch (const Error& e) {
    RethrowUnder(e, "", "scene");
  }
  return std::make_shared<const Scene>(std::move(scene));
}

v1::Scene ReadSceneFile(const std::string& path) {
  // OMPL.app problems are accepted wherever a scene file is (their meshes resolve relative to the
  // .cfg, as a scene file's do).
  if (std::filesystem::path(path).extension() == ".cfg") return ReadOmplAppProblem(path);
  v1::Scene proto;
  ReadJsonFile(path, &proto);
  return proto;
}

std::shared_ptr<const Scene> LoadSceneFile(const std::string& path) {
  const std::string base_dir = std::filesystem::path(path).parent_path().string();
  return SceneFromProto(ReadSceneFile(path), base_dir, BlobResolver());
}

double SceneResolution(const v1::Scene& proto) {
  const double r = proto.resolution();
  if (r != 0 && !(r >= limits::kMinResolution && r <= limits::kMaxResolution)) {
    throw InputError("scene.resolution", "must be 0 (the default " + Num(kDefaultResolution) +
                                             ") or in [" + Num(limits::kMinResolution) + ", " +
                                             Num(limits::kMaxResolution) + "], got " + Num(r));
  }
  return r > 0 ? r : kDefaultResolution;
}

}  // namespace hgraph
