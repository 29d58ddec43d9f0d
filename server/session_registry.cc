#include "server/session_registry.h"

#include <algorithm>

#include "core/common/client_text.h"
#include "core/common/digest.h"
#include "core/common/error.h"

namespace hgraph::server {
namespace {

constexpr std::string_view kPrefix = "sessions/";
constexpr std::string_view kHGraphs = "/hgraphs/";

google::protobuf::Timestamp ToTimestamp(SessionRegistry::Clock::time_point t) {
  const auto ns =
      std::chrono::duration_cast<std::chrono::nanoseconds>(t.time_since_epoch()).count();
  google::protobuf::Timestamp ts;
  ts.set_seconds(ns / 1'000'000'000);
  ts.set_nanos(static_cast<int32_t>(ns % 1'000'000'000));
  return ts;
}

}  // namespace

SessionRegistry::SessionRegistry(int max_sessions, std::chrono::milliseconds ttl)
    : max_sessions_(max_sessions), ttl_(ttl) {}

void SessionRegistry::ValidateName(const std::string& name, const std::string& field) {
  if (name.rfind(kPrefix, 0) != 0 || name.size() != kPrefix.size() + 32) {
    throw InputError(field,
                     "must be \"sessions/<32 hex digits>\", got \"" + ClientText(name) + "\"");
  }
  for (size_t i = kPrefix.size(); i < name.size(); ++i) {
    const char c = name[i];
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) {
      throw InputError(field,
                       "must be \"sessions/<32 hex digits>\", got \"" + ClientText(name) + "\"");
    }
  }
}

std::string SessionRegistry::SessionOfHGraph(const std::string& hgraph, const std::string& field) {
  const size_t at = hgraph.find(kHGraphs);
  const bool ok = at == kPrefix.size() + 32 && at + kHGraphs.size() < hgraph.size() &&
                  std::all_of(hgraph.begin() + static_cast<long>(at + kHGraphs.size()),
                              hgraph.end(), [](char c) { return c >= '0' && c <= '9'; });
  if (!ok) {
    throw InputError(field,
                     "must be \"sessions/<id>/hgraphs/<n>\", got \"" + ClientText(hgraph) + "\"");
  }
  std::string session = hgraph.substr(0, at);
  ValidateName(session, field);
  return session;
}

void SessionRegistry::CheckOwner(const std::string& name, const Record& record,
                                 const std::string& field, const std::string& tenant) {
  if (record.tenant != tenant) {
    throw Error(ErrorCode::kPermissionDenied, field,
                "session " + name + " belongs to another tenant than this call's token");
  }
}

v1::Session SessionRegistry::ToProto(const std::string& name, const Record& record) const {
  v1::Session session;
  session.set_name(name);
  *session.mutable_scene() = record.scene;
  *session.mutable_create_time() = ToTimestamp(record.create_time);
  *session.mutable_expire_time() = ToTimestamp(record.expire_time);
  for (const std::string& h : record.hgraphs) session.add_hgraphs(h);
  return session;
}

v1::Session SessionRegistry::Create(const v1::Digest& scene, const std::string& id,
                                    const std::string& tenant) {
  const std::string name = std::string(kPrefix) + (id.empty() ? RandomHex128() : id);
  if (!id.empty()) ValidateName(name, "session_id");
  std::lock_guard lock(mutex_);
  auto it = sessions_.find(name);
  // Even an expired session not yet swept: its H-Graphs are still held under its name.
  if (it != sessions_.end()) CheckOwner(name, it->second, "session_id", tenant);
  if (it != sessions_.end() && it->second.expire_time > Clock::now()) {
    if (it->second.scene.sha256() != scene.sha256() ||
        it->second.scene.size_bytes() != scene.size_bytes()) {
      throw Error(ErrorCode::kFailedPrecondition, "session_id",
                  "session " + name + " already exists on another scene");
    }
    it->second.expire_time = Clock::now() + ttl_;
    return ToProto(name, it->second);
  }
  if (static_cast<int>(sessions_.size()) >= max_sessions_) {
    throw Error(ErrorCode::kResourceExhausted, "",
                std::to_string(sessions_.size()) +
                    " sessions exist, the limit (--max-sessions); "
                    "delete one or let idle ones expire");
  }
  const Clock::time_point now = Clock::now();
  Record& record = sessions_[name];
  record.tenant = tenant;
  record.scene = scene;
  record.create_time = now;
  record.expire_time = now + ttl_;
  return ToProto(name, record);
}

v1::Session SessionRegistry::Touch(const std::string& name, const std::string& field,
                                   const std::string& tenant) {
  ValidateName(name, field);
  std::lock_guard lock(mutex_);
  auto it = sessions_.find(name);
  const Clock::time_point now = Clock::now();
  if (it == sessions_.end() || it->second.expire_time <= now) {
    throw Error(ErrorCode::kNotFound, field,
                "session " + name +
                    " does not exist on this server (expired, deleted, or "
                    "created on another replica)");
  }
  CheckOwner(name, it->second, field, tenant);
  it->second.expire_time = now + ttl_;
  return ToProto(name, it->second);
}

std::vector<v1::Session> SessionRegistry::List(const std::string& tenant) const {
  std::lock_guard lock(mutex_);
  std::vector<v1::Session> out;
  for (const auto& [name, record] : sessions_) {
    if (record.tenant == tenant) out.push_back(ToProto(name, record));
  }
  return out;
}

std::vector<std::string> SessionRegistry::Delete(const std::string& name, const std::string& field,
                                                 const std::string& tenant) {
  ValidateName(name, field);
  std::lock_guard lock(mutex_);
  auto it = sessions_.find(name);
  if (it == sessions_.end()) {
    throw Error(ErrorCode::kNotFound, field, "session " + name + " does not exist");
  }
  CheckOwner(name, it->second, field, tenant);
  std::vector<std::string> hgraphs = std::move(it->second.hgraphs);
  sessions_.erase(it);
  return hgraphs;
}

std::string SessionRegistry::AddHGraph(const std::string& session) {
  std::lock_guard lock(mutex_);
  auto it = sessions_.find(session);
  if (it == sessions_.end()) {
    throw Error(ErrorCode::kNotFound, "session", "session " + session + " was deleted meanwhile");
  }
  std::string name = session + std::string(kHGraphs) + std::to_string(it->second.next_hgraph++);
  it->second.hgraphs.push_back(name);
  return name;
}

void SessionRegistry::RemoveHGraph(const std::string& hgraph) {
  const size_t at = hgraph.find(kHGraphs);
  if (at == std::string::npos) return;
  std::lock_guard lock(mutex_);
  auto it = sessions_.find(hgraph.substr(0, at));
  if (it == sessions_.end()) return;
  auto& list = it->second.hgraphs;
  list.erase(std::remove(list.begin(), list.end(), hgraph), list.end());
}

std::vector<std::string> SessionRegistry::ExpireIdle(Clock::time_point now) {
  std::lock_guard lock(mutex_);
  std::vector<std::string> hgraphs;
  for (auto it = sessions_.begin(); it != sessions_.end();) {
    if (it->second.expire_time <= now) {
      for (auto& h : it->second.hgraphs) hgraphs.push_back(std::move(h));
      it = sessions_.erase(it);
    } else {
      ++it;
    }
  }
  return hgraphs;
}

int SessionRegistry::size() const {
  std::lock_guard lock(mutex_);
  return static_cast<int>(sessions_.size());
}

}  // namespace hgraph::server
