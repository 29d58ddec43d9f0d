// PathMergerService: construction (the metric families, the cache's eviction listener) and the
// session expiry. Each call kind lives in its own file: unary_handlers.cc, upload_call.cc,
// merge_call.cc, plan_call.cc; what they share is in call_support.{h,cc}.
#include "server/service.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "core/common/client_text.h"
#include "core/merge/snapshot.h"
#include "server/call_support.h"

namespace hgraph::server {

PathMergerService::PathMergerService(const ServerOptions& options, Metrics& metrics)
    : options_(options),
      metrics_(metrics),
      families_(metrics),
      cache_(options.cache_bytes),
      shared_(options.store
                  ? std::make_unique<SharedState>(options.store, options.session_ttl, families_)
                  : nullptr),
      scenes_(cache_, families_, MeshImporter(options.mesh_import), options.clearance_bound,
              shared_.get()),
      sessions_(options.max_sessions, options.session_ttl, options.tenant_max_sessions),
      pool_(options.threads, options.max_admitted) {
  metrics_.AddCollector([this] {
    for (CacheKind kind :
         {CacheKind::kBlob, CacheKind::kScene, CacheKind::kWorld, CacheKind::kHGraph}) {
      const Labels labels = {{"kind", CacheKindName(kind)}};
      families_.cache_bytes.Set(labels, static_cast<double>(cache_.bytes(kind)));
      families_.cache_evictions.Set(labels, static_cast<double>(cache_.evictions(kind)));
    }
    families_.cache_bytes.Set({{"kind", "upload"}}, static_cast<double>(cache_.reserved_bytes()));
    families_.cache_budget_bytes.Set({}, static_cast<double>(cache_.budget_bytes()));
    families_.sessions.Set({}, sessions_.size());
    families_.admitted_calls.Set({}, pool_.admitted());
  });
  // An evicted H-Graph disappears from its session's listing; with a shared store it is only
  // forgotten here, so that a later call loads it again.
  cache_.SetEvictionListener([this](CacheKind kind, const std::string& key) {
    if (kind == CacheKind::kHGraph) {
      if (shared_) {
        sessions_.ForgetHGraph(key);
      } else {
        sessions_.RemoveHGraph(key);
      }
    }
    spdlog::info("cache evicted {} {}", CacheKindName(kind), key);
  });
  SetMessageAllocatorFor_GetHGraph(&get_hgraph_messages_);
  SetMessageAllocatorFor_Requery(&requery_messages_);
  SetMessageAllocatorFor_AddPaths(&add_paths_messages_);
}

PathMergerService::~PathMergerService() { pool_.WaitIdle(); }

void PathMergerService::DropHGraphs(const std::vector<std::string>& names) {
  for (const std::string& name : names) cache_.Erase(CacheKind::kHGraph, name);
}

void PathMergerService::BeginShutdown() {
  std::lock_guard lock(durable_mutex_);
  shutting_down_ = true;
  for (const auto& [id, token] : durable_) token.Cancel();
}

bool PathMergerService::AddDurable(const CancelToken& token, uint64_t* id) {
  std::lock_guard lock(durable_mutex_);
  if (shutting_down_) return false;
  *id = next_durable_++;
  durable_.emplace(*id, token);
  return true;
}

void PathMergerService::RemoveDurable(uint64_t id) {
  std::lock_guard lock(durable_mutex_);
  durable_.erase(id);
}

void PathMergerService::ExpireIdleSessions() {
  const std::vector<std::string> dropped = sessions_.ExpireIdle(SessionRegistry::Clock::now());
  if (!dropped.empty()) spdlog::info("expired sessions dropped {} H-Graphs", dropped.size());
  DropHGraphs(dropped);
}

void PathMergerService::CheckTenantCache(const std::string& tenant) {
  if (options_.tenant_cache_bytes == 0) return;
  size_t held = 0;
  for (const v1::Session& session : sessions_.List(tenant)) {
    for (const std::string& hgraph : session.hgraphs()) {
      held += cache_.BytesOf(CacheKind::kHGraph, hgraph);
    }
  }
  if (held >= options_.tenant_cache_bytes) {
    throw ServiceError(grpc::StatusCode::RESOURCE_EXHAUSTED, "TENANT_QUOTA", "",
                       "this tenant's H-Graphs hold " + std::to_string(held) +
                           " bytes, its quota (--tenant-cache-bytes=" +
                           std::to_string(options_.tenant_cache_bytes) +
                           "); delete H-Graphs or sessions it no longer needs");
  }
}

v1::Session PathMergerService::TouchSession(const std::string& name, const std::string& field,
                                            const std::string& tenant) {
  try {
    return sessions_.Touch(name, field, tenant);
  } catch (const Error& e) {
    if (!shared_ || e.code() != ErrorCode::kNotFound) throw;
    std::optional<SessionRecord> record = shared_->GetSession(name);
    if (!record) throw;
    const auto created = SessionRegistry::Clock::time_point(
        std::chrono::duration_cast<SessionRegistry::Clock::duration>(
            std::chrono::nanoseconds(record->create_time_ns)));
    if (!sessions_.Adopt(name, record->tenant, record->scene, created)) {
      throw Error(ErrorCode::kResourceExhausted, field,
                  std::to_string(sessions_.size()) +
                      " sessions exist here, the limit (--max-sessions); " + ClientText(name) +
                      " is held by the shared store but cannot be taken on");
    }
    spdlog::info("session {} loaded from the store", ClientText(name));
    // Another tenant's: PERMISSION_DENIED, as on the replica that created it.
    return sessions_.Touch(name, field, tenant);
  }
}

std::shared_ptr<PathMergerService::StoredHGraph> PathMergerService::LoadHGraph(
    const std::string& name, const std::string& tenant, const std::string& field,
    const std::function<void(StoredHGraph&)>& first_use) {
  if (!shared_) return nullptr;
  std::unique_lock loading(hgraph_loading_mutex_);
  auto got = shared_->GetHGraph(name);
  if (!got) return nullptr;
  auto& [version, record] = *got;
  if (record.tenant != tenant) {
    // The session check passed, so the record is not this session's owner's: foreign.
    families_.store_refused.Increment({{"kind", "hgraph"}});
    spdlog::warn("store: refused {}: its record names another tenant than its session",
                 ClientText(name));
    return nullptr;
  }
  LoadedScene scene = scenes_.Get(record.scene, field);
  auto stored = std::make_shared<StoredHGraph>();
  stored->scene = scene;
  stored->resolution = record.resolution;
  stored->planner = std::make_unique<LocalPlanner>(
      scene.world, LocalPlannerOptions{.resolution = record.resolution,
                                       .clearance_bound = scene.clearance_bound});
  try {
    stored->session =
        std::make_unique<HybridizationSession>(LoadSession(*stored->planner, record.session));
  } catch (const SnapshotError& e) {
    families_.store_refused.Increment({{"kind", "hgraph"}});
    spdlog::warn("store: refused {}: {}", ClientText(name), e.what());
    return nullptr;
  }
  stored->generation = record.generation;
  stored->store_version = version;
  stored->scene_digest = record.scene;
  stored->tenant = tenant;
  stored->measure = std::move(record.measure);
  stored->options = std::move(record.options);
  stored->fingerprint = std::move(record.fingerprint);
  stored->answer = std::move(record.answer);
  stored->input_names = std::move(record.input_names);
  for (HGraphRecord::Request& r : record.requests) {
    stored->requests.emplace_back(std::move(r.id),
                                  std::make_pair(std::move(r.fingerprint), std::move(r.answer)));
  }
  if (first_use) {
    // Not yet reachable by any other call: no copy to search, no lock held meanwhile. A call
    // that asks for it meanwhile loads it too; the last to finish stays in the cache.
    loading.unlock();
    first_use(*stored);
  }
  const size_t bytes = stored->session->memory_bytes();
  // Replaces a stale copy held here (another replica changed it since).
  if (!cache_.Put(CacheKind::kHGraph, name, stored, bytes)) {
    spdlog::warn("store: {} of {} bytes exceeds --cache-bytes; not loaded", ClientText(name),
                 bytes);
    return nullptr;
  }
  if (!sessions_.AdoptHGraph(name, stored->fingerprint)) {
    cache_.Erase(CacheKind::kHGraph, name);
    return nullptr;
  }
  spdlog::info("{} loaded from the store (version {}, generation {}, {} edges)", ClientText(name),
               version, stored->generation, stored->session->graph().num_edges());
  return stored;
}

SharedState::Write PathMergerService::SaveHGraph(const std::string& name, StoredHGraph& stored,
                                                 bool cas) {
  if (!shared_) return SharedState::Write::kStored;
  HGraphRecord record;
  record.name = name;
  record.tenant = stored.tenant;
  record.resolution = stored.resolution;
  record.measure = stored.measure;
  record.options = stored.options;
  record.fingerprint = stored.fingerprint;
  record.answer = stored.answer;
  record.scene = stored.scene_digest;
  // The caller holds stored.requests_mutex, or no other call can reach `stored` yet.
  for (const auto& [id, first] : stored.requests) {
    record.requests.push_back({.id = id, .fingerprint = first.first, .answer = first.second});
  }
  uint64_t expected = 0;
  std::string value;
  {
    // The snapshot is written into the record's value under the lock; its checksum and the
    // write to the store go on without it.
    std::lock_guard lock(stored.mutex);
    record.generation = stored.generation;
    record.input_names = stored.input_names;
    expected = stored.store_version;
    value = SharedState::EncodeHGraph(record, expected + 1, stored.session.get());
  }
  const SharedState::Write write = shared_->PutHGraph(name, value, cas ? expected : 0);
  if (write == SharedState::Write::kStored) {
    std::lock_guard lock(stored.mutex);
    // A requery may have replaced the session meanwhile: its checks go with the next write.
    if (stored.store_version == expected) stored.store_version = expected + 1;
  }
  return write;
}

void PathMergerService::SyncStore() {
  if (!shared_) return;
  std::set<std::string> names;
  {
    std::lock_guard lock(store_mutex_);
    names.swap(unsynced_);
  }
  for (const std::string& name : names) {
    const auto stored = cache_.Get<StoredHGraph>(CacheKind::kHGraph, name);
    if (!stored) continue;
    // Not while an AddPaths runs (it holds this lock from its look-up to its own write).
    std::lock_guard adding(stored->requests_mutex);
    const SharedState::Write write = SaveHGraph(name, *stored, /*cas=*/true);
    if (write == SharedState::Write::kFailed) {
      std::lock_guard lock(store_mutex_);
      unsynced_.insert(name);
    }
    // kConflict: another replica wrote a newer version; these checks only saved work.
  }
  // Expiry: refreshed a few times per time-to-live for the sessions used since the last time.
  const auto now = SessionRegistry::Clock::now();
  const auto interval =
      std::max<std::chrono::milliseconds>(options_.session_ttl / 10, std::chrono::seconds(1));
  if (now - last_refresh_ < interval) return;
  const auto since = last_refresh_ == SessionRegistry::Clock::time_point{}
                         ? now - options_.session_ttl
                         : last_refresh_;
  last_refresh_ = now;
  for (const auto& [tenant, session] : sessions_.UsedSince(since)) {
    shared_->Refresh(session.name(), tenant,
                     std::vector<std::string>(session.hgraphs().begin(), session.hgraphs().end()),
                     session.scene(), scenes_.BlobsOf(session.scene()));
  }
}

}  // namespace hgraph::server
