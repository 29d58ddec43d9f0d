// hgraph-mesh-import: parses one mesh for hgraph-server in a process of its own. Reads a request
// (core/scene/mesh_wire.h) on stdin, writes the triangles or a refusal on stdout, exits 0 (or 3
// if it ran out of memory). It limits itself before reading a byte: address space and CPU as
// given, no core dumps, no file writes, and no new file descriptors (assimp reads only the bytes
// handed to it, through a MemoryIOSystem). The parent sets the same limits and a deadline.
#include <sys/resource.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <new>
#include <string>

#include "core/common/error.h"
#include "core/scene/mesh_loader.h"
#include "core/scene/mesh_wire.h"

namespace {

// stdin, stdout, stderr: nothing else can be opened. Sanitizer builds (scripts/sanitize.sh) leave
// their runtime a few descriptors: UBSan's vptr check probes memory through a pipe and
// LeakSanitizer reads /proc/self/maps at exit; without them each such check fails with a false
// report.
#ifdef HGRAPH_SANITIZER_BUILD
constexpr rlim_t kDescriptors = 8;
#else
constexpr rlim_t kDescriptors = 3;
#endif

void Limit(int resource, rlim_t value) {
  const rlimit limit{.rlim_cur = value, .rlim_max = value};
  setrlimit(static_cast<__rlimit_resource>(resource), &limit);
}

bool WriteAll(const std::string& bytes) {
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = write(1, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    done += static_cast<size_t>(n);
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  long memory_mb = 1024;
  long cpu_s = 20;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (std::strcmp(argv[i], "--memory-mb") == 0) memory_mb = std::strtol(argv[i + 1], nullptr, 10);
    if (std::strcmp(argv[i], "--cpu-s") == 0) cpu_s = std::strtol(argv[i + 1], nullptr, 10);
  }
  // 0: no address-space limit (sanitizer builds reserve terabytes of it).
  if (memory_mb != 0) Limit(RLIMIT_AS, static_cast<rlim_t>(memory_mb > 0 ? memory_mb : 1024) << 20);
  Limit(RLIMIT_CPU, static_cast<rlim_t>(cpu_s > 0 ? cpu_s : 20));
  Limit(RLIMIT_CORE, 0);
  Limit(RLIMIT_FSIZE, 0);
  Limit(RLIMIT_NOFILE, kDescriptors);

  try {
    std::string input;
    char buffer[1 << 16];
    for (;;) {
      const ssize_t n = read(0, buffer, sizeof buffer);
      if (n < 0 && errno == EINTR) continue;
      if (n < 0) return 2;
      if (n == 0) break;
      input.append(buffer, static_cast<size_t>(n));
    }
    const hgraph::MeshImportRequest request = hgraph::DecodeMeshRequest(input);
    input = std::string();
    std::string reply;
    try {
      reply = hgraph::EncodeMeshReply(
          *hgraph::LoadMeshBytes(request.bytes, request.format, request.options, "mesh"));
    } catch (const hgraph::Error& e) {
      // The parent names its own field; drop the placeholder.
      std::string message = e.what();
      if (message.starts_with("mesh: ")) message.erase(0, 6);
      reply = hgraph::EncodeMeshRefusal(message);
    }
    return WriteAll(reply) ? 0 : 2;
  } catch (const std::bad_alloc&) {
    return 3;
  } catch (const std::exception& e) {
    WriteAll(hgraph::EncodeMeshRefusal(std::string("importer failed: ") + e.what()));
    return 0;
  }
}
