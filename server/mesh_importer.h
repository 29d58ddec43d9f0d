// Parses untrusted mesh bytes in a child process (hgraph-mesh-import), one per import: the
// child gets the bytes on stdin, an empty environment, no other open file descriptor, an
// address-space limit (RLIMIT_AS), a CPU limit (RLIMIT_CPU) and a wall-clock deadline after
// which it is killed. Whatever it does (crash, hang, exhaust memory, write garbage) becomes an
// InputError naming the mesh field; the server process is never at risk. Thread safe; copyable.
#pragma once

#include <chrono>
#include <memory>
#include <string>

#include "core/common/progress.h"
#include "core/scene/mesh_loader.h"
#include "core/scene/scene.h"

namespace hgraph::server {

struct MeshImportLimits {
  std::string helper_path;   // the hgraph-mesh-import executable
  int64_t memory_mb = 1024;  // 0 = no address-space limit (sanitizer and fuzz builds only)
  int cpu_s = 20;
  std::chrono::milliseconds timeout{30000};  // per import, shortened by the call's deadline
};

// The helper next to the running executable (/proc/self/exe's folder).
std::string DefaultMeshImportHelper();

class MeshImporter {
 public:
  explicit MeshImporter(MeshImportLimits limits);

  // Throws Error(kFailedPrecondition) unless the helper is an executable file (checked at start
  // so that a misconfigured server fails at once, not on its first mesh).
  void CheckHelper() const;

  // Imports `bytes` (format = extension without the dot). Stops at `token`'s deadline or
  // cancellation, or at limits.timeout, whichever comes first.
  std::shared_ptr<const Mesh> Import(const std::string& bytes, const std::string& format,
                                     const MeshLoadOptions& options, const std::string& field,
                                     const CancelToken& token) const;

  const MeshImportLimits& limits() const { return limits_; }

 private:
  MeshImportLimits limits_;
};

}  // namespace hgraph::server
