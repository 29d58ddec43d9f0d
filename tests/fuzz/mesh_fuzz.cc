// Mesh bytes through the out-of-process importer and the server's checks of its reply: the
// first byte picks the format hint, the rest is the file. Whatever assimp does in the child,
// this process must get a mesh or an InputError.
#include "tests/fuzz/fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace hgraph;
  static const char* const kFormats[] = {"off", "ply", "obj", "stl", "dae", "gltf", "glb", "zae"};
  if (size < 2) return 0;
  const std::string format = kFormats[data[0] % 8];
  const std::string bytes(reinterpret_cast<const char*>(data) + 1, size - 1);
  fuzz::Run([&] {
    const auto mesh = fuzz::Importer().Import(bytes, format, {}, "mesh", CancelToken());
    for (const Eigen::Vector3i& t : mesh->triangles) {
      for (int k = 0; k < 3; ++k) {
        HGRAPH_CHECK(t[k] >= 0 && t[k] < static_cast<int>(mesh->vertices.size()));
      }
    }
  });
  return 0;
}
