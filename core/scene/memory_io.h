// An assimp IOSystem that serves files from memory only: the mesh's own bytes under one name, and
// optionally companion files handed over by name. Every other name is refused the same way
// (Exists false, Open null) without touching the file system, so a file name written inside a
// mesh (an OBJ mtllib, a glTF buffer uri, a COLLADA image) is never opened and a client cannot
// learn whether a path exists. Not copyable; owned by the Importer it is given to.
#pragma once

#include <assimp/IOStream.hpp>
#include <assimp/IOSystem.hpp>
#include <map>
#include <memory>
#include <string>

namespace hgraph {

class MemoryIOSystem final : public Assimp::IOSystem {
 public:
  // `files` maps a bare name ("mesh.obj") to its bytes; the bytes must outlive the system.
  explicit MemoryIOSystem(std::map<std::string, const std::string*> files);
  MemoryIOSystem(const MemoryIOSystem&) = delete;
  MemoryIOSystem& operator=(const MemoryIOSystem&) = delete;

  bool Exists(const char* name) const override;
  char getOsSeparator() const override { return '/'; }
  Assimp::IOStream* Open(const char* name, const char* mode) override;
  void Close(Assimp::IOStream* stream) override;
  bool ComparePaths(const char* one, const char* second) const override;

  // How many times a name outside `files` was asked for (for tests and diagnostics).
  int refused() const { return refused_; }

 private:
  const std::string* Find(const char* name) const;

  std::map<std::string, const std::string*> files_;
  mutable int refused_ = 0;
};

}  // namespace hgraph
