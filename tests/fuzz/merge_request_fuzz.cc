// MergePathsRequest bytes as the service receives them: decoded, converted by the adapter and
// merged on a small fixed scene (2-D, one box, a disc robot), one thread. Large batches are cut
// off first, as the server's --max-paths/--max-waypoints do.
#include "core/adapter/json_io.h"
#include "core/adapter/merge_proto.h"
#include "core/adapter/path_io.h"
#include "core/adapter/scene_proto.h"
#include "core/collision/collision_world.h"
#include "core/merge/merge.h"
#include "core/motion/local_planner.h"
#include "hgraph/v1/service.pb.h"
#include "tests/fuzz/fuzz_common.h"

namespace {

constexpr char kScene[] = R"({
  "space": {"components": [{"type": "TYPE_RN", "dimension": 2, "lower": [0, 0], "upper": [10, 10]}]},
  "obstacles": [{"shape": {"box": {"size": [2, 2, 1]}}, "pose": {"position": [5, 5, 0]}}],
  "robot": [{"shape": {"sphere": {"radius": 0.2}}, "component": 0}]
})";

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace hgraph;
  static const v1::Scene scene_proto = [] {
    v1::Scene proto;
    ParseJson(kScene, "scene", &proto);
    return proto;
  }();
  static const auto world =
      std::make_shared<const CollisionWorld>(SceneFromProto(scene_proto, "", BlobResolver()));
  v1::MergePathsRequest request;
  if (!request.ParseFromArray(data, static_cast<int>(size))) return 0;
  if (request.paths().paths_size() > 8) return 0;
  for (const v1::Path& p : request.paths().paths()) {
    if (p.waypoints_size() > 32) return 0;
  }
  fuzz::Run([&] {
    MergeRequest merge{.paths = PathsFromProto(request.paths()),
                       .measure = MeasureFromProto(request.measure()),
                       .options = MergeOptionsFromProto(request.options())};
    merge.options.threads = 1;
    const double resolution = ResolutionFromProto(request.options(), scene_proto);
    const LocalPlanner planner(world, LocalPlannerOptions{.resolution = resolution});
    HybridizationSession session(planner, merge);
    session.Query(merge.measure);
  });
  return 0;
}
