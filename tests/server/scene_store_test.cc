#include "server/scene_store.h"

#include <gtest/gtest.h>

#include <string>

#include "core/adapter/scene_proto.h"
#include "core/common/digest.h"
#include "core/common/error.h"
#include "server/mesh_importer.h"
#include "server/metrics.h"
#include "server/resource_cache.h"

namespace hgraph::server {
namespace {

v1::Scene Circles() { return ReadSceneFile(HGRAPH_TEST_DATA_DIR "/circles/scene.json"); }

MeshImporter Importer() {
  return MeshImporter(MeshImportLimits{.helper_path = HGRAPH_BINARY_DIR "/hgraph-mesh-import"});
}

v1::Digest DigestOf(const std::string& bytes) {
  v1::Digest digest;
  digest.set_sha256(Sha256Hex(bytes));
  digest.set_size_bytes(static_cast<int64_t>(bytes.size()));
  return digest;
}

struct Store {
  explicit Store(size_t budget)
      : cache(budget), families(registry), store(cache, families, Importer()) {}
  ResourceCache cache;
  Metrics registry;
  ServiceMetrics families;
  SceneStore store;
};

TEST(SceneStore, BlobsAreVerifiedThenStoredOnce) {
  Store s(1 << 20);
  const std::string bytes = "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
  const v1::Digest digest = DigestOf(bytes);
  EXPECT_FALSE(s.store.HasBlob(digest));
  EXPECT_TRUE(s.store.PutBlob(digest, bytes));
  EXPECT_TRUE(s.store.HasBlob(digest));
  EXPECT_FALSE(s.store.PutBlob(digest, bytes));  // already held

  v1::Digest wrong_size = digest;
  wrong_size.set_size_bytes(digest.size_bytes() + 1);
  EXPECT_FALSE(s.store.HasBlob(wrong_size));
  try {
    s.store.PutBlob(wrong_size, bytes);
    FAIL() << "a wrong size was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "digest.size_bytes");
  }
  v1::Digest wrong_sha = DigestOf(bytes + "x");
  wrong_sha.set_size_bytes(digest.size_bytes());
  try {
    s.store.PutBlob(wrong_sha, bytes);
    FAIL() << "a wrong hash was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "digest.sha256");
  }
}

TEST(SceneStore, ABlobOverTheBudgetIsResourceExhausted) {
  Store s(16);
  const std::string bytes(64, 'x');
  try {
    s.store.PutBlob(DigestOf(bytes), bytes);
    FAIL() << "a blob over the budget was stored";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kResourceExhausted);
    EXPECT_NE(std::string(e.what()).find("--cache-bytes"), std::string::npos) << e.what();
  }
}

TEST(SceneStore, SceneIsLoadedOnceAndSharedByDigest) {
  Store s(64 << 20);
  const v1::Digest digest = s.store.PutScene(Circles());
  EXPECT_TRUE(s.store.HasScene(digest));
  const LoadedScene a = s.store.Get(digest, "scene");
  const LoadedScene b = s.store.Get(digest, "scene");
  EXPECT_EQ(a.world.get(), b.world.get());
  EXPECT_EQ(s.families.scene_loads.Value(), 1);
  EXPECT_GE(s.families.scene_cache_hits.Value(), 2);
  // The same scene again is the same digest.
  EXPECT_EQ(s.store.PutScene(Circles()).sha256(), digest.sha256());
}

TEST(SceneStore, UnknownSceneIsNotFoundNamingTheField) {
  Store s(1 << 20);
  try {
    s.store.Get(DigestOf("no such scene"), "session");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kNotFound);
    EXPECT_EQ(e.field(), "session");
  }
}

TEST(SceneStore, MeshFilePathsAreRefused) {
  Store s(1 << 20);
  v1::Scene scene = Circles();
  scene.mutable_obstacles(0)->mutable_shape()->mutable_mesh()->set_path("/etc/passwd");
  try {
    s.store.PutScene(scene);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "scene.obstacles[0].shape.mesh.path");
  }
}

// A collision world larger than the whole budget cannot be kept: it is refused once, naming the
// budget, rather than accepted and then rebuilt on every later call.
TEST(SceneStore, AWorldOverTheBudgetIsRefusedNotRebuiltOnEveryCall) {
  const v1::Scene scene = Circles();
  Store s(scene.ByteSizeLong() + 64);  // the message fits, its BVHs do not
  try {
    s.store.PutScene(scene);
    FAIL() << "a world over the budget was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kResourceExhausted);
    EXPECT_NE(std::string(e.what()).find("--cache-bytes"), std::string::npos) << e.what();
  }
  EXPECT_EQ(s.families.scene_loads.Value(), 1);
}

}  // namespace
}  // namespace hgraph::server
