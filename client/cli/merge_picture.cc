#include "client/cli/merge_picture.h"

#include <map>

#include "client/cli/cli_common.h"
#include "core/adapter/json_io.h"
#include "core/adapter/merge_proto.h"
#include "core/adapter/path_io.h"
#include "core/common/client_text.h"
#include "core/common/error.h"

namespace hgraph::cli {
namespace {

// ValidatePath, with the file in the field and the scene's dimension in the message: a path of
// the wrong dimension is most often a file of another scene.
void ValidateInScene(const Scene& scene, const std::string& scene_file, const InputPath& path,
                     const std::string& field) {
  try {
    ValidatePath(scene.space, path, field);
  } catch (const InputError& e) {
    const std::string what = e.what();
    const std::string message = e.field().empty() ? what : what.substr(e.field().size() + 2);
    throw InputError(e.field(), message + " (the space of " + scene_file + ")");
  }
}

}  // namespace

RenderRequest MergePicture(const std::vector<InputPath>& inputs, const MergeResult& result) {
  RenderRequest picture;
  for (size_t i = 0; i < inputs.size(); ++i) {
    RenderPath path{.path = inputs[i]};
    if (i < result.inputs.size()) path.quality = result.inputs[i].quality;
    picture.inputs.push_back(std::move(path));
  }
  picture.merged = RenderPath{.path = result.path, .quality = result.quality};
  if (picture.merged->path.name.empty()) picture.merged->path.name = "merged";
  return picture;
}

PicturePaths LoadPicturePaths(const std::string& scene_file, v1::Scene scene_proto,
                              const std::shared_ptr<const Scene>& scene,
                              const std::string& paths_file, const std::string& result_file,
                              PathChecker checker) {
  PicturePaths out;
  if (!paths_file.empty()) {
    std::vector<InputPath> paths = LoadPathsFile(paths_file, scene->space);
    for (size_t i = 0; i < paths.size(); ++i) {
      ValidateInScene(*scene, scene_file, paths[i],
                      paths_file + ": paths[" + std::to_string(i) + "]");
      out.inputs.push_back(RenderPath{.path = std::move(paths[i])});
    }
  }
  std::vector<bool> reported(out.inputs.size(), false);
  if (!result_file.empty()) {
    v1::MergeResult& result = out.result.emplace();
    ReadJsonFile(result_file, &result);
    v1::PathSet merged;
    *merged.add_paths() = result.path();
    // A --best-so-far result has its path and objective only: the legend then measures the path.
    RenderPath path{.path = PathsFromProto(merged).front()};
    if (result.has_quality()) path.quality = QualityFromProto(result.quality());
    path.path.name = "merged";
    ValidateInScene(*scene, scene_file, path.path, result_file + ": path");
    for (size_t i = 0; i < path.path.waypoints.size(); ++i) {
      if (!scene->space.InBounds(path.path.waypoints[i])) {
        throw InputError(result_file + ": path.waypoints[" + std::to_string(i) + "]",
                         "lies outside the bounds of the space of " + scene_file +
                             ", which a merged path never leaves: a result of another scene?");
      }
    }
    const int n = result.path().waypoints_size();
    for (const auto& [field, size] : {std::pair{"source_path", result.source_path_size()},
                                      std::pair{"source_index", result.source_index_size()}}) {
      if (size != 0 && size != n) {
        throw InputError(result_file + ": " + field, "has " + std::to_string(size) +
                                                         " entries for a path of " +
                                                         std::to_string(n) + " waypoints");
      }
    }
    out.merged = std::move(path);
    std::map<std::string, const v1::InputReport*> reports;
    for (const v1::InputReport& report : result.inputs()) reports[report.name()] = &report;
    for (size_t i = 0; i < out.inputs.size(); ++i) {
      RenderPath& input = out.inputs[i];
      const auto it = reports.find(input.path.name);
      if (it == reports.end()) continue;
      reported[i] = true;
      if (it->second->valid()) {
        input.quality = QualityFromProto(it->second->quality());
      } else {
        input.path.name += " (invalid)";
      }
    }
  }
  if (out.inputs.empty() && !out.merged) {
    throw InputError("--paths", "nothing to draw: give --paths, --result or both");
  }

  std::vector<InputPath> unreported;
  std::vector<size_t> where;
  for (size_t i = 0; i < out.inputs.size(); ++i) {
    if (reported[i]) continue;
    unreported.push_back(out.inputs[i].path);
    where.push_back(i);
  }
  if (!unreported.empty()) {
    if (!checker) checker = LocalPathChecker(std::move(scene_proto), scene_file, scene);
    const CheckRun run = checker(unreported, CheckSettings{});
    for (size_t j = 0; j < where.size(); ++j) {
      RenderPath& input = out.inputs[where[j]];
      const InputReport& report = run.result.paths.at(j);
      if (report.valid) {
        input.quality = report.quality;
      } else {
        input.path.name += " (invalid)";
      }
    }
  }
  return out;
}

}  // namespace hgraph::cli
