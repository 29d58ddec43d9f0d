// Reading a whole file named by a flag or a field (certificates, keys), with the error naming
// that flag.
#pragma once

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>

#include "core/common/error.h"

namespace hgraph {

// The file's bytes; Error(kNotFound, field) naming the path and the reason when it cannot be read.
inline std::string ReadFileBytes(const std::string& path, const std::string& field) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    throw Error(ErrorCode::kNotFound, field, "cannot read " + path + ": " + std::strerror(errno));
  }
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

}  // namespace hgraph
