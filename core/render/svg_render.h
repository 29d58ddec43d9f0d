// SVG pictures of a scene and paths, as in the paper's Figure 1: obstacles seen from above (or
// projected on another axis plane), input paths thin and grey, the merged path bold, start and
// goal marked, the robot drawn at intervals along the merged path, and a legend with each path's
// length and minimum clearance. No dependency beyond the core types: the SVG is written by hand
// and renders with librsvg (rsvg-convert) and browsers alike.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "core/measure/measure.h"
#include "core/path/path.h"
#include "core/scene/scene.h"

namespace hgraph {

// The axis plane the picture is projected on; the first axis points right, the second up.
enum class Plane { kXY, kXZ, kYZ };

// Parses "xy", "xz" or "yz"; anything else is an InputError naming `field`.
Plane ParsePlane(const std::string& name, const std::string& field);
const char* PlaneName(Plane plane);

// A path to draw and what the legend says about it. Plain struct; copyable.
struct RenderPath {
  InputPath path;
  // From a MergeResult. Without it the legend shows the length under the space's metric and no
  // clearance (computing clearance needs the collision world, which a picture does not).
  std::optional<PathQuality> quality;
};

struct RenderRequest {
  std::vector<RenderPath> inputs;    // drawn thin and grey
  std::optional<RenderPath> merged;  // drawn bold, with the robot's footprints along it
  Plane plane = Plane::kXY;
  int width_px = 900;  // the picture's width; its height follows the bounds' aspect ratio
  // For robots that rotate, the robot is drawn at this many points evenly spaced (in the space's
  // metric) along the merged path, ends included. 0 draws it at start and goal only.
  int footprints = 12;
  std::string title;  // first line of the legend; empty = the scene's name
};

// The SVG document. The view is fitted to the space's bounds (of the components that drive
// robot bodies), widened by the robot's size so that it is never cut off at the boundary.
// Throws InputError naming "request.inputs[i]" / "request.merged" if a waypoint does not fit the
// space, and "request.width_px" / "request.footprints" for out-of-range values.
std::string RenderSvg(const Scene& scene, const RenderRequest& request);

}  // namespace hgraph
