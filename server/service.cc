// PathMergerService: construction (the metric families, the cache's eviction listener) and the
// session expiry. Each call kind lives in its own file: unary_handlers.cc, upload_call.cc,
// merge_call.cc, plan_call.cc; what they share is in call_support.{h,cc}.
#include "server/service.h"

#include <spdlog/spdlog.h>

#include <string>
#include <vector>

#include "server/call_support.h"

namespace hgraph::server {

PathMergerService::PathMergerService(const ServerOptions& options, Metrics& metrics)
    : options_(options),
      metrics_(metrics),
      families_(metrics),
      cache_(options.cache_bytes),
      scenes_(cache_, families_, MeshImporter(options.mesh_import), options.clearance_bound),
      sessions_(options.max_sessions, options.session_ttl),
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
  // An evicted H-Graph disappears from its session's listing.
  cache_.SetEvictionListener([this](CacheKind kind, const std::string& key) {
    if (kind == CacheKind::kHGraph) sessions_.RemoveHGraph(key);
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

}  // namespace hgraph::server
