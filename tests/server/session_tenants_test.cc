// Sessions and their owners, the tenants (server/session_registry.h, server/auth.h).
#include <gtest/gtest.h>

#include <chrono>
#include <string>

#include "core/common/error.h"
#include "server/session_registry.h"

namespace hgraph::server {
namespace {

using std::chrono::hours;
using std::chrono::milliseconds;

v1::Digest SceneDigest(char c) {
  v1::Digest d;
  d.set_sha256(std::string(64, c));
  d.set_size_bytes(10);
  return d;
}

const std::string kIdA(32, 'a');
const std::string kIdB(32, 'b');

// The code of the Error `f` throws (fails the test if none).
template <typename F>
ErrorCode CodeOf(F f) {
  try {
    f();
  } catch (const Error& e) {
    return e.code();
  }
  ADD_FAILURE() << "no error";
  return ErrorCode::kInvalidArgument;
}

TEST(SessionTenants, ASessionBelongsToTheTenantThatCreatedIt) {
  SessionRegistry registry(10, hours(1));
  const v1::Session a = registry.Create(SceneDigest('1'), kIdA, "team-a");
  EXPECT_EQ(registry.Touch(a.name(), "name", "team-a").name(), a.name());
  EXPECT_EQ(CodeOf([&] { registry.Touch(a.name(), "name", "team-b"); }),
            ErrorCode::kPermissionDenied);
  EXPECT_EQ(CodeOf([&] { registry.Touch(a.name(), "name", ""); }), ErrorCode::kPermissionDenied);
  EXPECT_EQ(CodeOf([&] { registry.Delete(a.name(), "name", "team-b"); }),
            ErrorCode::kPermissionDenied);
  // Re-creating another tenant's session by its id is refused too (ids are client-chosen).
  EXPECT_EQ(CodeOf([&] { registry.Create(SceneDigest('1'), kIdA, "team-b"); }),
            ErrorCode::kPermissionDenied);
  // Refusals change nothing: the owner still has it, a retried create returns it.
  EXPECT_EQ(registry.Create(SceneDigest('1'), kIdA, "team-a").name(), a.name());
  EXPECT_EQ(registry.size(), 1);
  EXPECT_TRUE(registry.Delete(a.name(), "name", "team-a").empty());
  EXPECT_EQ(CodeOf([&] { registry.Touch(a.name(), "name", "team-a"); }), ErrorCode::kNotFound);
}

TEST(SessionTenants, PermissionDeniedNamesTheFieldButNotTheOwner) {
  SessionRegistry registry(10, hours(1));
  const v1::Session a = registry.Create(SceneDigest('1'), kIdA, "team-a");
  try {
    registry.Touch(a.name(), "session", "team-b");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "session");
    EXPECT_NE(std::string(e.what()).find("belongs to another tenant"), std::string::npos);
    EXPECT_EQ(std::string(e.what()).find("team-a"), std::string::npos) << e.what();
  }
}

TEST(SessionTenants, ListShowsOnlyTheCallersSessions) {
  SessionRegistry registry(10, hours(1));
  registry.Create(SceneDigest('1'), kIdA, "team-a");
  registry.Create(SceneDigest('1'), kIdB, "team-b");
  registry.Create(SceneDigest('2'), "", "team-b");
  ASSERT_EQ(registry.List("team-a").size(), 1u);
  EXPECT_EQ(registry.List("team-a")[0].name(), "sessions/" + kIdA);
  EXPECT_EQ(registry.List("team-b").size(), 2u);
  EXPECT_TRUE(registry.List("").empty());
  EXPECT_TRUE(registry.List("team-c").empty());
}

TEST(SessionTenants, HGraphsAreReachedOnlyThroughTheirSession) {
  SessionRegistry registry(10, hours(1));
  const v1::Session a = registry.Create(SceneDigest('1'), kIdA, "team-a");
  bool repeat = false;
  const std::string hgraph = registry.ReserveHGraph(a.name(), "", "f", "team-a", &repeat);
  registry.KeepHGraph(hgraph);
  // Another tenant cannot merge into it.
  EXPECT_EQ(CodeOf([&] { registry.ReserveHGraph(a.name(), "", "f", "team-b", &repeat); }),
            ErrorCode::kPermissionDenied);
  const std::string session = SessionRegistry::SessionOfHGraph(hgraph, "hgraph");
  EXPECT_EQ(session, a.name());
  EXPECT_EQ(CodeOf([&] { registry.Touch(session, "hgraph", "team-b"); }),
            ErrorCode::kPermissionDenied);
  EXPECT_EQ(registry.Delete(a.name(), "name", "team-a"), std::vector<std::string>{hgraph});
}

TEST(SessionTenants, AnExpiredSessionNotYetSweptStaysItsOwners) {
  // Its H-Graphs are still held under its name until ExpireIdle drops them, so another tenant
  // must not take the name over in between.
  SessionRegistry registry(10, milliseconds(0));
  const v1::Session a = registry.Create(SceneDigest('1'), kIdA, "team-a");
  bool repeat = false;
  registry.KeepHGraph(registry.ReserveHGraph(a.name(), "", "f", "team-a", &repeat));
  EXPECT_EQ(CodeOf([&] { registry.Create(SceneDigest('1'), kIdA, "team-b"); }),
            ErrorCode::kPermissionDenied);
  EXPECT_EQ(registry.ExpireIdle(SessionRegistry::Clock::now()).size(), 1u);
  EXPECT_EQ(registry.Create(SceneDigest('1'), kIdA, "team-b").name(), a.name());
}

TEST(SessionTenants, TheAnonymousTenantOwnsEverythingWithoutTokens) {
  SessionRegistry registry(10, hours(1));
  const v1::Session s = registry.Create(SceneDigest('1'), "", "");
  EXPECT_EQ(registry.Touch(s.name(), "name", "").name(), s.name());
  EXPECT_EQ(registry.List("").size(), 1u);
}

}  // namespace
}  // namespace hgraph::server
