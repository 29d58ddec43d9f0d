// Two replicas sharing one store (server/shared_state.h): two PathMergerServices in this process,
// each on its own loopback gRPC port, over one MemoryStore (the Redis store runs in
// tests/integration/store_test.py). What one replica builds, the other answers for.
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "core/adapter/path_io.h"
#include "core/adapter/scene_proto.h"
#include "core/common/digest.h"
#include "hgraph/v1/service.grpc.pb.h"
#include "server/metrics.h"
#include "server/service.h"
#include "server/shared_state.h"
#include "server/store.h"

namespace hgraph::server {
namespace {

// One replica: a service and its server on a loopback port.
struct Replica {
  explicit Replica(std::shared_ptr<Store> store)
      : service(ServerOptions{.threads = 2, .store = std::move(store)}, metrics) {
    grpc::ServerBuilder builder;
    int port = 0;
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
    builder.RegisterService(&service);
    server = builder.BuildAndStart();
    stub = v1::PathMerger::NewStub(grpc::CreateChannel("127.0.0.1:" + std::to_string(port),
                                                       grpc::InsecureChannelCredentials()));
  }
  ~Replica() {
    server->Shutdown();
    service.WaitIdle();
  }

  Metrics metrics;
  PathMergerService service;
  std::unique_ptr<grpc::Server> server;
  std::unique_ptr<v1::PathMerger::Stub> stub;
};

class SharedStoreTest : public ::testing::Test {
 protected:
  SharedStoreTest()
      : store_(std::make_shared<MemoryStore>()),
        a_(std::make_unique<Replica>(store_)),
        b_(std::make_unique<Replica>(store_)) {}

  // A session on replica A on the circles scene, and a merge in it (all-pairs, length, no
  // post-optimization: a requery under its measure checks nothing).
  v1::MergePathsResponse MergeOnA() {
    const std::string dir = std::string(HGRAPH_TEST_DATA_DIR) + "/circles/";
    const v1::Scene scene = ReadSceneFile(dir + "scene.json");
    {
      grpc::ClientContext context;
      v1::PutSceneRequest request;
      *request.mutable_scene() = scene;
      v1::PutSceneResponse put;
      EXPECT_TRUE(a_->stub->PutScene(&context, request, &put).ok());
      grpc::ClientContext create_context;
      v1::CreateSessionRequest create;
      *create.mutable_scene() = put.digest();
      EXPECT_TRUE(a_->stub->CreateSession(&create_context, create, &session_).ok());
    }
    v1::MergePathsRequest request;
    request.set_session(session_.name());
    *request.mutable_paths() =
        PathsToProto(LoadPathsFile(dir + "paths.txt", SceneFromProto(scene, "", {})->space));
    request.mutable_options()->set_variant(v1::VARIANT_ALL_PAIRS);
    request.mutable_options()->set_optimize_ms(0);
    grpc::ClientContext context;
    auto reader = a_->stub->MergePaths(&context, request);
    v1::MergePathsResponse event, result;
    while (reader->Read(&event)) {
      if (event.has_result()) result = event;
    }
    EXPECT_TRUE(reader->Finish().ok());
    return result;
  }

  static grpc::Status Requery(Replica& replica, const std::string& hgraph,
                              const v1::Measure& measure, v1::RequeryResponse* response) {
    grpc::ClientContext context;
    v1::RequeryRequest request;
    request.set_hgraph(hgraph);
    *request.mutable_measure() = measure;
    return replica.stub->Requery(&context, request, response);
  }

  static grpc::Status AddPaths(Replica& replica, const std::string& hgraph,
                               const v1::PathSet& paths, v1::AddPathsResponse* response) {
    grpc::ClientContext context;
    v1::AddPathsRequest request;
    request.set_hgraph(hgraph);
    *request.mutable_paths() = paths;
    return replica.stub->AddPaths(&context, request, response);
  }

  std::shared_ptr<MemoryStore> store_;
  std::unique_ptr<Replica> a_;
  std::unique_ptr<Replica> b_;
  v1::Session session_;
};

// Merged on A, requeried on B under the merge's measure: the merge's path, and no check, no
// distance query: B loaded every report A's merge made. Under another measure, B answers as A.
TEST_F(SharedStoreTest, AnotherReplicaAnswersAsTheBuilder) {
  const v1::MergePathsResponse merged = MergeOnA();
  ASSERT_EQ(merged.retention(), v1::RETENTION_KEPT);
  EXPECT_TRUE(merged.shared());

  v1::RequeryResponse on_b;
  ASSERT_TRUE(Requery(*b_, merged.hgraph(), v1::Measure(), &on_b).ok());
  EXPECT_EQ(on_b.result().path().SerializeAsString(), merged.result().path().SerializeAsString());
  EXPECT_EQ(on_b.result().stats().collision_checks(), 0);
  EXPECT_EQ(on_b.result().stats().distance_queries(), 0);
  EXPECT_GT(on_b.result().stats().edges_reused(), 0);
  EXPECT_EQ(on_b.generation(), 1);
  EXPECT_NE(b_->metrics.Render().find("hgraph_store_loads_total{kind=\"hgraph\"} 1"),
            std::string::npos)
      << b_->metrics.Render();

  v1::Measure clearance;
  clearance.set_type(v1::Measure::TYPE_INVERSE_CLEARANCE);
  v1::RequeryResponse clearance_b, clearance_a;
  ASSERT_TRUE(Requery(*b_, merged.hgraph(), clearance, &clearance_b).ok());
  ASSERT_TRUE(Requery(*a_, merged.hgraph(), clearance, &clearance_a).ok());
  EXPECT_EQ(clearance_b.result().path().SerializeAsString(),
            clearance_a.result().path().SerializeAsString());
  EXPECT_EQ(clearance_b.result().stats().distance_queries(),
            clearance_a.result().stats().distance_queries());
}

// A replica that goes away loses nothing: a new one, on the same store, answers.
TEST_F(SharedStoreTest, SurvivesTheBuilder) {
  const v1::MergePathsResponse merged = MergeOnA();
  a_.reset();
  Replica c(store_);
  v1::RequeryResponse on_c;
  ASSERT_TRUE(Requery(c, merged.hgraph(), v1::Measure(), &on_c).ok());
  EXPECT_EQ(on_c.result().path().SerializeAsString(), merged.result().path().SerializeAsString());
  EXPECT_EQ(on_c.result().stats().collision_checks(), 0);
  grpc::ClientContext context;
  v1::GetSessionRequest get;
  get.set_name(session_.name());
  v1::Session session;
  ASSERT_TRUE(c.stub->GetSession(&context, get, &session).ok());
  EXPECT_EQ(session.scene().sha256(), session_.scene().sha256());
}

// ListSessions on a replica that holds none of the tenant's sessions lists them from the store,
// each with the H-Graphs written there, and pages through them; B lists what A created.
TEST_F(SharedStoreTest, ListsTheSessionsOfEveryReplica) {
  const v1::MergePathsResponse merged = MergeOnA();
  const std::string first = session_.name();
  MergeOnA();  // a second session on A
  const std::string second = session_.name();
  std::vector<v1::Session> listed;
  std::string token;
  do {
    grpc::ClientContext context;
    v1::ListSessionsRequest request;
    request.set_page_size(1);
    request.set_page_token(token);
    v1::ListSessionsResponse page;
    ASSERT_TRUE(b_->stub->ListSessions(&context, request, &page).ok());
    ASSERT_LE(page.sessions_size(), 1);
    listed.insert(listed.end(), page.sessions().begin(), page.sessions().end());
    token = page.next_page_token();
  } while (!token.empty());
  ASSERT_EQ(listed.size(), 2u);
  EXPECT_EQ(std::min(first, second), listed[0].name());
  EXPECT_EQ(std::max(first, second), listed[1].name());
  const v1::Session& one = listed[0].name() == first ? listed[0] : listed[1];
  ASSERT_EQ(one.hgraphs_size(), 1);
  EXPECT_EQ(one.hgraphs(0), merged.hgraph());
  EXPECT_EQ(one.scene().sha256(), session_.scene().sha256());
  EXPECT_GT(one.expire_time().seconds(), one.create_time().seconds());
  // Listing loads nothing: B holds no session yet (GetSession would load it).
  EXPECT_EQ(b_->metrics.Render().find("hgraph_store_loads_total{kind=\"session\"} 1"),
            std::string::npos);
}

// DeleteSession on a replica that never held the session's H-Graph deletes it from the store:
// no replica finds it afterwards.
TEST_F(SharedStoreTest, DeletingOnAnotherReplicaDeletesEveryStoredHGraph) {
  const v1::MergePathsResponse merged = MergeOnA();
  ASSERT_TRUE(store_->Exists(SharedState::HGraphKey(merged.hgraph())));
  {
    grpc::ClientContext context;
    v1::DeleteSessionRequest request;
    request.set_name(session_.name());
    v1::DeleteSessionResponse response;
    ASSERT_TRUE(b_->stub->DeleteSession(&context, request, &response).ok());
  }
  EXPECT_FALSE(store_->Exists(SharedState::HGraphKey(merged.hgraph())));
  EXPECT_FALSE(store_->Exists(SharedState::SessionKey(session_.name())));
  EXPECT_FALSE(store_->Exists(SharedState::SessionHGraphsKey(session_.name())));
  EXPECT_TRUE(store_->Members(SharedState::TenantSessionsKey("")).empty());
  Replica c(store_);
  v1::RequeryResponse response;
  EXPECT_EQ(Requery(c, merged.hgraph(), v1::Measure(), &response).error_code(),
            grpc::StatusCode::NOT_FOUND);
}

// Additions on both replicas, in turn, each on the copy it held: neither is lost. B's copy is
// stale after A's addition; B loads the stored one before adding to it.
TEST_F(SharedStoreTest, AdditionsOnTwoReplicasAreNotLost) {
  const v1::MergePathsResponse merged = MergeOnA();
  v1::RequeryResponse warm;
  ASSERT_TRUE(Requery(*b_, merged.hgraph(), v1::Measure(), &warm).ok());  // B holds it now
  const std::string dir = std::string(HGRAPH_TEST_DATA_DIR) + "/circles/";
  const v1::Scene scene = ReadSceneFile(dir + "scene.json");
  v1::PathSet paths =
      PathsToProto(LoadPathsFile(dir + "paths.txt", SceneFromProto(scene, "", {})->space));
  v1::PathSet one;
  *one.add_paths() = paths.paths(0);
  one.mutable_paths(0)->set_name("from-a");
  v1::AddPathsResponse on_a, on_b;
  ASSERT_TRUE(AddPaths(*a_, merged.hgraph(), one, &on_a).ok());
  EXPECT_EQ(on_a.generation(), 2);
  EXPECT_TRUE(on_a.shared());
  one.mutable_paths(0)->set_name("from-b");
  ASSERT_TRUE(AddPaths(*b_, merged.hgraph(), one, &on_b).ok());
  EXPECT_EQ(on_b.generation(), 3);
  // A's copy is stale now: it loads generation 3, with both additions.
  v1::RequeryResponse after;
  ASSERT_TRUE(Requery(*a_, merged.hgraph(), v1::Measure(), &after).ok());
  EXPECT_EQ(after.generation(), 3);
  EXPECT_EQ(after.result().inputs_size(), paths.paths_size() + 2);
}

// A store whose H-Graph version reads lag behind the first `stale` times, and whose first
// `conflicts` compare-and-sets fail: what a replica sees when another replica's write lands
// between its check of the version and its own write (a race this process cannot time
// otherwise). Everything else is the MemoryStore's.
class LaggingStore final : public Store {
 public:
  LaggingStore(std::shared_ptr<MemoryStore> store, int stale, int conflicts = 0)
      : store_(std::move(store)), stale_(stale), conflicts_(conflicts) {}
  std::optional<std::string> Get(const std::string& key) override { return store_->Get(key); }
  std::optional<std::string> GetPrefix(const std::string& key, size_t bytes) override {
    if (stale_ > 0 && key.find(":hgraph:") != std::string::npos) {
      --stale_;
      return std::nullopt;  // "not there": the replica keeps its copy
    }
    return store_->GetPrefix(key, bytes);
  }
  void Set(const std::string& key, std::string_view value, std::chrono::milliseconds ttl) override {
    store_->Set(key, value, ttl);
  }
  bool SetIfPrefix(const std::string& key, std::string_view expected_prefix, std::string_view value,
                   std::chrono::milliseconds ttl) override {
    if (conflicts_ > 0) {
      --conflicts_;
      return false;
    }
    return store_->SetIfPrefix(key, expected_prefix, value, ttl);
  }
  bool Exists(const std::string& key) override { return store_->Exists(key); }
  void Expire(const std::vector<std::string>& keys, std::chrono::milliseconds ttl) override {
    store_->Expire(keys, ttl);
  }
  void Delete(const std::vector<std::string>& keys) override { store_->Delete(keys); }
  std::vector<std::optional<std::string>> GetMany(const std::vector<std::string>& keys) override {
    return store_->GetMany(keys);
  }
  std::optional<std::chrono::milliseconds> TimeToLive(const std::string& key) override {
    return store_->TimeToLive(key);
  }
  void AddMember(const std::string& key, const std::string& member,
                 std::chrono::milliseconds ttl) override {
    store_->AddMember(key, member, ttl);
  }
  std::vector<std::string> Members(const std::string& key) override { return store_->Members(key); }
  void RemoveMembers(const std::string& key, const std::vector<std::string>& members) override {
    store_->RemoveMembers(key, members);
  }
  std::string Describe() const override { return "lagging memory"; }

 private:
  std::shared_ptr<MemoryStore> store_;
  std::atomic<int> stale_;
  std::atomic<int> conflicts_;
};

// The race itself: B adds to a stale copy, its compare-and-set finds A's newer version, and B
// adds again on the stored H-Graph: both additions are kept. When B loses twice, it answers
// ABORTED (STORE_CONFLICT) and adds nothing.
TEST_F(SharedStoreTest, TheLoserOfACompareAndSetAddsAgainOrAborts) {
  const v1::MergePathsResponse merged = MergeOnA();
  const std::string dir = std::string(HGRAPH_TEST_DATA_DIR) + "/circles/";
  const v1::Scene scene = ReadSceneFile(dir + "scene.json");
  v1::PathSet one;
  *one.add_paths() =
      PathsToProto(LoadPathsFile(dir + "paths.txt", SceneFromProto(scene, "", {})->space)).paths(0);
  for (int stale : {1, 2}) {
    // 1: one real race; 2: a replica that loses every compare-and-set (another replica wins
    // each time).
    Replica lagging(std::make_shared<LaggingStore>(store_, stale, stale == 2 ? 2 : 0));
    v1::RequeryResponse warm;
    ASSERT_TRUE(Requery(lagging, merged.hgraph(), v1::Measure(), &warm).ok());
    v1::AddPathsResponse on_a, on_lagging;
    one.mutable_paths(0)->set_name("a" + std::to_string(stale));
    ASSERT_TRUE(AddPaths(*a_, merged.hgraph(), one, &on_a).ok());
    one.mutable_paths(0)->set_name("lagging" + std::to_string(stale));
    const grpc::Status status = AddPaths(lagging, merged.hgraph(), one, &on_lagging);
    v1::RequeryResponse after;
    ASSERT_TRUE(Requery(*a_, merged.hgraph(), v1::Measure(), &after).ok());
    if (stale == 1) {
      ASSERT_TRUE(status.ok()) << status.error_message();
      EXPECT_EQ(on_lagging.generation(), on_a.generation() + 1);
      EXPECT_EQ(after.generation(), on_lagging.generation());
      EXPECT_EQ(after.result().inputs(after.result().inputs_size() - 1).name(), "lagging1");
      EXPECT_EQ(after.result().inputs(after.result().inputs_size() - 2).name(), "a1");
    } else {
      EXPECT_EQ(status.error_code(), grpc::StatusCode::ABORTED);
      EXPECT_NE(status.error_message().find("another replica"), std::string::npos)
          << status.error_message();
      EXPECT_EQ(after.generation(), on_a.generation()) << "the loser added nothing";
    }
  }
}

// Garbage under an H-Graph's key is refused (counted, logged): NOT_FOUND, never a crash or a
// wrong answer. So is an H-Graph record stored under another H-Graph's key.
TEST_F(SharedStoreTest, RefusesCorruptAndForeignEntries) {
  const v1::MergePathsResponse merged = MergeOnA();
  const std::string key = SharedState::HGraphKey(merged.hgraph());
  const std::string good = *store_->Get(key);
  // A record of the layout before AddPaths' request ids were stored (tag HGRAPH1:), and a sound
  // record whose snapshot is of the format before (3): refused as of another format, as the
  // damaged ones are.
  std::string old_layout = good;
  old_layout.replace(0, 8, "HGRAPH1:");
  std::string old_snapshot = good;
  const size_t magic = old_snapshot.rfind(std::string("HGSESSN\0", 8));
  ASSERT_NE(magic, std::string::npos);
  old_snapshot[magic + 8] = 3;
  old_snapshot.replace(24, 64, Sha256Hex(std::string_view(old_snapshot).substr(88)));
  for (const std::string& bad :
       {std::string("garbage"), good.substr(0, good.size() / 2), good + "x",
        good.substr(0, 200) + std::string(good.size() - 200, '\0'), old_layout, old_snapshot}) {
    store_->Set(key, bad, std::chrono::minutes(1));
    Replica c(store_);
    v1::RequeryResponse response;
    const grpc::Status status = Requery(c, merged.hgraph(), v1::Measure(), &response);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::NOT_FOUND) << status.error_message();
    EXPECT_NE(c.metrics.Render().find("hgraph_store_refused_total{kind=\"hgraph\"} 1"),
              std::string::npos);
  }
  // A sound record of another name: refused too.
  const std::string other = session_.name() + "/hgraphs/other";
  store_->Set(SharedState::HGraphKey(other), good, std::chrono::minutes(1));
  Replica c(store_);
  v1::RequeryResponse response;
  EXPECT_EQ(Requery(c, other, v1::Measure(), &response).error_code(), grpc::StatusCode::NOT_FOUND);
}

// The store's address: errors name the flag and what is wrong.
TEST(StoreAddress, ParsesAndRefuses) {
  EXPECT_FALSE(ParseStoreAddress("memory").redis);
  const StoreAddress a = ParseStoreAddress("redis://cache.local:6380/3");
  EXPECT_TRUE(a.redis);
  EXPECT_FALSE(a.tls);
  EXPECT_EQ(a.host, "cache.local");
  EXPECT_EQ(a.port, 6380);
  EXPECT_EQ(a.db, 3);
  const StoreAddress b = ParseStoreAddress("rediss://[::1]");
  EXPECT_TRUE(b.tls);
  EXPECT_EQ(b.host, "::1");
  EXPECT_EQ(b.port, 6379);
  for (const char* bad :
       {"", "redis", "http://x", "redis://", "redis://h:0", "redis://h:70000",
        "redis://h:", "redis://h/16", "redis://h/x", "redis://u:p@h", "redis://[::1"}) {
    try {
      ParseStoreAddress(bad);
      ADD_FAILURE() << bad << " was accepted";
    } catch (const InputError& e) {
      EXPECT_EQ(e.field(), "--store") << bad;
    }
  }
}

// Compare-and-set: a write over a version succeeds once; the second, over the same version,
// finds the first's and writes nothing.
TEST(MemoryStore, SetsIfThePrefixMatches) {
  MemoryStore store;
  const auto ttl = std::chrono::minutes(1);
  EXPECT_TRUE(store.SetIfPrefix("k", "", "v1:a", ttl));
  EXPECT_FALSE(store.SetIfPrefix("k", "", "v1:b", ttl));
  EXPECT_TRUE(store.SetIfPrefix("k", "v1", "v2:a", ttl));
  EXPECT_FALSE(store.SetIfPrefix("k", "v1", "v2:b", ttl));
  EXPECT_EQ(*store.Get("k"), "v2:a");
  EXPECT_EQ(*store.GetPrefix("k", 2), "v2");
  store.Set("e", "x", std::chrono::milliseconds(1));
  std::this_thread::sleep_for(std::chrono::milliseconds(5));
  EXPECT_FALSE(store.Get("e").has_value());
}

// Sets: members added and removed, expiry no sooner than the longest asked, values of many keys.
TEST(MemoryStore, KeepsSets) {
  MemoryStore store;
  store.AddMember("s", "a", std::chrono::minutes(1));
  store.AddMember("s", "b", std::chrono::milliseconds(1));  // does not shorten the set's life
  store.AddMember("s", "a", std::chrono::minutes(1));
  std::this_thread::sleep_for(std::chrono::milliseconds(5));
  std::vector<std::string> members = store.Members("s");
  std::sort(members.begin(), members.end());
  EXPECT_EQ(members, (std::vector<std::string>{"a", "b"}));
  EXPECT_GT(*store.TimeToLive("s"), std::chrono::seconds(50));
  store.RemoveMembers("s", {"a", "c"});
  EXPECT_EQ(store.Members("s"), std::vector<std::string>{"b"});
  store.RemoveMembers("s", {"b"});
  EXPECT_FALSE(store.Exists("s"));
  EXPECT_TRUE(store.Members("absent").empty());
  EXPECT_FALSE(store.TimeToLive("absent").has_value());
  store.Set("k", "v", std::chrono::minutes(1));
  const auto values = store.GetMany({"k", "absent"});
  ASSERT_EQ(values.size(), 2u);
  EXPECT_EQ(values[0], std::optional<std::string>("v"));
  EXPECT_FALSE(values[1].has_value());
}

}  // namespace
}  // namespace hgraph::server
