#include "server/session_registry.h"

#include <algorithm>

#include "core/common/client_text.h"
#include "core/common/digest.h"
#include "core/common/error.h"
#include "server/status/status.h"

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

// An H-Graph id (MergePathsRequest.hgraph_id): 1 to 63 lower-case letters, digits and '-',
// starting with a letter or digit. The server's own are 32 hex digits.
bool ValidHGraphId(const std::string& id) {
  if (id.empty() || id.size() > 63 || id[0] == '-') return false;
  return std::all_of(id.begin(), id.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-';
  });
}

ServiceError SessionNotFound(const std::string& field, const std::string& message) {
  return ServiceError(grpc::StatusCode::NOT_FOUND, "SESSION_NOT_FOUND", field, message);
}

}  // namespace

SessionRegistry::SessionRegistry(int max_sessions, std::chrono::milliseconds ttl,
                                 int tenant_max_sessions)
    : max_sessions_(max_sessions), tenant_max_sessions_(tenant_max_sessions), ttl_(ttl) {}

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
  const bool ok = at == kPrefix.size() + 32 && ValidHGraphId(hgraph.substr(at + kHGraphs.size()));
  if (!ok) {
    throw InputError(
        field, "must be \"sessions/<id>/hgraphs/<hgraph id>\", got \"" + ClientText(hgraph) + "\"");
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
  if (tenant_max_sessions_ > 0) {
    const Clock::time_point now = Clock::now();
    const auto held = std::count_if(sessions_.begin(), sessions_.end(), [&](const auto& s) {
      return s.second.tenant == tenant && s.second.expire_time > now;
    });
    if (held >= tenant_max_sessions_) {
      throw ServiceError(grpc::StatusCode::RESOURCE_EXHAUSTED, "TENANT_QUOTA", "",
                         "this tenant has " + std::to_string(held) +
                             " sessions, its quota (--tenant-max-sessions=" +
                             std::to_string(tenant_max_sessions_) +
                             "); delete one or let idle ones expire");
    }
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
    throw SessionNotFound(field, "session " + name +
                                     " does not exist on this server (expired, deleted, or "
                                     "created on another replica)");
  }
  CheckOwner(name, it->second, field, tenant);
  it->second.expire_time = now + ttl_;
  return ToProto(name, it->second);
}

std::vector<v1::Session> SessionRegistry::List(const std::string& tenant, const std::string& after,
                                               size_t page_size, bool* more) const {
  std::lock_guard lock(mutex_);
  std::vector<v1::Session> out;
  if (more != nullptr) *more = false;
  for (auto it = sessions_.upper_bound(after); it != sessions_.end(); ++it) {
    if (it->second.tenant != tenant) continue;
    if (out.size() == page_size) {
      if (more != nullptr) *more = true;
      break;
    }
    out.push_back(ToProto(it->first, it->second));
  }
  return out;
}

std::vector<std::string> SessionRegistry::Delete(const std::string& name, const std::string& field,
                                                 const std::string& tenant) {
  ValidateName(name, field);
  std::lock_guard lock(mutex_);
  auto it = sessions_.find(name);
  if (it == sessions_.end()) {
    throw SessionNotFound(field, "session " + name + " does not exist");
  }
  CheckOwner(name, it->second, field, tenant);
  std::vector<std::string> hgraphs = std::move(it->second.hgraphs);
  sessions_.erase(it);
  return hgraphs;
}

SessionRegistry::Record* SessionRegistry::RecordOf(const std::string& hgraph) {
  const size_t at = hgraph.find(kHGraphs);
  if (at == std::string::npos) return nullptr;
  auto it = sessions_.find(hgraph.substr(0, at));
  return it == sessions_.end() ? nullptr : &it->second;
}

const SessionRegistry::Record* SessionRegistry::RecordOf(const std::string& hgraph) const {
  return const_cast<SessionRegistry*>(this)->RecordOf(hgraph);
}

std::string SessionRegistry::ReserveHGraph(const std::string& session, const std::string& hgraph_id,
                                           const std::string& fingerprint,
                                           const std::string& tenant, bool* repeat) {
  *repeat = false;
  if (!hgraph_id.empty() && !ValidHGraphId(hgraph_id)) {
    throw InputError("hgraph_id",
                     "must be 1 to 63 lower-case letters, digits and '-', starting with a letter "
                     "or digit, got \"" +
                         ClientText(hgraph_id) + "\"");
  }
  // The caller touched the session already; a merge that outlives the session's expiry (not
  // yet swept) still reserves, as its KeepHGraph would still keep.
  std::lock_guard lock(mutex_);
  auto it = sessions_.find(session);
  if (it == sessions_.end()) {
    throw SessionNotFound("session", "session " + session + " was deleted meanwhile");
  }
  CheckOwner(session, it->second, "session", tenant);
  Record& record = it->second;
  if (hgraph_id.empty()) {
    std::string name;
    do {
      name = session + std::string(kHGraphs) + RandomHex128();
    } while (record.names.count(name) > 0);
    record.names[name] =
        Record::HGraphEntry{.state = HGraphState::kRunning, .fingerprint = fingerprint};
    return name;
  }
  const std::string name = session + std::string(kHGraphs) + hgraph_id;
  auto known = record.names.find(name);
  if (known == record.names.end()) {
    record.names[name] =
        Record::HGraphEntry{.state = HGraphState::kRunning, .fingerprint = fingerprint};
    return name;
  }
  switch (known->second.state) {
    case HGraphState::kRunning:
      throw ServiceError(
          grpc::StatusCode::ABORTED, "MERGE_RUNNING", "hgraph_id",
          "the merge of " + name + " is still running; retry later, or poll it with GetHGraph",
          std::chrono::milliseconds(1000));
    case HGraphState::kRetired:
      throw ServiceError(grpc::StatusCode::NOT_FOUND, "HGRAPH_NOT_FOUND", "hgraph_id",
                         name +
                             " was evicted or deleted, and names are not given out twice; merge "
                             "again under a new hgraph_id");
    default: break;
  }
  if (known->second.fingerprint != fingerprint) {
    throw ServiceError(grpc::StatusCode::ALREADY_EXISTS, "ALREADY_EXISTS", "hgraph_id",
                       name + " already names an H-Graph merged from another request");
  }
  *repeat = true;
  return name;
}

void SessionRegistry::KeepHGraph(const std::string& hgraph) {
  std::lock_guard lock(mutex_);
  Record* record = RecordOf(hgraph);
  if (record == nullptr || record->names.count(hgraph) == 0) {
    throw Error(ErrorCode::kNotFound, "session",
                "the session of " + hgraph + " was deleted meanwhile");
  }
  record->names[hgraph].state = HGraphState::kKept;
  record->hgraphs.push_back(hgraph);
}

void SessionRegistry::AbandonHGraph(const std::string& hgraph) {
  std::lock_guard lock(mutex_);
  Record* record = RecordOf(hgraph);
  if (record == nullptr) return;
  auto it = record->names.find(hgraph);
  if (it != record->names.end() && it->second.state == HGraphState::kRunning) {
    record->names.erase(it);
  }
}

void SessionRegistry::RemoveHGraph(const std::string& hgraph) {
  std::lock_guard lock(mutex_);
  Record* record = RecordOf(hgraph);
  if (record == nullptr) return;
  auto it = record->names.find(hgraph);
  if (it != record->names.end()) it->second.state = HGraphState::kRetired;
  auto& list = record->hgraphs;
  list.erase(std::remove(list.begin(), list.end(), hgraph), list.end());
}

SessionRegistry::HGraphState SessionRegistry::StateOf(const std::string& hgraph) const {
  std::lock_guard lock(mutex_);
  const Record* record = RecordOf(hgraph);
  if (record == nullptr) return HGraphState::kUnknown;
  auto it = record->names.find(hgraph);
  return it == record->names.end() ? HGraphState::kUnknown : it->second.state;
}

bool SessionRegistry::Adopt(const std::string& name, const std::string& tenant,
                            const v1::Digest& scene, Clock::time_point create_time) {
  ValidateName(name, "session");
  std::lock_guard lock(mutex_);
  if (auto it = sessions_.find(name); it != sessions_.end()) {
    if (it->second.expire_time > Clock::now()) return true;
    sessions_.erase(it);
  }
  if (static_cast<int>(sessions_.size()) >= max_sessions_) return false;
  Record& record = sessions_[name];
  record.tenant = tenant;
  record.scene = scene;
  record.create_time = create_time;
  record.expire_time = Clock::now() + ttl_;
  return true;
}

bool SessionRegistry::AdoptHGraph(const std::string& hgraph, const std::string& fingerprint) {
  std::lock_guard lock(mutex_);
  Record* record = RecordOf(hgraph);
  if (record == nullptr) return false;
  auto it = record->names.find(hgraph);
  if (it != record->names.end()) return it->second.state == HGraphState::kKept;
  record->names[hgraph] =
      Record::HGraphEntry{.state = HGraphState::kKept, .fingerprint = fingerprint};
  record->hgraphs.push_back(hgraph);
  return true;
}

void SessionRegistry::ForgetHGraph(const std::string& hgraph) {
  std::lock_guard lock(mutex_);
  Record* record = RecordOf(hgraph);
  if (record == nullptr) return;
  auto it = record->names.find(hgraph);
  if (it == record->names.end() || it->second.state != HGraphState::kKept) return;
  record->names.erase(it);
  auto& list = record->hgraphs;
  list.erase(std::remove(list.begin(), list.end(), hgraph), list.end());
}

std::vector<std::pair<std::string, v1::Session>> SessionRegistry::UsedSince(
    Clock::time_point since) const {
  std::lock_guard lock(mutex_);
  std::vector<std::pair<std::string, v1::Session>> out;
  for (const auto& [name, record] : sessions_) {
    if (record.expire_time > since + ttl_) out.emplace_back(record.tenant, ToProto(name, record));
  }
  return out;
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
