// OMPL inputs the CLI reads: an OMPL.app .cfg problem (written to a scratch folder, so its mesh
// names resolve to files that do not exist there), the state printout of .path files, and the
// matrix text format, the last two against a fixed SE(2) and R^2 space. The first byte picks
// the reader.
#include <unistd.h>

#include <fstream>

#include "core/adapter/ompl_cfg.h"
#include "core/adapter/path_io.h"
#include "tests/fuzz/fuzz_common.h"

namespace {

const std::string& ScratchDir() {
  static const std::string dir = [] {
    char name[] = "/tmp/hgraph-fuzz-XXXXXX";
    const char* made = mkdtemp(name);
    return std::string(made ? made : "/tmp");
  }();
  return dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace hgraph;
  if (size < 1) return 0;
  const std::string text(reinterpret_cast<const char*>(data) + 1, size - 1);
  static const Space se2({ComponentSpec{.type = ComponentType::kSE2,
                                        .lower = Eigen::Vector2d(-10, -10),
                                        .upper = Eigen::Vector2d(10, 10)}});
  static const Space r2 = Space::RealVector(Eigen::Vector2d(0, 0), Eigen::Vector2d(80, 80));
  fuzz::Run([&] {
    switch (data[0] % 3) {
      case 0: {
        const std::string path = ScratchDir() + "/problem.cfg";
        std::ofstream(path, std::ios::binary) << text;
        ReadOmplAppProblem(path);
        break;
      }
      case 1:
        if (LooksLikeOmplStatePrint(text)) ParseOmplStatePrint(text, "fuzz.path", se2);
        break;
      default: ParsePathsText(text, "fuzz.txt", r2); break;
    }
  });
  return 0;
}
