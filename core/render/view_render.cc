#include "core/render/view_render.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <utility>

#include "core/common/client_text.h"
#include "core/common/error.h"
#include "core/render/view_assets.h"

namespace hgraph {
namespace {

using Json = nlohmann::json;
using Vec3 = Eigen::Vector3d;

// Inputs take these in turn; the merged path's stretches take their input's colour, so that the
// eye follows an input into the merged path. Red and near-black are kept for the stretches no
// input owns.
constexpr const char* kInputPalette[] = {"#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd", "#8c564b",
                                         "#17becf", "#bcbd22", "#7f7f7f", "#aec7e8", "#ffbb78"};
constexpr const char* kShortcutColour = "#d62728";
constexpr const char* kBridgeColour = "#111111";
constexpr const char* kUnreportedColour = "#e377c2";
constexpr const char* kMergedColour = "#d62728";
constexpr const char* kRobotColour = "#f2b701";

const char* InputColour(size_t i) {
  return kInputPalette[i % (sizeof(kInputPalette) / sizeof(kInputPalette[0]))];
}

std::string Base64(const void* data, size_t size) {
  static constexpr char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  const auto* bytes = static_cast<const unsigned char*>(data);
  std::string out;
  out.reserve((size + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 2 < size; i += 3) {
    const uint32_t v = (bytes[i] << 16) | (bytes[i + 1] << 8) | bytes[i + 2];
    out += kAlphabet[v >> 18];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += kAlphabet[v & 63];
  }
  if (i + 1 == size) {
    const uint32_t v = bytes[i] << 16;
    out += kAlphabet[v >> 18];
    out += kAlphabet[(v >> 12) & 63];
    out += "==";
  } else if (i + 2 == size) {
    const uint32_t v = (bytes[i] << 16) | (bytes[i + 1] << 8);
    out += kAlphabet[v >> 18];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += '=';
  }
  return out;
}

template <typename T>
std::string Base64(const std::vector<T>& values) {
  return Base64(values.data(), values.size() * sizeof(T));
}

// JSON numbers cannot be infinite or NaN; the page reads null as "not known".
Json Number(double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); }

std::string HtmlEscape(const std::string& text) {
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

bool IsPlanar(const Scene& scene) {
  for (int c : RobotComponents(scene)) {
    const ComponentSpec& spec = scene.space.component(c);
    const bool planar = spec.type == ComponentType::kSE2 || spec.type == ComponentType::kSO2 ||
                        (spec.type == ComponentType::kRealVector && spec.dimension == 2);
    if (!planar) return false;
  }
  return true;
}

class ViewWriter {
 public:
  ViewWriter(const Scene& scene, const ViewRequest& request)
      : scene_(scene), request_(request), components_(RobotComponents(scene)) {}

  std::string Write() {
    Json data;
    data["title"] =
        request_.title.empty() ? (scene_.name.empty() ? "scene" : scene_.name) : request_.title;
    data["planar"] = IsPlanar(scene_);
    data["robot_colour"] = kRobotColour;
    data["bounds"] = Bounds();
    data["meshes"] = Json::array();
    data["obstacles"] = Json::array();
    for (size_t i = 0; i < scene_.obstacles.size(); ++i) {
      const Obstacle& o = scene_.obstacles[i];
      const Eigen::Matrix4d m = o.pose.matrix();
      data["obstacles"].push_back(
          {{"name", o.name},
           {"shape", ShapeJson(o.shape, "scene.obstacles[" + std::to_string(i) + "]")},
           {"pose", std::vector<double>(m.data(), m.data() + 16)}});
    }
    data["bodies"] = Json::array();
    for (size_t i = 0; i < scene_.robot.size(); ++i) {
      const RobotBody& b = scene_.robot[i];
      data["bodies"].push_back(
          {{"name", b.name},
           {"shape", ShapeJson(b.shape, "scene.robot[" + std::to_string(i) + "]")}});
    }
    data["meshes"] = meshes_;
    data["inputs"] = Json::array();
    for (size_t i = 0; i < request_.inputs.size(); ++i) {
      Json p = PathJson(request_.inputs[i], InputColour(i));
      data["inputs"].push_back(std::move(p));
    }
    data["merged"] = nullptr;
    data["sources"] = Json::array();
    if (request_.merged) data["merged"] = MergedJson(&data["sources"]);
    const InputPath* reference = request_.merged           ? &request_.merged->path
                                 : request_.inputs.empty() ? nullptr
                                                           : &request_.inputs.front().path;
    std::optional<Config> start = scene_.start;
    std::optional<Config> goal = scene_.goal;
    if (reference != nullptr && !reference->waypoints.empty()) {
      start = reference->waypoints.front();
      goal = reference->waypoints.back();
    }
    data["start"] = Json::array();
    data["goal"] = Json::array();
    for (int c : components_) {
      if (start) data["start"].push_back(Point(scene_.space.Pose(c, *start).translation()));
      if (goal) data["goal"].push_back(Point(scene_.space.Pose(c, *goal).translation()));
    }
    if (!request_.measure.empty()) {
      Json m = {{"name", request_.measure}};
      if (request_.objective) m["objective"] = Number(*request_.objective);
      if (request_.best_input_objective) {
        m["best_input_objective"] = Number(*request_.best_input_objective);
      }
      data["measure"] = std::move(m);
    }
    data["rounds"] = Json::array();
    for (const OptimizeRound& r : request_.rounds) {
      data["rounds"].push_back({{"round", r.round},
                                {"elapsed_ms", Number(r.elapsed_ms)},
                                {"objective", Number(r.objective)}});
    }
    return Html(data["title"].get<std::string>(), data);
  }

 private:
  static std::vector<double> Point(const Vec3& p) { return {p.x(), p.y(), p.z()}; }

  // The translational bounds of the components that drive bodies (2D ones at z = 0), widened
  // by the robot's size so that the robot at the boundary stays in the frame.
  Json Bounds() const {
    Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity());
    Vec3 hi = -lo;
    for (int c : components_) {
      const ComponentSpec& spec = scene_.space.component(c);
      Vec3 a = Vec3::Zero();
      Vec3 b = Vec3::Zero();
      if (spec.type != ComponentType::kSO2 && spec.type != ComponentType::kSO3) {
        const int n = static_cast<int>(std::min<Eigen::Index>(3, spec.lower.size()));
        a.head(n) = spec.lower.head(n);
        b.head(n) = spec.upper.head(n);
      }
      lo = lo.cwiseMin(a);
      hi = hi.cwiseMax(b);
    }
    if (components_.empty()) lo = hi = Vec3::Zero();
    if ((hi - lo).norm() < 1e-9) {
      double r = 1;
      for (const RobotBody& body : scene_.robot) {
        if (body.shape.type == ShapeType::kMesh && body.shape.mesh != nullptr) {
          for (const Vec3& v : body.shape.mesh->vertices) r = std::max(r, (body.offset * v).norm());
        }
      }
      lo -= Vec3::Constant(r);
      hi += Vec3::Constant(r);
    }
    return {{"lower", Point(lo)}, {"upper", Point(hi)}};
  }

  Json ShapeJson(const Shape& shape, const std::string& field) {
    switch (shape.type) {
      case ShapeType::kBox: return {{"type", "box"}, {"size", Point(shape.box_size)}};
      case ShapeType::kSphere: return {{"type", "sphere"}, {"radius", shape.radius}};
      case ShapeType::kCylinder:
        return {{"type", "cylinder"}, {"radius", shape.radius}, {"length", shape.length}};
      case ShapeType::kMesh: return {{"type", "mesh"}, {"mesh", MeshIndex(shape, field)}};
    }
    return {{"type", "box"}, {"size", Point(Vec3::Zero())}};
  }

  // Each mesh goes into the file once however many obstacles and bodies use it.
  int MeshIndex(const Shape& shape, const std::string& field) {
    HGRAPH_CHECK(shape.mesh != nullptr);
    const auto it = mesh_index_.find(shape.mesh.get());
    if (it != mesh_index_.end()) return it->second;
    const Mesh& mesh = *shape.mesh;
    const int64_t triangles = static_cast<int64_t>(mesh.triangles.size());
    if (triangles > request_.max_mesh_triangles) {
      throw InputError(field, "mesh '" + ClientText(shape.source) + "' has " +
                                  std::to_string(triangles) +
                                  " triangles, more than the view's limit of " +
                                  std::to_string(request_.max_mesh_triangles));
    }
    std::vector<float> positions;
    positions.reserve(mesh.vertices.size() * 3);
    for (const Vec3& v : mesh.vertices) {
      for (int k = 0; k < 3; ++k) positions.push_back(static_cast<float>(v[k]));
    }
    std::vector<uint32_t> indices;
    indices.reserve(mesh.triangles.size() * 3);
    for (const Eigen::Vector3i& t : mesh.triangles) {
      for (int k = 0; k < 3; ++k) indices.push_back(static_cast<uint32_t>(t[k]));
    }
    meshes_.push_back({{"positions", Base64(positions)}, {"indices", Base64(indices)}});
    const int index = static_cast<int>(meshes_.size()) - 1;
    mesh_index_[shape.mesh.get()] = index;
    return index;
  }

  Json PathJson(const RenderPath& render, const char* colour) const {
    const InputPath& path = render.path;
    Json p = {{"name", path.name}, {"colour", colour}};
    const double length = render.quality ? render.quality->length : PathLength(scene_.space, path);
    p["length"] = Number(length);
    p["has_clearance"] = render.quality && render.quality->has_clearance;
    p["min_clearance"] = render.quality ? Number(render.quality->min_clearance) : Json(nullptr);
    p["traces"] = Json::array();
    for (int c : components_) {
      std::vector<float> xyz;
      xyz.reserve(path.waypoints.size() * 3);
      for (const Config& q : path.waypoints) {
        const Vec3 t = scene_.space.Pose(c, q).translation();
        for (int k = 0; k < 3; ++k) xyz.push_back(static_cast<float>(t[k]));
      }
      p["traces"].push_back(Base64(xyz));
    }
    // Per frame, per body: position and quaternion (x y z w), posed as the space defines.
    const std::vector<Config> samples = SamplesAlong(scene_.space, path, request_.frames);
    std::vector<float> frames;
    frames.reserve(samples.size() * scene_.robot.size() * 7);
    for (const Config& q : samples) {
      for (const RobotBody& body : scene_.robot) {
        const Eigen::Isometry3d pose = scene_.space.Pose(body.component, q) * body.offset;
        const Eigen::Quaterniond r(pose.linear());
        const Vec3& t = pose.translation();
        for (double v : {t.x(), t.y(), t.z(), r.x(), r.y(), r.z(), r.w()}) {
          frames.push_back(static_cast<float>(v));
        }
      }
    }
    p["frames"] = Base64(frames);
    p["frame_count"] = samples.size();
    return p;
  }

  Json MergedJson(Json* legend) const {
    Json p = PathJson(*request_.merged, kMergedColour);
    const size_t n = request_.merged->path.waypoints.size();
    std::vector<int> stretches;
    if (request_.sources.empty()) {
      stretches.assign(n > 0 ? n - 1 : 0, std::numeric_limits<int>::min());
    } else {
      stretches = StretchSources(request_.sources, request_.input_waypoints);
    }
    std::set<int> used(stretches.begin(), stretches.end());
    Json colours = Json::array();
    for (int s : stretches) colours.push_back(StretchColour(s));
    p["segment_colours"] = std::move(colours);
    p["segment_sources"] = stretches;
    for (size_t i = 0; i < request_.inputs.size(); ++i) {
      if (used.count(static_cast<int>(i)) > 0) {
        legend->push_back(
            {{"label", request_.inputs[i].path.name}, {"colour", InputColour(i)}, {"source", i}});
      }
    }
    // Sources beyond the inputs given (a paths file with fewer paths than the merge had).
    for (int s : used) {
      if (s >= static_cast<int>(request_.inputs.size())) {
        legend->push_back(
            {{"label", "input " + std::to_string(s)}, {"colour", StretchColour(s)}, {"source", s}});
      }
    }
    if (used.count(kBridgeStretch) > 0) {
      legend->push_back(
          {{"label", "bridge"}, {"colour", kBridgeColour}, {"source", kBridgeStretch}});
    }
    if (used.count(kShortcutStretch) > 0) {
      legend->push_back(
          {{"label", "shortcut"}, {"colour", kShortcutColour}, {"source", kShortcutStretch}});
    }
    if (used.count(std::numeric_limits<int>::min()) > 0) {
      legend->push_back({{"label", "source not reported"}, {"colour", kUnreportedColour}});
    }
    return p;
  }

  static const char* StretchColour(int source) {
    if (source >= 0) return InputColour(static_cast<size_t>(source));
    if (source == kShortcutStretch) return kShortcutColour;
    if (source == kBridgeStretch) return kBridgeColour;
    return kUnreportedColour;
  }

  static std::string Html(const std::string& title, const Json& data) {
    // '<' only occurs inside JSON strings, where \u003c means the same: no text of the data can
    // end the <script> element that holds it.
    std::string json;
    for (char c : data.dump()) {
      if (c == '<') {
        json += "\\u003c";
      } else {
        json += c;
      }
    }
    const auto append = [](std::string* out, const char* const* parts) {
      for (; *parts != nullptr; ++parts) *out += *parts;
    };
    std::string html;
    html.reserve(json.size() + (1 << 20));
    html += "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n";
    html += "<meta name=\"generator\" content=\"hgraph view (three.js ";
    html += view_assets::kThreeVersion;
    html += ")\">\n<title>" + HtmlEscape(title) + " - hgraph view</title>\n<style>\n";
    append(&html, view_assets::kPageCss);
    html += "</style>\n</head>\n<body>\n<canvas id=\"view\"></canvas>\n<div id=\"legend\"></div>\n";
    html += "<div id=\"chart\"></div>\n<div id=\"bar\">\n";
    html += "<button id=\"play\" type=\"button\">Play</button>\n";
    html +=
        "<input id=\"time\" type=\"range\" min=\"0\" max=\"1000\" value=\"0\" "
        "aria-label=\"position along the path\">\n";
    html +=
        "<label>speed <select id=\"speed\"><option value=\"0.25\">0.25x</option>"
        "<option value=\"0.5\">0.5x</option><option value=\"1\" selected>1x</option>"
        "<option value=\"2\">2x</option><option value=\"4\">4x</option></select></label>\n";
    html += "<button id=\"home\" type=\"button\">Reset view</button>\n";
    html += "<label><input id=\"xray\" type=\"checkbox\"> see-through obstacles</label>\n</div>\n";
    html += "<script type=\"application/json\" id=\"hgraph-view-data\">";
    html += json;
    html += "</script>\n<script>\n";
    append(&html, view_assets::kThreeJs);
    html += "</script>\n<script>\n";
    append(&html, view_assets::kPageJs);
    html += "</script>\n</body>\n</html>\n";
    return html;
  }

  const Scene& scene_;
  const ViewRequest& request_;
  std::vector<int> components_;
  Json meshes_ = Json::array();
  std::map<const Mesh*, int> mesh_index_;
};

}  // namespace

std::vector<int> StretchSources(const std::vector<WaypointSource>& sources,
                                const std::vector<int>& input_waypoints) {
  // `end` moved onto input `path` when it is the shared start or goal, else unchanged.
  const auto on_input = [&](WaypointSource end, int path) {
    if (end.path == path || end.t != 0) return end;
    const auto count = [&](int p) {
      return p >= 0 && p < static_cast<int>(input_waypoints.size()) ? input_waypoints[p] : -1;
    };
    if (end.index == 0) return WaypointSource{.path = path, .index = 0};
    if (count(end.path) > 0 && end.index == count(end.path) - 1 && count(path) > 0) {
      return WaypointSource{.path = path, .index = count(path) - 1};
    }
    return end;
  };
  std::vector<int> stretches;
  for (size_t i = 0; i + 1 < sources.size(); ++i) {
    WaypointSource a = sources[i];
    WaypointSource b = sources[i + 1];
    if (a.path < 0 || b.path < 0) {
      stretches.push_back(kShortcutStretch);
      continue;
    }
    if (a.path != b.path) {
      const WaypointSource a_on_b = on_input(a, b.path);
      if (a_on_b.path == b.path) {
        a = a_on_b;
      } else {
        b = on_input(b, a.path);
      }
    }
    // On one edge of one input (either way round): both positions within [k, k + 1].
    const double pa = a.index + a.t;
    const double pb = b.index + b.t;
    const double lo = std::min(pa, pb);
    const double hi = std::max(pa, pb);
    const bool one_edge = a.path == b.path && hi <= std::floor(lo) + 1 + 1e-9;
    stretches.push_back(one_edge ? a.path : kBridgeStretch);
  }
  return stretches;
}

std::string RenderViewHtml(const Scene& scene, const ViewRequest& request) {
  if (request.frames < 2 || request.frames > 100000) {
    throw InputError("request.frames",
                     "must be in [2, 100000], got " + std::to_string(request.frames));
  }
  if (request.max_mesh_triangles < 0) {
    throw InputError("request.max_mesh_triangles",
                     "must not be negative, got " + std::to_string(request.max_mesh_triangles));
  }
  for (size_t i = 0; i < request.inputs.size(); ++i) {
    ValidatePath(scene.space, request.inputs[i].path, "request.inputs[" + std::to_string(i) + "]");
  }
  if (request.merged) {
    ValidatePath(scene.space, request.merged->path, "request.merged");
    const size_t n = request.merged->path.waypoints.size();
    if (!request.sources.empty() && request.sources.size() != n) {
      throw InputError("request.sources", "has " + std::to_string(request.sources.size()) +
                                              " entries for a merged path of " + std::to_string(n) +
                                              " waypoints");
    }
  } else if (!request.sources.empty()) {
    throw InputError("request.sources", "given without a merged path");
  }
  return ViewWriter(scene, request).Write();
}

}  // namespace hgraph
