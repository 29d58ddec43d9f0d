// The pictures of a merge: the SVG of `merge --svg`, and the paths that `render` and `view`
// draw. Drawn in process, also after a merge through the service (--server): the CLI holds the
// scene.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "client/cli/command.h"
#include "core/merge/merge.h"
#include "core/render/svg_render.h"
#include "core/scene/scene.h"
#include "hgraph/v1/merge.pb.h"
#include "hgraph/v1/scene.pb.h"

namespace hgraph::cli {

RenderRequest MergePicture(const std::vector<InputPath>& inputs, const MergeResult& result);

// What `render` and `view` draw: the paths of --paths and the merged path of --result, each
// with its length and clearance, taken from the result where it reports the input (matched by
// name: a paths file in another order, or a subset, still gets the right numbers) and otherwise
// from checking it as a merge checks its inputs.
struct PicturePaths {
  std::vector<RenderPath> inputs;    // an invalid one has " (invalid)" after its name
  std::optional<RenderPath> merged;  // named "merged"
  std::optional<v1::MergeResult> result;
};

// Reads and checks the files against the scene: every waypoint must fit the scene's space (and
// the merged path its bounds, which every merged path keeps), else an InputError names the file
// and the field ("result.json: path.waypoints[3]"). `checker` checks the unreported inputs (in
// process when empty, on `scene_proto` read from `scene_file`). Throws InputError("--paths")
// when both files are empty.
PicturePaths LoadPicturePaths(const std::string& scene_file, v1::Scene scene_proto,
                              const std::shared_ptr<const Scene>& scene,
                              const std::string& paths_file, const std::string& result_file,
                              PathChecker checker);

}  // namespace hgraph::cli
