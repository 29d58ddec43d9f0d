// The picture of a merge (--svg): the inputs with their reported quality, and the merged path.
// Drawn in process, also after a merge through the service (--server): the CLI holds the scene.
#pragma once

#include <vector>

#include "core/merge/merge.h"
#include "core/render/svg_render.h"

namespace hgraph::cli {

RenderRequest MergePicture(const std::vector<InputPath>& inputs, const MergeResult& result);

}  // namespace hgraph::cli
