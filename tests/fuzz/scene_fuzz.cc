// Proto JSON scenes as the service reads them: parsed, mesh paths refused (the server never
// opens a client's file names), inline meshes through the out-of-process importer, built and
// validated.
#include "core/adapter/json_io.h"
#include "core/adapter/scene_proto.h"
#include "core/collision/collision_world.h"
#include "tests/fuzz/fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace hgraph;
  const std::string text(reinterpret_cast<const char*>(data), size);
  fuzz::Run([&] {
    v1::Scene proto;
    ParseJson(text, "fuzz.json", &proto);
    for (const v1::Obstacle& o : proto.obstacles()) {
      if (o.shape().mesh().source_case() == v1::MeshRef::kPath) return;
    }
    for (const v1::RobotBody& b : proto.robot()) {
      if (b.shape().mesh().source_case() == v1::MeshRef::kPath) return;
    }
    const MeshBytesLoader load = [](const std::string& bytes, const std::string& format,
                                    const MeshLoadOptions& options, const std::string& field) {
      return fuzz::Importer().Import(bytes, format, options, field, CancelToken());
    };
    const auto scene = SceneFromProto(proto, "", BlobResolver(), load);
    CollisionWorld world(scene);
  });
  return 0;
}
