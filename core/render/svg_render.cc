#include "core/render/svg_render.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <set>
#include <utility>

#include "core/common/client_text.h"
#include "core/common/error.h"

namespace hgraph {
namespace {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;

// Colours: obstacles neutral, inputs light grey so that they recede, the merged path in one
// saturated colour that nothing else uses (tests look for its pixels), the robot translucent.
constexpr const char* kObstacleFill = "#5f5f5f";
constexpr const char* kObstacleStroke = "#3c3c3c";
constexpr const char* kInputColour = "#a0a0a0";
constexpr const char* kMergedColour = "#d62728";
constexpr const char* kRobotColour = "#1f77b4";
constexpr const char* kStartColour = "#2ca02c";
constexpr const char* kGoalColour = "#9467bd";
constexpr const char* kFont = "DejaVu Sans, Helvetica, Arial, sans-serif";

constexpr double kPadPx = 12;
constexpr double kLegendRowPx = 20;
constexpr int kCircleSegments = 32;  // a cylinder's end discs, before the convex hull

Vec2 Project(const Vec3& p, Plane plane) {
  switch (plane) {
    case Plane::kXY: return {p.x(), p.y()};
    case Plane::kXZ: return {p.x(), p.z()};
    case Plane::kYZ: return {p.y(), p.z()};
  }
  return {p.x(), p.y()};
}

// World (projected) coordinates to pixels; SVG's y axis points down, the picture's up.
struct View {
  double u_min = 0;
  double v_max = 0;
  double scale = 1;
  Vec2 ToPx(const Vec2& w) const {
    return {kPadPx + (w.x() - u_min) * scale, kPadPx + (v_max - w.y()) * scale};
  }
};

std::string Num(double v) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.2f", v);
  return text;
}

std::string Quantity(double v) {
  if (std::isnan(v)) return "n/a";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  char text[32];
  std::snprintf(text, sizeof(text), "%.4g", v);
  return text;
}

std::string Escape(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

double Cross(const Vec2& o, const Vec2& a, const Vec2& b) {
  return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
}

// Andrew's monotone chain. The projection of a convex solid is the convex hull of its projected
// vertices, which makes boxes exact and cylinders exact up to the disc sampling.
std::vector<Vec2> ConvexHull(std::vector<Vec2> points) {
  std::sort(points.begin(), points.end(), [](const Vec2& a, const Vec2& b) {
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
  });
  if (points.size() < 3) return points;
  std::vector<Vec2> hull(2 * points.size());
  size_t k = 0;
  for (const Vec2& p : points) {
    while (k >= 2 && Cross(hull[k - 2], hull[k - 1], p) <= 0) --k;
    hull[k++] = p;
  }
  for (size_t i = points.size() - 1, lower = k + 1; i-- > 0;) {
    while (k >= lower && Cross(hull[k - 2], hull[k - 1], points[i]) <= 0) --k;
    hull[k++] = points[i];
  }
  hull.resize(k - 1);
  return hull;
}

void AppendPolygon(const std::vector<Vec2>& px, std::string* d) {
  if (px.empty()) return;
  *d += "M" + Num(px[0].x()) + " " + Num(px[0].y());
  for (size_t i = 1; i < px.size(); ++i) *d += "L" + Num(px[i].x()) + " " + Num(px[i].y());
  *d += "Z";
}

// Vertices whose projection's hull is the projection of a convex primitive.
std::vector<Vec3> PrimitiveVertices(const Shape& shape) {
  std::vector<Vec3> v;
  switch (shape.type) {
    case ShapeType::kBox: {
      const Vec3 h = shape.box_size / 2;
      for (int i = 0; i < 8; ++i) {
        v.emplace_back(i & 1 ? h.x() : -h.x(), i & 2 ? h.y() : -h.y(), i & 4 ? h.z() : -h.z());
      }
      break;
    }
    case ShapeType::kCylinder:
      for (int i = 0; i < kCircleSegments; ++i) {
        const double a = 2 * M_PI * i / kCircleSegments;
        for (double z : {-shape.length / 2, shape.length / 2}) {
          v.emplace_back(shape.radius * std::cos(a), shape.radius * std::sin(a), z);
        }
      }
      break;
    case ShapeType::kSphere:
    case ShapeType::kMesh: break;
  }
  return v;
}

// SVG path data of the shape's projection at `pose`. Meshes become their projected triangles,
// each turned counter-clockwise so that the nonzero fill rule paints their union: front and
// back faces of a closed mesh project with opposite windings and would otherwise cancel.
std::string ShapePathData(const Shape& shape, const Eigen::Isometry3d& pose, Plane plane,
                          const View& view) {
  std::string d;
  if (shape.type == ShapeType::kSphere) {
    const Vec2 c = view.ToPx(Project(pose.translation(), plane));
    const double r = shape.radius * view.scale;
    if (r <= 0) return d;
    // Two arcs: a <circle> cannot join the other subpaths of a body.
    d += "M" + Num(c.x() - r) + " " + Num(c.y()) + "a" + Num(r) + " " + Num(r) + " 0 1 0 " +
         Num(2 * r) + " 0a" + Num(r) + " " + Num(r) + " 0 1 0 " + Num(-2 * r) + " 0Z";
    return d;
  }
  if (shape.type == ShapeType::kMesh) {
    if (shape.mesh == nullptr) return d;
    std::vector<Vec2> px;
    px.reserve(shape.mesh->vertices.size());
    for (const Vec3& v : shape.mesh->vertices) px.push_back(view.ToPx(Project(pose * v, plane)));
    for (const Eigen::Vector3i& t : shape.mesh->triangles) {
      const Vec2& a = px[t[0]];
      Vec2 b = px[t[1]];
      Vec2 c = px[t[2]];
      const double area2 = Cross(a, b, c);
      if (std::abs(area2) < 1e-6) continue;  // seen edge-on: covered by the faces around it
      if (area2 < 0) std::swap(b, c);
      AppendPolygon({a, b, c}, &d);
    }
    return d;
  }
  std::vector<Vec2> px;
  for (const Vec3& v : PrimitiveVertices(shape)) px.push_back(view.ToPx(Project(pose * v, plane)));
  AppendPolygon(ConvexHull(std::move(px)), &d);
  return d;
}

// Largest distance from a shape's origin to its surface.
double ShapeRadius(const Shape& shape) {
  switch (shape.type) {
    case ShapeType::kBox: return shape.box_size.norm() / 2;
    case ShapeType::kSphere: return shape.radius;
    case ShapeType::kCylinder: return std::hypot(shape.radius, shape.length / 2);
    case ShapeType::kMesh: {
      double r = 0;
      if (shape.mesh != nullptr) {
        for (const Vec3& v : shape.mesh->vertices) r = std::max(r, v.norm());
      }
      return r;
    }
  }
  return 0;
}

bool Rotates(ComponentType type) { return type != ComponentType::kRealVector; }

// Translational bounds of a component as a 3D box (2D components live in the plane z = 0;
// pure rotations stay at the origin).
std::pair<Vec3, Vec3> ComponentBox(const ComponentSpec& c) {
  Vec3 lo = Vec3::Zero();
  Vec3 hi = Vec3::Zero();
  const int n = static_cast<int>(std::min<Eigen::Index>(3, c.lower.size()));
  if (c.type == ComponentType::kSO2 || c.type == ComponentType::kSO3) return {lo, hi};
  lo.head(n) = c.lower.head(n);
  hi.head(n) = c.upper.head(n);
  return {lo, hi};
}

class SvgWriter {
 public:
  SvgWriter(const Scene& scene, const RenderRequest& request)
      : scene_(scene), request_(request), components_(RobotComponents(scene)) {}

  std::string Write() {
    FitView();
    const int rows = static_cast<int>(request_.inputs.size()) + (request_.merged ? 1 : 0) + 2;
    const double legend_top = plot_h_ + 2 * kPadPx;
    const double height = legend_top + rows * kLegendRowPx + kPadPx;
    out_ += "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
    out_ += "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + Num(width_) + "\" height=\"" +
            Num(height) + "\" viewBox=\"0 0 " + Num(width_) + " " + Num(height) + "\">\n";
    out_ += "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
    // Everything of the scene is clipped to the fitted bounds so it never runs into the legend.
    out_ += "<defs><clipPath id=\"plot\"><rect x=\"" + Num(kPadPx) + "\" y=\"" + Num(kPadPx) +
            "\" width=\"" + Num(plot_w_) + "\" height=\"" + Num(plot_h_) +
            "\"/></clipPath></defs>\n";
    out_ += "<g clip-path=\"url(#plot)\">\n";
    WriteBounds();
    WriteObstacles();
    for (const RenderPath& input : request_.inputs) WriteTrace(input.path, kInputColour, 1.3);
    WriteFootprints();
    if (request_.merged) WriteTrace(request_.merged->path, kMergedColour, 3.5);
    WriteEndpoints();
    out_ += "</g>\n";
    out_ += "<rect x=\"" + Num(kPadPx) + "\" y=\"" + Num(kPadPx) + "\" width=\"" + Num(plot_w_) +
            "\" height=\"" + Num(plot_h_) +
            "\" fill=\"none\" stroke=\"#222\" stroke-width=\"1\"/>\n";
    WriteLegend(legend_top);
    out_ += "</svg>\n";
    return out_;
  }

 private:
  void FitView() {
    Vec2 lo = Vec2::Constant(std::numeric_limits<double>::infinity());
    Vec2 hi = -lo;
    double robot_radius = 0;
    for (const RobotBody& body : scene_.robot) {
      // Meshes are measured in the body frame: OMPL.app robots sit far from their mesh origin.
      if (body.shape.type == ShapeType::kMesh && body.shape.mesh != nullptr) {
        for (const Vec3& v : body.shape.mesh->vertices) {
          robot_radius = std::max(robot_radius, (body.offset * v).norm());
        }
        continue;
      }
      robot_radius =
          std::max(robot_radius, body.offset.translation().norm() + ShapeRadius(body.shape));
    }
    for (int c : components_) {
      const auto [box_lo, box_hi] = ComponentBox(scene_.space.component(c));
      for (const Vec3& corner : {box_lo, box_hi}) {
        lo = lo.cwiseMin(Project(corner, request_.plane));
        hi = hi.cwiseMax(Project(corner, request_.plane));
      }
    }
    // A 2D space seen from the side (or a pure rotation) has no extent along an axis: widen it
    // by the obstacles so that the picture still shows something sensible.
    for (int axis = 0; axis < 2; ++axis) {
      if (hi[axis] - lo[axis] > 1e-9) continue;
      for (const Obstacle& obstacle : scene_.obstacles) {
        const double r = ShapeRadius(obstacle.shape);
        const Vec2 p = Project(obstacle.pose.translation(), request_.plane);
        lo[axis] = std::min(lo[axis], p[axis] - r);
        hi[axis] = std::max(hi[axis], p[axis] + r);
      }
      if (!(hi[axis] - lo[axis] > 1e-9)) {
        lo[axis] = -1;
        hi[axis] = 1;
      }
    }
    const double margin = robot_radius + 0.02 * std::max(hi.x() - lo.x(), hi.y() - lo.y());
    lo -= Vec2::Constant(margin);
    hi += Vec2::Constant(margin);
    width_ = request_.width_px;
    view_.u_min = lo.x();
    view_.v_max = hi.y();
    view_.scale = (width_ - 2 * kPadPx) / (hi.x() - lo.x());
    // Tall views are capped at twice the width so that the legend stays on screen.
    const double max_plot_h = 2.0 * width_;
    if ((hi.y() - lo.y()) * view_.scale > max_plot_h) view_.scale = max_plot_h / (hi.y() - lo.y());
    plot_w_ = (hi.x() - lo.x()) * view_.scale;
    plot_h_ = (hi.y() - lo.y()) * view_.scale;
  }

  void WriteBounds() {
    for (int c : components_) {
      const auto [box_lo, box_hi] = ComponentBox(scene_.space.component(c));
      const Vec2 a = view_.ToPx(Project(box_lo, request_.plane));
      const Vec2 b = view_.ToPx(Project(box_hi, request_.plane));
      const Vec2 lo = a.cwiseMin(b);
      const Vec2 size = (a - b).cwiseAbs();
      out_ += "<rect x=\"" + Num(lo.x()) + "\" y=\"" + Num(lo.y()) + "\" width=\"" + Num(size.x()) +
              "\" height=\"" + Num(size.y()) +
              "\" fill=\"none\" stroke=\"#bbbbbb\" stroke-width=\"1\" stroke-dasharray=\"4 3\"/>\n";
    }
  }

  void WriteObstacles() {
    out_ += "<g fill=\"" + std::string(kObstacleFill) + "\">\n";
    for (const Obstacle& obstacle : scene_.obstacles) {
      const std::string d = ShapePathData(obstacle.shape, obstacle.pose, request_.plane, view_);
      if (d.empty()) continue;
      // Meshes get no outline: it would draw every projected triangle's edges.
      const bool outline = obstacle.shape.type != ShapeType::kMesh;
      out_ += "<path d=\"" + d + "\"" +
              (outline ? std::string(" stroke=\"") + kObstacleStroke + "\" stroke-width=\"0.8\""
                       : std::string()) +
              "/>\n";
    }
    out_ += "</g>\n";
  }

  // One polyline per component that drives a body (two wrenches leave two traces).
  void WriteTrace(const InputPath& path, const char* colour, double width) {
    for (int c : components_) {
      std::string points;
      for (const Config& q : path.waypoints) {
        const Vec2 p = view_.ToPx(Project(scene_.space.Pose(c, q).translation(), request_.plane));
        points += Num(p.x()) + "," + Num(p.y()) + " ";
      }
      out_ += "<polyline points=\"" + points + "\" fill=\"none\" stroke=\"" + colour +
              "\" stroke-width=\"" + Num(width) +
              "\" stroke-linejoin=\"round\" stroke-linecap=\"round\"/>\n";
    }
  }

  const InputPath* ReferencePath() const {
    if (request_.merged && !request_.merged->path.waypoints.empty()) return &request_.merged->path;
    for (const RenderPath& input : request_.inputs) {
      if (!input.path.waypoints.empty()) return &input.path;
    }
    return nullptr;
  }

  void WriteRobotAt(const Config& q, double opacity) {
    for (const RobotBody& body : scene_.robot) {
      const Eigen::Isometry3d pose = scene_.space.Pose(body.component, q) * body.offset;
      const std::string d = ShapePathData(body.shape, pose, request_.plane, view_);
      if (d.empty()) continue;
      drew_robot_ = true;
      const bool outline = body.shape.type != ShapeType::kMesh;
      out_ += "<path d=\"" + d + "\" fill=\"" + kRobotColour + "\" fill-opacity=\"" + Num(opacity) +
              "\"" +
              (outline ? std::string(" stroke=\"") + kRobotColour + "\" stroke-width=\"1\""
                       : std::string()) +
              "/>\n";
    }
  }

  // The robot at start and goal always (it shows its size); along the merged path as well when
  // it rotates, as in the paper's Figure 1, since a trace of the reference point hides turning.
  void WriteFootprints() {
    const InputPath* path = ReferencePath();
    if (path == nullptr) return;
    bool rotates = false;
    for (const RobotBody& body : scene_.robot) {
      rotates = rotates || Rotates(scene_.space.component(body.component).type);
    }
    const int count = rotates && request_.merged ? request_.footprints : 0;
    out_ += "<g>\n";
    for (const Config& q : SamplesAlong(scene_.space, *path, count)) WriteRobotAt(q, 0.22);
    out_ += "</g>\n";
  }

  void WriteEndpoints() {
    const InputPath* path = ReferencePath();
    std::optional<Config> start = scene_.start;
    std::optional<Config> goal = scene_.goal;
    if (path != nullptr) {
      start = path->waypoints.front();
      goal = path->waypoints.back();
    }
    for (int c : components_) {
      if (start) {
        const Vec2 p =
            view_.ToPx(Project(scene_.space.Pose(c, *start).translation(), request_.plane));
        out_ += "<circle cx=\"" + Num(p.x()) + "\" cy=\"" + Num(p.y()) + "\" r=\"6\" fill=\"" +
                kStartColour + "\" stroke=\"white\" stroke-width=\"1.5\"/>\n";
      }
      if (goal) {
        const Vec2 p =
            view_.ToPx(Project(scene_.space.Pose(c, *goal).translation(), request_.plane));
        out_ += "<rect x=\"" + Num(p.x() - 6) + "\" y=\"" + Num(p.y() - 6) +
                "\" width=\"12\" height=\"12\" fill=\"" + kGoalColour +
                "\" stroke=\"white\" stroke-width=\"1.5\"/>\n";
      }
    }
  }

  void LegendText(double x, double y, const std::string& text, bool bold = false) {
    out_ += "<text x=\"" + Num(x) + "\" y=\"" + Num(y) + "\" font-family=\"" + kFont +
            "\" font-size=\"13\"" + (bold ? " font-weight=\"bold\"" : "") + " fill=\"#222\">" +
            Escape(text) + "</text>\n";
  }

  void LegendRow(double y, const RenderPath& path, const char* colour, double width) {
    out_ += "<line x1=\"" + Num(kPadPx) + "\" y1=\"" + Num(y - 4) + "\" x2=\"" + Num(kPadPx + 28) +
            "\" y2=\"" + Num(y - 4) + "\" stroke=\"" + colour + "\" stroke-width=\"" + Num(width) +
            "\" stroke-linecap=\"round\"/>\n";
    const double length = path.quality ? path.quality->length : PathLength(scene_.space, path.path);
    const double clearance = path.quality && path.quality->has_clearance
                                 ? path.quality->min_clearance
                                 : std::numeric_limits<double>::quiet_NaN();
    LegendText(kPadPx + 36, y, path.path.name);
    LegendText(kPadPx + 250, y, "length " + Quantity(length));
    LegendText(kPadPx + 420, y, "min clearance " + Quantity(clearance));
  }

  void WriteLegend(double top) {
    double y = top + 14;
    std::string title = request_.title.empty() ? scene_.name : request_.title;
    if (title.empty()) title = "scene";
    LegendText(kPadPx, y, title + "  (" + PlaneName(request_.plane) + " plane)", true);
    y += kLegendRowPx;
    for (const RenderPath& input : request_.inputs) {
      LegendRow(y, input, kInputColour, 1.3);
      y += kLegendRowPx;
    }
    if (request_.merged) {
      LegendRow(y, *request_.merged, kMergedColour, 3.5);
      y += kLegendRowPx;
    }
    out_ += "<circle cx=\"" + Num(kPadPx + 6) + "\" cy=\"" + Num(y - 4) + "\" r=\"5\" fill=\"" +
            kStartColour + "\"/>\n";
    LegendText(kPadPx + 16, y, "start");
    out_ += "<rect x=\"" + Num(kPadPx + 70) + "\" y=\"" + Num(y - 9) +
            "\" width=\"10\" height=\"10\" fill=\"" + kGoalColour + "\"/>\n";
    LegendText(kPadPx + 86, y, "goal");
    if (!drew_robot_) return;  // a point robot has nothing to show
    out_ += "<rect x=\"" + Num(kPadPx + 140) + "\" y=\"" + Num(y - 9) +
            "\" width=\"14\" height=\"10\" fill=\"" + kRobotColour +
            "\" fill-opacity=\"0.22\" stroke=\"" + kRobotColour + "\"/>\n";
    LegendText(kPadPx + 160, y, "robot");
  }

  const Scene& scene_;
  const RenderRequest& request_;
  std::vector<int> components_;
  View view_;
  double width_ = 0;
  double plot_w_ = 0;
  double plot_h_ = 0;
  bool drew_robot_ = false;
  std::string out_;
};

}  // namespace

Plane ParsePlane(const std::string& name, const std::string& field) {
  if (name == "xy") return Plane::kXY;
  if (name == "xz") return Plane::kXZ;
  if (name == "yz") return Plane::kYZ;
  throw InputError(field, "plane must be xy, xz or yz, got '" + ClientText(name) + "'");
}

const char* PlaneName(Plane plane) {
  switch (plane) {
    case Plane::kXY: return "xy";
    case Plane::kXZ: return "xz";
    case Plane::kYZ: return "yz";
  }
  return "xy";
}

std::string RenderSvg(const Scene& scene, const RenderRequest& request) {
  if (request.width_px < 100 || request.width_px > 20000) {
    throw InputError("request.width_px",
                     "must be in [100, 20000], got " + std::to_string(request.width_px));
  }
  if (request.footprints < 0 || request.footprints > 1000) {
    throw InputError("request.footprints",
                     "must be in [0, 1000], got " + std::to_string(request.footprints));
  }
  for (size_t i = 0; i < request.inputs.size(); ++i) {
    ValidatePath(scene.space, request.inputs[i].path, "request.inputs[" + std::to_string(i) + "]");
  }
  if (request.merged) ValidatePath(scene.space, request.merged->path, "request.merged");
  return SvgWriter(scene, request).Write();
}

}  // namespace hgraph
