#include "server/resource_cache.h"

#include <algorithm>
#include <utility>
#include <vector>

namespace hgraph::server {

const char* CacheKindName(CacheKind kind) {
  switch (kind) {
    case CacheKind::kBlob: return "blob";
    case CacheKind::kScene: return "scene";
    case CacheKind::kWorld: return "world";
    case CacheKind::kHGraph: return "hgraph";
  }
  return "unknown";
}

ResourceCache::ResourceCache(size_t budget_bytes) : budget_bytes_(budget_bytes) {}

void ResourceCache::SetEvictionListener(EvictionListener listener) {
  std::lock_guard lock(mutex_);
  listener_ = std::move(listener);
}

std::string ResourceCache::FullKey(CacheKind kind, const std::string& key) {
  return std::string(CacheKindName(kind)) + ":" + key;
}

std::shared_ptr<const void> ResourceCache::GetErased(CacheKind kind, const std::string& key) {
  std::lock_guard lock(mutex_);
  auto it = index_.find(FullKey(kind, key));
  if (it == index_.end()) return nullptr;
  lru_.splice(lru_.begin(), lru_, it->second);
  return it->second->value;
}

bool ResourceCache::Contains(CacheKind kind, const std::string& key) const {
  std::lock_guard lock(mutex_);
  return index_.count(FullKey(kind, key)) != 0;
}

bool ResourceCache::Put(CacheKind kind, const std::string& key, std::shared_ptr<const void> value,
                        size_t bytes) {
  if (bytes > budget_bytes_) return false;
  std::vector<std::pair<CacheKind, std::string>> evicted;
  // Values leave the lock before they are destroyed: destroying an H-Graph can take a while.
  std::vector<std::shared_ptr<const void>> dropped;
  EvictionListener listener;
  {
    std::lock_guard lock(mutex_);
    const std::string full = FullKey(kind, key);
    if (auto it = index_.find(full); it != index_.end()) {
      bytes_ -= it->second->bytes;
      kind_bytes_[static_cast<int>(it->second->kind)] -= it->second->bytes;
      dropped.push_back(std::move(it->second->value));
      lru_.erase(it->second);
      index_.erase(it);
    }
    lru_.push_front(Entry{kind, full, std::move(value), bytes});
    index_[full] = lru_.begin();
    bytes_ += bytes;
    kind_bytes_[static_cast<int>(kind)] += bytes;
    EvictToFit(1, &evicted, &dropped);
    listener = listener_;
  }
  if (listener) {
    for (const auto& [victim_kind, victim_key] : evicted) listener(victim_kind, victim_key);
  }
  return true;
}

void ResourceCache::EvictToFit(size_t keep, std::vector<std::pair<CacheKind, std::string>>* evicted,
                               std::vector<std::shared_ptr<const void>>* dropped) {
  while (bytes_ + reserved_ > budget_bytes_ && lru_.size() > keep) {
    Entry& victim = lru_.back();
    bytes_ -= victim.bytes;
    kind_bytes_[static_cast<int>(victim.kind)] -= victim.bytes;
    ++evictions_[static_cast<int>(victim.kind)];
    evicted->emplace_back(victim.kind, victim.key.substr(victim.key.find(':') + 1));
    dropped->push_back(std::move(victim.value));
    index_.erase(victim.key);
    lru_.pop_back();
  }
}

bool ResourceCache::Resize(CacheKind kind, const std::string& key, size_t bytes) {
  std::vector<std::pair<CacheKind, std::string>> evicted;
  std::vector<std::shared_ptr<const void>> dropped;
  EvictionListener listener;
  bool held = false;
  {
    std::lock_guard lock(mutex_);
    const auto it = index_.find(FullKey(kind, key));
    if (it == index_.end()) return false;
    const int k = static_cast<int>(kind);
    bytes_ -= it->second->bytes;
    kind_bytes_[k] -= it->second->bytes;
    if (bytes > budget_bytes_) {
      ++evictions_[k];
      evicted.emplace_back(kind, key);
      dropped.push_back(std::move(it->second->value));
      lru_.erase(it->second);
      index_.erase(it);
    } else {
      it->second->bytes = bytes;
      bytes_ += bytes;
      kind_bytes_[k] += bytes;
      lru_.splice(lru_.begin(), lru_, it->second);
      EvictToFit(1, &evicted, &dropped);
      held = true;
    }
    listener = listener_;
  }
  if (listener) {
    for (const auto& [victim_kind, victim_key] : evicted) listener(victim_kind, victim_key);
  }
  return held;
}

bool ResourceCache::Reserve(size_t bytes) {
  std::vector<std::pair<CacheKind, std::string>> evicted;
  std::vector<std::shared_ptr<const void>> dropped;
  EvictionListener listener;
  {
    std::lock_guard lock(mutex_);
    if (bytes > budget_bytes_ - reserved_) return false;
    reserved_ += bytes;
    EvictToFit(0, &evicted, &dropped);
    listener = listener_;
  }
  if (listener) {
    for (const auto& [kind, key] : evicted) listener(kind, key);
  }
  return true;
}

void ResourceCache::Unreserve(size_t bytes) {
  std::lock_guard lock(mutex_);
  reserved_ -= std::min(bytes, reserved_);
}

size_t ResourceCache::reserved_bytes() const {
  std::lock_guard lock(mutex_);
  return reserved_;
}

void ResourceCache::Erase(CacheKind kind, const std::string& key) {
  std::shared_ptr<const void> dropped;
  std::lock_guard lock(mutex_);
  auto it = index_.find(FullKey(kind, key));
  if (it == index_.end()) return;
  bytes_ -= it->second->bytes;
  kind_bytes_[static_cast<int>(kind)] -= it->second->bytes;
  dropped = std::move(it->second->value);
  lru_.erase(it->second);
  index_.erase(it);
}

size_t ResourceCache::bytes() const {
  std::lock_guard lock(mutex_);
  return bytes_;
}

size_t ResourceCache::BytesOf(CacheKind kind, const std::string& key) const {
  std::lock_guard lock(mutex_);
  auto it = index_.find(FullKey(kind, key));
  return it == index_.end() ? 0 : it->second->bytes;
}

size_t ResourceCache::bytes(CacheKind kind) const {
  std::lock_guard lock(mutex_);
  return kind_bytes_[static_cast<int>(kind)];
}

int64_t ResourceCache::evictions(CacheKind kind) const {
  std::lock_guard lock(mutex_);
  return evictions_[static_cast<int>(kind)];
}

}  // namespace hgraph::server
