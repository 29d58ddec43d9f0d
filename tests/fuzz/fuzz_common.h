// Shared by the fuzz targets: each defines LLVMFuzzerTestOneInput. Under HGRAPH_FUZZ (clang) they
// link libFuzzer; otherwise replay_main.cc runs them over files (the regression inputs under
// tests/fuzz/regressions/), so that every compiler replays what a fuzzer once found.
//
// An hgraph::Error is the expected answer to bad input and is swallowed; anything else
// (InternalError, a crash, a sanitizer report) escapes and is a finding.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "core/common/error.h"
#include "server/mesh_importer.h"

namespace hgraph::fuzz {

// The importer the server would use, with the helper built beside the fuzz targets. No memory
// limit: sanitizer builds reserve terabytes of address space (the other limits still hold).
inline const server::MeshImporter& Importer() {
  static const server::MeshImporter importer(server::MeshImportLimits{
      .helper_path = std::string(HGRAPH_BINARY_DIR) + "/hgraph-mesh-import",
      .memory_mb = 0,
      .cpu_s = 10,
      .timeout = std::chrono::milliseconds(10000)});
  return importer;
}

template <typename Body>
void Run(Body&& body) {
  try {
    body();
  } catch (const Error&) {
  }
}

}  // namespace hgraph::fuzz
