#include "client/cli/merge_picture.h"

namespace hgraph::cli {

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

}  // namespace hgraph::cli
