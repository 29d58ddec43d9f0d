// Reading a whole file: the one reader of the files named by flags (certificates, keys, token
// tables) and of the files the adapters read (scenes, paths, meshes sent by the CLI, OMPL.app
// problems). Each caller's error names what it must name; the reading is here.
#pragma once

#include <cerrno>
#include <cstring>
#include <fstream>
#include <optional>
#include <string>
#include <utility>

#include "core/common/error.h"

namespace hgraph {

// Why a file could not be read: the errno, and whether opening it failed or reading it did (a
// directory opens, and its read fails with EISDIR).
struct FileReadFailure {
  int error = 0;
  bool at_open = true;
};

// Reads the whole file at `path` into *bytes (left as it was on failure); returns the failure,
// or nullopt.
inline std::optional<FileReadFailure> TryReadFileBytes(const std::string& path,
                                                       std::string* bytes) {
  errno = 0;
  std::ifstream in(path, std::ios::binary);
  if (!in) return FileReadFailure{.error = errno, .at_open = true};
  std::string contents;
  char chunk[1 << 16];
  // The stream's own reads, not `<< rdbuf()`: only they leave a failed read(2) in in.bad().
  while (in.read(chunk, sizeof(chunk)) || in.gcount() > 0) {
    contents.append(chunk, static_cast<size_t>(in.gcount()));
  }
  if (in.bad()) return FileReadFailure{.error = errno, .at_open = false};
  *bytes = std::move(contents);
  return std::nullopt;
}

// The file's bytes; Error(kNotFound, field) naming the path and the reason when it cannot be
// read ("cannot read PATH: REASON").
inline std::string ReadFileBytes(const std::string& path, const std::string& field) {
  std::string bytes;
  if (const std::optional<FileReadFailure> failure = TryReadFileBytes(path, &bytes)) {
    throw Error(ErrorCode::kNotFound, field,
                "cannot read " + path + ": " + std::strerror(failure->error));
  }
  return bytes;
}

}  // namespace hgraph
