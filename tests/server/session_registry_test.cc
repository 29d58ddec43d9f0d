#include "server/session_registry.h"

#include <gtest/gtest.h>

#include <chrono>
#include <string>
#include <vector>

#include "core/common/error.h"
#include "server/auth.h"

namespace hgraph::server {
namespace {

// Without --auth-tokens every session is the anonymous tenant's (session_tenants_test.cc covers
// owners).
const std::string kAnonymous(kAnonymousTenant);

using namespace std::chrono_literals;

v1::Digest Scene(char c) {
  v1::Digest digest;
  digest.set_sha256(std::string(64, c));
  digest.set_size_bytes(10);
  return digest;
}

const std::string kId = "0123456789abcdef0123456789abcdef";

ErrorCode CodeOf(const std::function<void()>& f, std::string* field = nullptr) {
  try {
    f();
  } catch (const Error& e) {
    if (field) *field = e.field();
    return e.code();
  }
  ADD_FAILURE() << "no error";
  return ErrorCode::kInvalidArgument;
}

TEST(SessionRegistry, CreateWithAnIdIsIdempotentOnTheSameScene) {
  SessionRegistry registry(10, 1h);
  const v1::Session a = registry.Create(Scene('a'), kId, kAnonymous);
  EXPECT_EQ(a.name(), "sessions/" + kId);
  EXPECT_EQ(registry.Create(Scene('a'), kId, kAnonymous).name(), a.name());
  EXPECT_EQ(registry.size(), 1);
  std::string field;
  EXPECT_EQ(CodeOf([&] { registry.Create(Scene('b'), kId, kAnonymous); }, &field),
            ErrorCode::kFailedPrecondition);
  EXPECT_EQ(field, "session_id");
  EXPECT_EQ(CodeOf([&] { registry.Create(Scene('a'), "not-hex", kAnonymous); }, &field),
            ErrorCode::kInvalidArgument);
  EXPECT_EQ(field, "session_id");
}

TEST(SessionRegistry, RandomIdsAreDistinctAndTheLimitHolds) {
  SessionRegistry registry(2, 1h);
  const std::string a = registry.Create(Scene('a'), "", kAnonymous).name();
  const std::string b = registry.Create(Scene('a'), "", kAnonymous).name();
  EXPECT_NE(a, b);
  EXPECT_EQ(CodeOf([&] { registry.Create(Scene('a'), "", kAnonymous); }),
            ErrorCode::kResourceExhausted);
}

TEST(SessionRegistry, HGraphsAreNamedInTheirSessionAndReturnedOnDelete) {
  SessionRegistry registry(10, 1h);
  const std::string session = registry.Create(Scene('a'), kId, kAnonymous).name();
  const std::string first = registry.AddHGraph(session);
  const std::string second = registry.AddHGraph(session);
  EXPECT_EQ(first, session + "/hgraphs/1");
  EXPECT_EQ(second, session + "/hgraphs/2");
  EXPECT_EQ(SessionRegistry::SessionOfHGraph(second, "hgraph"), session);
  registry.RemoveHGraph(first);
  EXPECT_EQ(registry.Touch(session, "name", kAnonymous).hgraphs_size(), 1);
  EXPECT_EQ(registry.Delete(session, "name", kAnonymous), std::vector<std::string>{second});
  std::string field;
  EXPECT_EQ(CodeOf([&] { registry.Touch(session, "name", kAnonymous); }, &field),
            ErrorCode::kNotFound);
  EXPECT_EQ(field, "name");
  // A merge that finishes after the delete finds no session to add its H-Graph to.
  EXPECT_EQ(CodeOf([&] { registry.AddHGraph(session); }), ErrorCode::kNotFound);
}

TEST(SessionRegistry, MalformedNamesAreInputErrorsNamingTheField) {
  SessionRegistry registry(10, 1h);
  std::string field;
  EXPECT_EQ(CodeOf([&] { registry.Touch("sessions/xyz", "session", kAnonymous); }, &field),
            ErrorCode::kInvalidArgument);
  EXPECT_EQ(field, "session");
  EXPECT_EQ(CodeOf([&] { SessionRegistry::SessionOfHGraph("sessions/" + kId, "hgraph"); }, &field),
            ErrorCode::kInvalidArgument);
  EXPECT_EQ(field, "hgraph");
}

TEST(SessionRegistry, IdleSessionsExpireWithTheirHGraphs) {
  SessionRegistry registry(10, 1h);
  const std::string session = registry.Create(Scene('a'), kId, kAnonymous).name();
  const std::string hgraph = registry.AddHGraph(session);
  EXPECT_TRUE(registry.ExpireIdle(SessionRegistry::Clock::now() + 30min).empty());
  EXPECT_EQ(registry.size(), 1);
  EXPECT_EQ(registry.ExpireIdle(SessionRegistry::Clock::now() + 2h),
            std::vector<std::string>{hgraph});
  EXPECT_EQ(registry.size(), 0);
}

}  // namespace
}  // namespace hgraph::server
