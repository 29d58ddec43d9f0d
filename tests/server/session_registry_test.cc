#include "server/session_registry.h"

#include <gtest/gtest.h>

#include <chrono>
#include <string>
#include <vector>

#include "core/common/error.h"
#include "server/auth.h"
#include "server/status/status.h"

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

// A merge's H-Graph name, reserved at its start and kept at its end.
std::string AddHGraph(SessionRegistry& registry, const std::string& session,
                      const std::string& id = "", const std::string& fingerprint = "f") {
  bool repeat = false;
  const std::string name = registry.ReserveHGraph(session, id, fingerprint, kAnonymous, &repeat);
  if (!repeat) registry.KeepHGraph(name);
  return name;
}

TEST(SessionRegistry, HGraphsAreNamedInTheirSessionAndReturnedOnDelete) {
  SessionRegistry registry(10, 1h);
  const std::string session = registry.Create(Scene('a'), kId, kAnonymous).name();
  const std::string first = AddHGraph(registry, session);
  const std::string second = AddHGraph(registry, session);
  // Random ids: 32 hex digits, distinct.
  EXPECT_EQ(first.rfind(session + "/hgraphs/", 0), 0u);
  EXPECT_EQ(first.size(), session.size() + 9 + 32);
  EXPECT_NE(first, second);
  EXPECT_EQ(SessionRegistry::SessionOfHGraph(second, "hgraph"), session);
  registry.RemoveHGraph(first);
  EXPECT_EQ(registry.Touch(session, "name", kAnonymous).hgraphs_size(), 1);
  EXPECT_EQ(registry.Delete(session, "name", kAnonymous), std::vector<std::string>{second});
  std::string field;
  EXPECT_EQ(CodeOf([&] { registry.Touch(session, "name", kAnonymous); }, &field),
            ErrorCode::kNotFound);
  EXPECT_EQ(field, "name");
  // A merge that finishes after the delete finds no session to add its H-Graph to.
  EXPECT_EQ(CodeOf([&] { registry.KeepHGraph(second); }), ErrorCode::kNotFound);
}

TEST(SessionRegistry, ClientChosenHGraphIdsRepeatOnlyTheSameRequestAndAreNeverGivenOutTwice) {
  SessionRegistry registry(10, 1h);
  const std::string session = registry.Create(Scene('a'), kId, kAnonymous).name();
  bool repeat = true;
  const std::string name = registry.ReserveHGraph(session, "my-graph", "f1", kAnonymous, &repeat);
  EXPECT_EQ(name, session + "/hgraphs/my-graph");
  EXPECT_FALSE(repeat);
  EXPECT_EQ(registry.StateOf(name), SessionRegistry::HGraphState::kRunning);
  // While it runs: ABORTED (MERGE_RUNNING).
  try {
    registry.ReserveHGraph(session, "my-graph", "f1", kAnonymous, &repeat);
    ADD_FAILURE() << "a repeat of a running merge was accepted";
  } catch (const ServiceError& e) {
    EXPECT_EQ(e.status(), grpc::StatusCode::ABORTED);
    EXPECT_EQ(e.reason(), "MERGE_RUNNING");
    EXPECT_GT(e.retry_delay().count(), 0);
  }
  registry.KeepHGraph(name);
  EXPECT_EQ(registry.ReserveHGraph(session, "my-graph", "f1", kAnonymous, &repeat), name);
  EXPECT_TRUE(repeat);
  try {
    registry.ReserveHGraph(session, "my-graph", "f2", kAnonymous, &repeat);
    ADD_FAILURE() << "another request under a used id was accepted";
  } catch (const ServiceError& e) {
    EXPECT_EQ(e.status(), grpc::StatusCode::ALREADY_EXISTS);
  }
  // Evicted or deleted: the name stays retired.
  registry.RemoveHGraph(name);
  EXPECT_EQ(registry.StateOf(name), SessionRegistry::HGraphState::kRetired);
  try {
    registry.ReserveHGraph(session, "my-graph", "f1", kAnonymous, &repeat);
    ADD_FAILURE() << "a retired name was given out again";
  } catch (const ServiceError& e) {
    EXPECT_EQ(e.status(), grpc::StatusCode::NOT_FOUND);
    EXPECT_EQ(e.reason(), "HGRAPH_NOT_FOUND");
  }
  // A failed merge's name is forgotten: its retry runs.
  const std::string failed = registry.ReserveHGraph(session, "again", "f", kAnonymous, &repeat);
  registry.AbandonHGraph(failed);
  EXPECT_EQ(registry.StateOf(failed), SessionRegistry::HGraphState::kUnknown);
  EXPECT_EQ(registry.ReserveHGraph(session, "again", "f", kAnonymous, &repeat), failed);
  EXPECT_FALSE(repeat);
  std::string field;
  EXPECT_EQ(
      CodeOf([&] { registry.ReserveHGraph(session, "Bad_Id", "f", kAnonymous, &repeat); }, &field),
      ErrorCode::kInvalidArgument);
  EXPECT_EQ(field, "hgraph_id");
}

TEST(SessionRegistry, ListPagesInNameOrder) {
  SessionRegistry registry(10, 1h);
  for (char c : {'3', '1', '2'}) {
    registry.Create(Scene('a'), std::string(32, c), kAnonymous);
  }
  bool more = false;
  const auto first = registry.List(kAnonymous, "", 2, &more);
  ASSERT_EQ(first.size(), 2u);
  EXPECT_TRUE(more);
  EXPECT_EQ(first[0].name(), "sessions/" + std::string(32, '1'));
  EXPECT_EQ(first[1].name(), "sessions/" + std::string(32, '2'));
  const auto second = registry.List(kAnonymous, first[1].name(), 2, &more);
  ASSERT_EQ(second.size(), 1u);
  EXPECT_FALSE(more);
  EXPECT_EQ(second[0].name(), "sessions/" + std::string(32, '3'));
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
  const std::string hgraph = AddHGraph(registry, session);
  EXPECT_TRUE(registry.ExpireIdle(SessionRegistry::Clock::now() + 30min).empty());
  EXPECT_EQ(registry.size(), 1);
  EXPECT_EQ(registry.ExpireIdle(SessionRegistry::Clock::now() + 2h),
            std::vector<std::string>{hgraph});
  EXPECT_EQ(registry.size(), 0);
}

}  // namespace
}  // namespace hgraph::server
