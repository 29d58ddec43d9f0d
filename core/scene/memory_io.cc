#include "core/scene/memory_io.h"

#include <algorithm>
#include <cstring>

namespace hgraph {
namespace {

// Read-only view of bytes held elsewhere.
class MemoryStream final : public Assimp::IOStream {
 public:
  explicit MemoryStream(const std::string& bytes) : bytes_(bytes) {}

  size_t Read(void* buffer, size_t size, size_t count) override {
    if (size == 0 || count == 0) return 0;
    const size_t left = bytes_.size() - position_;
    const size_t items = std::min(count, left / size);
    std::memcpy(buffer, bytes_.data() + position_, items * size);
    position_ += items * size;
    return items;
  }
  size_t Write(const void*, size_t, size_t) override { return 0; }
  aiReturn Seek(size_t offset, aiOrigin origin) override {
    size_t target = 0;
    switch (origin) {
      case aiOrigin_SET: target = offset; break;
      case aiOrigin_CUR: target = position_ + offset; break;
      case aiOrigin_END: target = bytes_.size() - offset; break;
      default: return aiReturn_FAILURE;
    }
    // Offsets are unsigned; a "negative" one wraps and lands past the end.
    if (target > bytes_.size()) return aiReturn_FAILURE;
    position_ = target;
    return aiReturn_SUCCESS;
  }
  size_t Tell() const override { return position_; }
  size_t FileSize() const override { return bytes_.size(); }
  void Flush() override {}

 private:
  const std::string& bytes_;
  size_t position_ = 0;
};

// Importers join the model's folder and a referenced name ("./mesh.obj", "/x/../mesh.mtl");
// only a bare name, optionally behind "./", can match a served file.
std::string BareName(const char* name) {
  std::string s = name == nullptr ? "" : name;
  while (s.starts_with("./")) s.erase(0, 2);
  return s;
}

}  // namespace

MemoryIOSystem::MemoryIOSystem(std::map<std::string, const std::string*> files)
    : files_(std::move(files)) {}

const std::string* MemoryIOSystem::Find(const char* name) const {
  const auto it = files_.find(BareName(name));
  if (it == files_.end()) {
    ++refused_;
    return nullptr;
  }
  return it->second;
}

bool MemoryIOSystem::Exists(const char* name) const { return Find(name) != nullptr; }

Assimp::IOStream* MemoryIOSystem::Open(const char* name, const char* mode) {
  // Writing is never needed to import; refuse it like an unknown name.
  if (mode != nullptr && (std::strchr(mode, 'w') != nullptr || std::strchr(mode, 'a') != nullptr ||
                          std::strchr(mode, '+') != nullptr)) {
    ++refused_;
    return nullptr;
  }
  const std::string* bytes = Find(name);
  return bytes == nullptr ? nullptr : new MemoryStream(*bytes);
}

void MemoryIOSystem::Close(Assimp::IOStream* stream) { delete stream; }

bool MemoryIOSystem::ComparePaths(const char* one, const char* second) const {
  return BareName(one) == BareName(second);
}

}  // namespace hgraph
