#include "server/resource_cache.h"

#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace hgraph::server {
namespace {

std::shared_ptr<const std::string> Value(const std::string& s) {
  return std::make_shared<const std::string>(s);
}

TEST(ResourceCache, KeysAreQualifiedByKind) {
  ResourceCache cache(100);
  ASSERT_TRUE(cache.Put(CacheKind::kBlob, "k", Value("blob"), 10));
  ASSERT_TRUE(cache.Put(CacheKind::kScene, "k", Value("scene"), 10));
  EXPECT_EQ(*cache.Get<const std::string>(CacheKind::kBlob, "k"), "blob");
  EXPECT_EQ(*cache.Get<const std::string>(CacheKind::kScene, "k"), "scene");
  EXPECT_EQ(cache.Get<const std::string>(CacheKind::kWorld, "k"), nullptr);
  EXPECT_EQ(cache.bytes(), 20u);
  EXPECT_EQ(cache.bytes(CacheKind::kBlob), 10u);
}

TEST(ResourceCache, EvictsLeastRecentlyUsedAndTellsTheListener) {
  ResourceCache cache(30);
  std::vector<std::pair<CacheKind, std::string>> evicted;
  cache.SetEvictionListener(
      [&](CacheKind kind, const std::string& key) { evicted.emplace_back(kind, key); });
  ASSERT_TRUE(cache.Put(CacheKind::kBlob, "a", Value("a"), 10));
  ASSERT_TRUE(cache.Put(CacheKind::kBlob, "b", Value("b"), 10));
  ASSERT_TRUE(cache.Put(CacheKind::kHGraph, "c", Value("c"), 10));
  // A lookup makes "a" the most recently used: "b" goes first.
  ASSERT_NE(cache.Get<const std::string>(CacheKind::kBlob, "a"), nullptr);
  ASSERT_TRUE(cache.Put(CacheKind::kBlob, "d", Value("d"), 10));
  ASSERT_EQ(evicted.size(), 1u);
  EXPECT_EQ(evicted[0].first, CacheKind::kBlob);
  EXPECT_EQ(evicted[0].second, "b");
  EXPECT_FALSE(cache.Contains(CacheKind::kBlob, "b"));
  EXPECT_TRUE(cache.Contains(CacheKind::kBlob, "a"));
  EXPECT_EQ(cache.evictions(CacheKind::kBlob), 1);
  EXPECT_EQ(cache.bytes(), 30u);
}

TEST(ResourceCache, AnEntryOverTheBudgetIsRefusedAndEvictsNothing) {
  ResourceCache cache(30);
  ASSERT_TRUE(cache.Put(CacheKind::kBlob, "a", Value("a"), 20));
  EXPECT_FALSE(cache.Put(CacheKind::kBlob, "big", Value("big"), 31));
  EXPECT_TRUE(cache.Contains(CacheKind::kBlob, "a"));
  EXPECT_FALSE(cache.Contains(CacheKind::kBlob, "big"));
  EXPECT_EQ(cache.bytes(), 20u);
}

TEST(ResourceCache, ReplacingAKeyCountsItsBytesOnce) {
  ResourceCache cache(100);
  ASSERT_TRUE(cache.Put(CacheKind::kWorld, "w", Value("1"), 40));
  ASSERT_TRUE(cache.Put(CacheKind::kWorld, "w", Value("2"), 25));
  EXPECT_EQ(cache.bytes(), 25u);
  EXPECT_EQ(*cache.Get<const std::string>(CacheKind::kWorld, "w"), "2");
  cache.Erase(CacheKind::kWorld, "w");
  EXPECT_EQ(cache.bytes(), 0u);
  EXPECT_EQ(cache.evictions(CacheKind::kWorld), 0);
}

// An entry that grew is counted at its new size, becomes the most recently used and makes the
// least recently used others go; one that outgrew the whole budget goes itself, and the listener
// hears of both; a key no longer held is not stored again.
TEST(ResourceCache, ResizeCountsAGrownEntryAndEvictsToFit) {
  ResourceCache cache(100);
  std::vector<std::string> told;
  cache.SetEvictionListener([&](CacheKind, const std::string& key) { told.push_back(key); });
  ASSERT_TRUE(cache.Put(CacheKind::kHGraph, "h", Value("h"), 20));
  ASSERT_TRUE(cache.Put(CacheKind::kBlob, "old", Value("old"), 30));
  ASSERT_TRUE(cache.Put(CacheKind::kBlob, "new", Value("new"), 30));
  EXPECT_TRUE(cache.Resize(CacheKind::kHGraph, "h", 40));
  EXPECT_EQ(cache.bytes(), 100u);
  EXPECT_EQ(cache.bytes(CacheKind::kHGraph), 40u);
  EXPECT_TRUE(told.empty());
  // "old" is now the least recently used ("h" moved up): growing "h" again evicts it.
  EXPECT_TRUE(cache.Resize(CacheKind::kHGraph, "h", 65));
  EXPECT_EQ(told, std::vector<std::string>{"old"});
  EXPECT_TRUE(cache.Contains(CacheKind::kBlob, "new"));
  EXPECT_EQ(cache.bytes(), 95u);
  EXPECT_FALSE(cache.Resize(CacheKind::kHGraph, "h", 101));
  EXPECT_FALSE(cache.Contains(CacheKind::kHGraph, "h"));
  EXPECT_EQ((std::vector<std::string>{"old", "h"}), told);
  EXPECT_EQ(cache.bytes(), 30u);
  EXPECT_EQ(cache.evictions(CacheKind::kHGraph), 1);
  EXPECT_FALSE(cache.Resize(CacheKind::kHGraph, "h", 10));
  EXPECT_FALSE(cache.Contains(CacheKind::kHGraph, "h"));
  EXPECT_EQ(cache.bytes(), 30u);
}

// A running call keeps what it looked up even after the entry is evicted.
TEST(ResourceCache, EvictionNeverFreesAValueInUse) {
  ResourceCache cache(10);
  ASSERT_TRUE(cache.Put(CacheKind::kScene, "s", Value("scene"), 10));
  const auto held = cache.Get<const std::string>(CacheKind::kScene, "s");
  ASSERT_TRUE(cache.Put(CacheKind::kScene, "t", Value("other"), 10));
  EXPECT_FALSE(cache.Contains(CacheKind::kScene, "s"));
  EXPECT_EQ(*held, "scene");
}

}  // namespace
}  // namespace hgraph::server
