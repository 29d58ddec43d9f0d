// The 3D view: one self-contained HTML file with three.js inlined (core/render/view/), showing
// the scene's obstacles and robot in 3D, the input paths each in its own colour, the merged path
// thick and coloured by where each stretch came from, the robot animated along a path, a legend
// with every path's length and clearance, and a chart of the post-optimization's progress. The
// file needs no server and no network: it opens from file://.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/render/svg_render.h"
#include "core/scene/scene.h"

namespace hgraph {

// One reported objective of the post-optimization (a progress event of phase "optimize").
struct OptimizeRound {
  int64_t round = 0;  // 0: the H-Graph optimum
  double elapsed_ms = 0;
  double objective = 0;
};

// What the view shows. Plain struct; copyable.
struct ViewRequest {
  std::vector<RenderPath> inputs;
  std::optional<RenderPath> merged;
  // One per waypoint of `merged`, or empty when the result does not say (all stretches are then
  // drawn in one colour, "source not reported").
  std::vector<WaypointSource> sources;
  // The number of waypoints of each of the merge's inputs (MergeResult.inputs[i].waypoints), in
  // the order source paths count them; lets a stretch that leaves the shared start or reaches the
  // shared goal count as the input it runs along, whichever input the endpoint is reported from.
  std::vector<int> input_waypoints;
  // Names in the legend's measure line; empty: no measure line.
  std::string measure;
  std::optional<double> objective;
  std::optional<double> best_input_objective;
  std::vector<OptimizeRound> rounds;
  std::string title;  // empty = the scene's name
  // A mesh with more triangles than this is refused rather than written into a file that a
  // browser would struggle to open.
  int64_t max_mesh_triangles = 1'000'000;
  // Robot poses sampled along each path for the animation, evenly spaced in the space's metric.
  int frames = 400;
};

// The HTML document. Throws InputError naming "request.inputs[i]" / "request.merged" if a
// waypoint does not fit the space, "request.sources" if it does not match the merged path,
// "request.frames" / "request.max_mesh_triangles" out of range, and the obstacle or body
// ("scene.obstacles[i]", "scene.robot[i]", with the mesh's source) whose mesh is above
// max_mesh_triangles.
std::string RenderViewHtml(const Scene& scene, const ViewRequest& request);

// The source of each stretch (waypoint i to i + 1) of a merged path: the input index when both
// ends lie on one edge of that input, kShortcutStretch when either end is a shortcut's
// (source path -1), kBridgeStretch when they lie on different inputs or on distant parts of one.
// Inputs share their start and goal, so an end at an input's first waypoint (or, with
// `input_waypoints`, its last) lies on every input.
inline constexpr int kShortcutStretch = -1;
inline constexpr int kBridgeStretch = -2;
std::vector<int> StretchSources(const std::vector<WaypointSource>& sources,
                                const std::vector<int>& input_waypoints = {});

}  // namespace hgraph
