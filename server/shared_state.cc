#include "server/shared_state.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cinttypes>
#include <cstdio>
#include <cstring>
#include <set>
#include <utility>

#include "core/common/client_text.h"
#include "core/common/digest.h"
#include "core/merge/snapshot.h"

namespace hgraph::server {
namespace {

constexpr char kPrefix[] = "hgraph:1:";
// An H-Graph record: this tag and its version in 16 hex digits (what compare-and-set compares),
// the SHA-256 of the rest in hex, then the fields.
// Records of another layout (HGRAPH1: before AddPaths' request ids) are refused as of another
// format.
constexpr std::string_view kHGraphTag = "HGRAPH2:";
constexpr size_t kVersionEnd = 8 + 16;
constexpr size_t kHeaderSize = kVersionEnd + 64;
constexpr std::string_view kSessionTag = "SESSION1";
// Store entries outlive a replica's own expiry of the session by this much.
constexpr std::chrono::minutes kTtlMargin{1};
constexpr std::chrono::seconds kLogInterval{10};

// A list of byte strings: a count, then each string's length and bytes (64-bit little-endian).
class Fields {
 public:
  void Add(std::string_view s) {
    Number(s.size());
    body_.append(s);
    ++count_;
  }
  void Add(const google::protobuf::Message& m) { Add(m.SerializeAsString()); }
  std::string Take() const {
    std::string out;
    AppendTo(out);
    return out;
  }
  // Appends what Take returns; with `more`, counting that many fields the caller appends.
  void AppendTo(std::string& out, uint64_t more = 0) const {
    Append(out, count_ + more);
    out += body_;
  }
  // Appends one field that `append` writes at the end of `out`: its size, then its bytes
  // (the caller's, appended there without a copy).
  template <typename F>
  static void AppendField(std::string& out, const F& append) {
    const size_t at = out.size();
    Append(out, 0);
    append(out);
    const uint64_t size = out.size() - at - 8;
    std::memcpy(out.data() + at, &size, 8);
  }
  size_t size() const { return 8 + body_.size(); }

 private:
  static void Append(std::string& out, uint64_t n) {
    char bytes[8];
    std::memcpy(bytes, &n, 8);
    out.append(bytes, 8);
  }
  void Number(uint64_t n) { Append(body_, n); }
  std::string body_;
  uint64_t count_ = 0;
};

// Splits what Fields wrote; nullopt for anything else.
std::optional<std::vector<std::string_view>> SplitFields(std::string_view in) {
  const auto number = [&](uint64_t* n) {
    if (in.size() < 8) return false;
    std::memcpy(n, in.data(), 8);
    in.remove_prefix(8);
    return true;
  };
  uint64_t count = 0;
  if (!number(&count) || count > in.size() / 8) return std::nullopt;
  std::vector<std::string_view> fields;
  for (uint64_t i = 0; i < count; ++i) {
    uint64_t size = 0;
    if (!number(&size) || size > in.size()) return std::nullopt;
    fields.push_back(in.substr(0, size));
    in.remove_prefix(size);
  }
  if (!in.empty()) return std::nullopt;
  return fields;
}

std::string Hex16(uint64_t v) {
  char text[17];
  std::snprintf(text, sizeof(text), "%016" PRIx64, v);
  return text;
}

std::optional<uint64_t> ParseHex16(std::string_view text) {
  if (text.size() != 16) return std::nullopt;
  uint64_t v = 0;
  for (char c : text) {
    int d = 0;
    if (c >= '0' && c <= '9') {
      d = c - '0';
    } else if (c >= 'a' && c <= 'f') {
      d = c - 'a' + 10;
    } else {
      return std::nullopt;
    }
    v = v * 16 + static_cast<uint64_t>(d);
  }
  return v;
}

std::optional<int64_t> ParseInt(std::string_view text) {
  if (text.empty() || text.size() > 19) return std::nullopt;
  int64_t v = 0;
  for (char c : text) {
    if (c < '0' || c > '9') return std::nullopt;
    v = v * 10 + (c - '0');
  }
  return v;
}

template <typename Message>
bool ParseMessage(std::string_view bytes, Message* out) {
  return out->ParseFromArray(bytes.data(), static_cast<int>(bytes.size()));
}

}  // namespace

std::string SharedState::BlobKey(const std::string& sha256) {
  return std::string(kPrefix) + "blob:" + sha256;
}
std::string SharedState::SceneKey(const std::string& sha256) {
  return std::string(kPrefix) + "scene:" + sha256;
}
// "sessions/<id>" -> "hgraph:1:session:<id>"
std::string SharedState::SessionKey(const std::string& session) {
  return std::string(kPrefix) + "session:" + session.substr(std::strlen("sessions/"));
}
// "sessions/<id>/hgraphs/<h>" -> "hgraph:1:hgraph:<id>:<h>"
std::string SharedState::HGraphKey(const std::string& hgraph) {
  const size_t at = hgraph.find("/hgraphs/");
  const std::string session =
      hgraph.substr(std::strlen("sessions/"), at - std::strlen("sessions/"));
  return std::string(kPrefix) + "hgraph:" + session + ":" +
         hgraph.substr(at + std::strlen("/hgraphs/"));
}

std::string SharedState::TenantSessionsKey(const std::string& tenant) {
  return std::string(kPrefix) + "tenant:" + Sha256Hex(tenant) + ":sessions";
}
// "sessions/<id>" -> "hgraph:1:session-hgraphs:<id>"
std::string SharedState::SessionHGraphsKey(const std::string& session) {
  return std::string(kPrefix) + "session-hgraphs:" + session.substr(std::strlen("sessions/"));
}

SharedState::SharedState(std::shared_ptr<Store> store, std::chrono::milliseconds ttl,
                         ServiceMetrics& metrics)
    : store_(std::move(store)), ttl_(ttl + kTtlMargin), metrics_(metrics) {}

void SharedState::Failed(const char* op, const std::string& what) {
  healthy_ = false;
  metrics_.store_errors.Increment({{"op", op}});
  const auto now = std::chrono::steady_clock::now();
  std::lock_guard lock(log_mutex_);
  if (last_log_ != std::chrono::steady_clock::time_point{} && now - last_log_ < kLogInterval) {
    ++unlogged_;
    return;
  }
  spdlog::warn(
      "store {}: {} failed: {} ({} more failures since the last line); serving from memory",
      store_->Describe(), op, what, unlogged_);
  last_log_ = now;
  unlogged_ = 0;
}

void SharedState::Succeeded() {
  if (healthy_.exchange(true)) return;
  spdlog::info("store {}: answering again", store_->Describe());
}

void SharedState::Refused(const char* kind, const std::string& key, const std::string& why) {
  metrics_.store_refused.Increment({{"kind", kind}});
  spdlog::warn("store {}: refused the {} under {}: {}", store_->Describe(), kind, ClientText(key),
               why);
}

void SharedState::PutBlob(const std::string& sha256, const std::string& bytes) {
  try {
    store_->Set(BlobKey(sha256), bytes, ttl_);
    Succeeded();
  } catch (const StoreError& e) {
    Failed("put_blob", e.what());
  }
}

bool SharedState::HasBlob(const v1::Digest& digest) {
  try {
    const bool held = store_->Exists(BlobKey(digest.sha256()));
    Succeeded();
    return held;
  } catch (const StoreError& e) {
    Failed("has_blob", e.what());
    return false;
  }
}

std::optional<std::string> SharedState::GetBlob(const v1::Digest& digest) {
  std::optional<std::string> bytes;
  const std::string key = BlobKey(digest.sha256());
  try {
    bytes = store_->Get(key);
    Succeeded();
  } catch (const StoreError& e) {
    Failed("get_blob", e.what());
    return std::nullopt;
  }
  if (!bytes) return std::nullopt;
  if (static_cast<int64_t>(bytes->size()) != digest.size_bytes() ||
      Sha256Hex(*bytes) != digest.sha256()) {
    Refused("blob", key, "its bytes do not match the digest");
    return std::nullopt;
  }
  metrics_.store_loads.Increment({{"kind", "blob"}});
  return bytes;
}

void SharedState::PutScene(const v1::Digest& digest, const std::string& canonical_bytes) {
  try {
    store_->Set(SceneKey(digest.sha256()), canonical_bytes, ttl_);
    Succeeded();
  } catch (const StoreError& e) {
    Failed("put_scene", e.what());
  }
}

std::optional<v1::Scene> SharedState::GetScene(const v1::Digest& digest) {
  std::optional<std::string> bytes;
  const std::string key = SceneKey(digest.sha256());
  try {
    bytes = store_->Get(key);
    Succeeded();
  } catch (const StoreError& e) {
    Failed("get_scene", e.what());
    return std::nullopt;
  }
  if (!bytes) return std::nullopt;
  v1::Scene scene;
  if (Sha256Hex(*bytes) != digest.sha256() || !ParseMessage(*bytes, &scene)) {
    Refused("scene", key, "its bytes do not match the digest");
    return std::nullopt;
  }
  metrics_.store_loads.Increment({{"kind", "scene"}});
  return scene;
}

void SharedState::PutSession(const std::string& name, const SessionRecord& record) {
  Fields fields;
  fields.Add(record.tenant);
  fields.Add(record.scene.sha256());
  fields.Add(std::to_string(record.scene.size_bytes()));
  fields.Add(std::to_string(record.create_time_ns));
  try {
    store_->Set(SessionKey(name), std::string(kSessionTag) + fields.Take(), ttl_);
    store_->AddMember(TenantSessionsKey(record.tenant), name, ttl_);
    Succeeded();
  } catch (const StoreError& e) {
    Failed("put_session", e.what());
  }
}

std::optional<SessionRecord> SharedState::GetSession(const std::string& name) {
  std::optional<std::string> bytes;
  const std::string key = SessionKey(name);
  try {
    bytes = store_->Get(key);
    Succeeded();
  } catch (const StoreError& e) {
    Failed("get_session", e.what());
    return std::nullopt;
  }
  if (!bytes) return std::nullopt;
  std::optional<SessionRecord> record = ParseSession(key, *bytes);
  if (record) metrics_.store_loads.Increment({{"kind", "session"}});
  return record;
}

std::optional<SessionRecord> SharedState::ParseSession(const std::string& key,
                                                       std::string_view value) {
  std::optional<std::vector<std::string_view>> fields;
  if (value.starts_with(kSessionTag)) fields = SplitFields(value.substr(kSessionTag.size()));
  std::optional<int64_t> size;
  std::optional<int64_t> created;
  if (fields && fields->size() == 4) {
    size = ParseInt((*fields)[2]);
    created = ParseInt((*fields)[3]);
  }
  if (!size || !created || !IsSha256Hex((*fields)[1])) {
    Refused("session", key, "not a session record of this format");
    return std::nullopt;
  }
  SessionRecord record;
  record.tenant = std::string((*fields)[0]);
  record.scene.set_sha256(std::string((*fields)[1]));
  record.scene.set_size_bytes(*size);
  record.create_time_ns = *created;
  return record;
}

std::optional<std::map<std::string, SessionRecord>> SharedState::ListSessions(
    const std::string& tenant) {
  const std::string list_key = TenantSessionsKey(tenant);
  std::vector<std::string> names;
  std::vector<std::optional<std::string>> values;
  try {
    for (std::string& name : store_->Members(list_key)) {
      // Only names of the form this server writes ("sessions/<id>", one level).
      if (name.starts_with("sessions/") && name.size() > std::strlen("sessions/") &&
          name.find('/', std::strlen("sessions/")) == std::string::npos) {
        names.push_back(std::move(name));
      }
    }
    std::vector<std::string> keys;
    for (const std::string& name : names) keys.push_back(SessionKey(name));
    values = store_->GetMany(keys);
    Succeeded();
  } catch (const StoreError& e) {
    Failed("list_sessions", e.what());
    return std::nullopt;
  }
  std::map<std::string, SessionRecord> out;
  std::vector<std::string> gone;
  for (size_t i = 0; i < names.size(); ++i) {
    if (!values[i]) {
      gone.push_back(names[i]);  // expired, or deleted
      continue;
    }
    std::optional<SessionRecord> record = ParseSession(SessionKey(names[i]), *values[i]);
    // Another tenant's record in this tenant's list: not listed.
    if (record && record->tenant == tenant) out.emplace(names[i], std::move(*record));
  }
  if (!gone.empty()) {
    try {
      store_->RemoveMembers(list_key, gone);
    } catch (const StoreError& e) {
      Failed("list_sessions", e.what());
    }
  }
  return out;
}

std::vector<std::string> SharedState::HGraphsOf(const std::string& session) {
  std::vector<std::string> out;
  try {
    for (std::string& name : store_->Members(SessionHGraphsKey(session))) {
      // Only this session's H-Graphs, whatever the set holds.
      if (name.starts_with(session + "/hgraphs/") &&
          name.size() > session.size() + std::strlen("/hgraphs/")) {
        out.push_back(std::move(name));
      }
    }
    Succeeded();
  } catch (const StoreError& e) {
    Failed("list_hgraphs", e.what());
    return {};
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::optional<std::chrono::milliseconds> SharedState::SessionTimeToLive(
    const std::string& session) {
  try {
    std::optional<std::chrono::milliseconds> ttl = store_->TimeToLive(SessionKey(session));
    Succeeded();
    if (!ttl) return std::nullopt;
    return std::max(*ttl - std::chrono::duration_cast<std::chrono::milliseconds>(kTtlMargin),
                    std::chrono::milliseconds(0));
  } catch (const StoreError& e) {
    Failed("get_session", e.what());
    return std::nullopt;
  }
}

void SharedState::DeleteSession(const std::string& name, const std::string& tenant,
                                const std::vector<std::string>& hgraphs) {
  std::set<std::string> all(hgraphs.begin(), hgraphs.end());
  for (std::string& h : HGraphsOf(name)) all.insert(std::move(h));
  std::vector<std::string> keys = {SessionKey(name), SessionHGraphsKey(name)};
  for (const std::string& h : all) keys.push_back(HGraphKey(h));
  try {
    store_->Delete(keys);
    store_->RemoveMembers(TenantSessionsKey(tenant), {name});
    Succeeded();
  } catch (const StoreError& e) {
    Failed("delete", e.what());
  }
}

void SharedState::DeleteHGraph(const std::string& hgraph) {
  try {
    store_->Delete({HGraphKey(hgraph)});
    store_->RemoveMembers(SessionHGraphsKey(hgraph.substr(0, hgraph.find("/hgraphs/"))), {hgraph});
    Succeeded();
  } catch (const StoreError& e) {
    Failed("delete", e.what());
  }
}

void SharedState::Refresh(const std::string& session, const std::string& tenant,
                          const std::vector<std::string>& hgraphs, const v1::Digest& scene,
                          const std::vector<std::string>& blob_sha256s) {
  std::vector<std::string> keys = {SessionKey(session), SessionHGraphsKey(session),
                                   SceneKey(scene.sha256())};
  for (const std::string& h : hgraphs) keys.push_back(HGraphKey(h));
  for (const std::string& b : blob_sha256s) keys.push_back(BlobKey(b));
  try {
    store_->Expire(keys, ttl_);
    store_->AddMember(TenantSessionsKey(tenant), session, ttl_);
    Succeeded();
  } catch (const StoreError& e) {
    Failed("refresh", e.what());
  }
}

std::string SharedState::EncodeHGraph(const HGraphRecord& record, uint64_t version,
                                      const HybridizationSession* session) {
  Fields names;
  for (const std::string& n : record.input_names) names.Add(n);
  Fields fields;
  fields.Add(record.name);
  fields.Add(record.tenant);
  fields.Add(record.scene.sha256());
  fields.Add(std::to_string(record.scene.size_bytes()));
  fields.Add(std::string_view(reinterpret_cast<const char*>(&record.resolution), 8));
  fields.Add(std::to_string(record.generation));
  fields.Add(record.measure);
  fields.Add(record.options);
  fields.Add(record.fingerprint);
  fields.Add(record.answer);
  fields.Add(names.Take());
  Fields requests;
  for (const HGraphRecord::Request& r : record.requests) {
    Fields request;
    request.Add(r.id);
    request.Add(r.fingerprint);
    request.Add(r.answer);
    requests.Add(request.Take());
  }
  fields.Add(requests.Take());
  // The header, its checksum left for PutHGraph; then the fields, the snapshot last, written
  // in place.
  std::string value;
  value.reserve(kHeaderSize + fields.size() + 8 + (session ? 0 : record.session.size()));
  value.append(kHGraphTag).append(Hex16(version)).append(kHeaderSize - kVersionEnd, '0');
  fields.AppendTo(value, 1);
  Fields::AppendField(value, [&](std::string& out) {
    if (session != nullptr) {
      AppendSession(*session, &out);
    } else {
      out += record.session;
    }
  });
  return value;
}

SharedState::Write SharedState::PutHGraph(const HGraphRecord& record, uint64_t expected_version,
                                          uint64_t version) {
  std::string value = EncodeHGraph(record, version);
  return PutHGraph(record.name, value, expected_version);
}

SharedState::Write SharedState::PutHGraph(const std::string& name, std::string& value,
                                          uint64_t expected_version) {
  value.replace(kVersionEnd, kHeaderSize - kVersionEnd,
                Sha256Hex(std::string_view(value).substr(kHeaderSize)));
  const std::string key = HGraphKey(name);
  try {
    bool stored = true;
    if (expected_version == 0) {
      store_->Set(key, value, ttl_);
      // Listed under its session, so that deleting the session on any replica deletes it.
      store_->AddMember(SessionHGraphsKey(name.substr(0, name.find("/hgraphs/"))), name, ttl_);
    } else {
      stored =
          store_->SetIfPrefix(key, std::string(kHGraphTag) + Hex16(expected_version), value, ttl_);
    }
    Succeeded();
    return stored ? Write::kStored : Write::kConflict;
  } catch (const StoreError& e) {
    Failed("put_hgraph", e.what());
    return Write::kFailed;
  }
}

uint64_t SharedState::HGraphVersion(const std::string& name) {
  std::optional<std::string> head;
  try {
    head = store_->GetPrefix(HGraphKey(name), kVersionEnd);
    Succeeded();
  } catch (const StoreError& e) {
    Failed("get_hgraph", e.what());
    return 0;
  }
  if (!head || !head->starts_with(kHGraphTag) || head->size() != kVersionEnd) return 0;
  return ParseHex16(std::string_view(*head).substr(kHGraphTag.size())).value_or(0);
}

std::optional<std::pair<uint64_t, HGraphRecord>> SharedState::GetHGraph(const std::string& name) {
  std::optional<std::string> bytes;
  const std::string key = HGraphKey(name);
  try {
    bytes = store_->Get(key);
    Succeeded();
  } catch (const StoreError& e) {
    Failed("get_hgraph", e.what());
    return std::nullopt;
  }
  if (!bytes) return std::nullopt;
  const std::string_view value(*bytes);
  if (value.size() < kHeaderSize || !value.starts_with(kHGraphTag)) {
    Refused("hgraph", key, "not an H-Graph record of this format (or truncated)");
    return std::nullopt;
  }
  const std::optional<uint64_t> version =
      ParseHex16(value.substr(kHGraphTag.size(), kVersionEnd - kHGraphTag.size()));
  const std::string_view body = value.substr(kHeaderSize);
  if (!version || *version == 0 ||
      Sha256Hex(body) != value.substr(kVersionEnd, kHeaderSize - kVersionEnd)) {
    Refused("hgraph", key, "its checksum does not match (corrupt or truncated)");
    return std::nullopt;
  }
  const auto fields = SplitFields(body);
  HGraphRecord record;
  std::optional<int64_t> size;
  std::optional<int64_t> generation;
  std::optional<std::vector<std::string_view>> names;
  std::optional<std::vector<std::string_view>> requests;
  if (fields && fields->size() == 13) {
    const auto& f = *fields;
    record.name = std::string(f[0]);
    record.tenant = std::string(f[1]);
    record.scene.set_sha256(std::string(f[2]));
    size = ParseInt(f[3]);
    if (f[4].size() == 8) std::memcpy(&record.resolution, f[4].data(), 8);
    generation = ParseInt(f[5]);
    names = SplitFields(f[10]);
    requests = SplitFields(f[11]);
    bool requests_parse = requests.has_value();
    for (size_t i = 0; requests_parse && i < requests->size(); ++i) {
      const auto request = SplitFields((*requests)[i]);
      HGraphRecord::Request& r = record.requests.emplace_back();
      requests_parse = request && request->size() == 3 && ParseMessage((*request)[2], &r.answer);
      if (requests_parse) {
        r.id = std::string((*request)[0]);
        r.fingerprint = std::string((*request)[1]);
      }
    }
    if (size && generation && names && requests_parse && f[4].size() == 8 && IsSha256Hex(f[2]) &&
        ParseMessage(f[6], &record.measure) && ParseMessage(f[7], &record.options) &&
        ParseMessage(f[9], &record.answer)) {
      record.scene.set_size_bytes(*size);
      record.generation = *generation;
      record.fingerprint = std::string(f[8]);
      for (std::string_view n : *names) record.input_names.emplace_back(n);
      // The snapshot, the last field (it ends the value): kept in the value's own buffer, not
      // copied. The views into the value are not used after this.
      bytes->erase(0, static_cast<size_t>(f[12].data() - bytes->data()));
      record.session = std::move(*bytes);
    } else {
      size.reset();
    }
  }
  if (!size) {
    Refused("hgraph", key, "its fields do not parse");
    return std::nullopt;
  }
  if (record.name != name) {
    Refused("hgraph", key, "it names another H-Graph (" + ClientText(record.name) + ")");
    return std::nullopt;
  }
  metrics_.store_loads.Increment({{"kind", "hgraph"}});
  return std::make_pair(*version, std::move(record));
}

}  // namespace hgraph::server
