// One LRU cache over every large object the server keeps for later calls: uploaded blobs, scene
// messages, loaded collision worlds and H-Graphs, under one byte budget (--cache-bytes).
//
// Values are immutable or internally synchronised objects held by shared_ptr, so that evicting
// an entry never frees an object a running call still uses: the call keeps its reference and
// the memory goes when the call ends. A later lookup of an evicted key finds nothing and the
// service answers NOT_FOUND (the client re-uploads), never a crash.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <list>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

namespace hgraph::server {

// What a key holds; part of the key and a metrics label.
enum class CacheKind { kBlob, kScene, kWorld, kHGraph };
const char* CacheKindName(CacheKind kind);

// Thread safe. Not copyable or movable.
class ResourceCache {
 public:
  // Called (outside the cache's lock) with the kind and key of every evicted entry.
  using EvictionListener = std::function<void(CacheKind, const std::string& key)>;

  explicit ResourceCache(size_t budget_bytes);
  ResourceCache(const ResourceCache&) = delete;
  ResourceCache& operator=(const ResourceCache&) = delete;

  void SetEvictionListener(EvictionListener listener);

  // The value, marked most recently used, or nullptr.
  template <class T>
  std::shared_ptr<T> Get(CacheKind kind, const std::string& key) {
    // Values go in as shared_ptr<const void>; T is what the caller stored under this kind.
    return std::const_pointer_cast<T>(std::static_pointer_cast<const T>(GetErased(kind, key)));
  }
  bool Contains(CacheKind kind, const std::string& key) const;

  // Inserts or replaces the entry, then evicts least recently used entries (never this one)
  // until the total is within the budget. Returns false, storing nothing, if `bytes` alone
  // exceeds the budget.
  bool Put(CacheKind kind, const std::string& key, std::shared_ptr<const void> value, size_t bytes);
  // Counts an entry whose value grew or shrank (an H-Graph a query added to) at `bytes`, marks it
  // most recently used and evicts others until the total fits; an entry now over the whole budget
  // is evicted itself (the listener is told). Returns whether the entry is still held (false
  // also when it was not: evicted meanwhile).
  bool Resize(CacheKind kind, const std::string& key, size_t bytes);
  void Erase(CacheKind kind, const std::string& key);

  // Bytes held outside the cache that count against its budget (unfinished uploads): reserving
  // evicts least recently used entries to make room. Returns false, reserving nothing, if the
  // reservations would exceed the budget by themselves.
  bool Reserve(size_t bytes);
  void Unreserve(size_t bytes);
  size_t reserved_bytes() const;

  size_t bytes() const;
  size_t bytes(CacheKind kind) const;
  // The bytes the entry counts for (0 when absent).
  size_t BytesOf(CacheKind kind, const std::string& key) const;
  size_t budget_bytes() const { return budget_bytes_; }
  int64_t evictions(CacheKind kind) const;

 private:
  struct Entry {
    CacheKind kind;
    std::string key;  // kind-qualified
    std::shared_ptr<const void> value;
    size_t bytes = 0;
  };
  static std::string FullKey(CacheKind kind, const std::string& key);
  // Evicts from the back until entries and reservations fit the budget, keeping at least `keep`
  // entries; the caller holds mutex_ and calls the listener for `evicted` after releasing it.
  void EvictToFit(size_t keep, std::vector<std::pair<CacheKind, std::string>>* evicted,
                  std::vector<std::shared_ptr<const void>>* dropped);
  std::shared_ptr<const void> GetErased(CacheKind kind, const std::string& key);

  const size_t budget_bytes_;
  mutable std::mutex mutex_;
  std::list<Entry> lru_;  // front = most recently used
  std::unordered_map<std::string, std::list<Entry>::iterator> index_;
  size_t bytes_ = 0;
  size_t reserved_ = 0;
  size_t kind_bytes_[4] = {0, 0, 0, 0};
  int64_t evictions_[4] = {0, 0, 0, 0};
  EvictionListener listener_;
};

}  // namespace hgraph::server
