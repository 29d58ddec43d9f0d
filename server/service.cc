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
      cache_(options.cache_bytes),
      scenes_(cache_, metrics, MeshImporter(options.mesh_import)),
      sessions_(options.max_sessions, options.session_ttl),
      pool_(options.threads, options.max_admitted) {
  metrics_.DeclareCounter("grpc_server_started_total", "RPCs started on the server.");
  metrics_.DeclareCounter("grpc_server_handled_total",
                          "RPCs completed on the server, regardless of success or failure.");
  metrics_.DeclareHistogram(
      "grpc_server_handling_seconds", "Response latency of RPCs handled by the server, in seconds.",
      {0.001, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1, 2.5, 5, 10, 30, 60, 300});
  metrics_.DeclareCounter("hgraph_merges_total", "Merges and re-queries that returned a result.");
  metrics_.DeclareCounter(
      "hgraph_merge_collision_checks_total",
      "Collision checks run by merges, re-queries and path checks (by method).");
  metrics_.DeclareCounter(
      "hgraph_merge_distance_queries_total",
      "Distance (clearance) queries run by merges, re-queries and path checks.");
  metrics_.DeclareCounter(
      "hgraph_merge_edges_checked_total",
      "Local-planner runs (input edges, bridges, clearance re-checks, checked paths).");
  metrics_.DeclareCounter("hgraph_merge_edges_reused_total",
                          "Stored edge reports that served a re-query without a new check.");
  metrics_.DeclareHistogram("hgraph_merge_phase_seconds", "Wall time of each merge phase.",
                            {0.001, 0.01, 0.1, 0.5, 1, 5, 10, 60, 300});
  metrics_.DeclareCounter("hgraph_scene_cache_hits_total",
                          "Scene lookups served by an already loaded collision world.");
  metrics_.DeclareCounter("hgraph_scene_cache_misses_total",
                          "Scene lookups that had to load meshes and build BVHs.");
  metrics_.DeclareCounter("hgraph_scene_loads_total", "Scenes loaded and BVH-built.");
  metrics_.DeclareGauge("hgraph_cache_bytes", "Bytes held in the cache, by kind.");
  metrics_.DeclareGauge("hgraph_cache_budget_bytes", "The cache's budget (--cache-bytes).");
  metrics_.DeclareCounter("hgraph_cache_evictions_total", "Cache entries evicted, by kind.");
  metrics_.DeclareGauge("hgraph_sessions", "Live sessions.");
  metrics_.DeclareGauge("hgraph_admitted_calls", "Calls queued or running on the worker pool.");
  metrics_.AddCollector([this] {
    for (CacheKind kind :
         {CacheKind::kBlob, CacheKind::kScene, CacheKind::kWorld, CacheKind::kHGraph}) {
      const Labels labels = {{"kind", CacheKindName(kind)}};
      metrics_.Set("hgraph_cache_bytes", labels, static_cast<double>(cache_.bytes(kind)));
      metrics_.Set("hgraph_cache_evictions_total", labels,
                   static_cast<double>(cache_.evictions(kind)));
    }
    metrics_.Set("hgraph_cache_budget_bytes", {}, static_cast<double>(cache_.budget_bytes()));
    metrics_.Set("hgraph_sessions", {}, sessions_.size());
    metrics_.Set("hgraph_admitted_calls", {}, pool_.admitted());
  });
  // An evicted H-Graph disappears from its session's listing.
  cache_.SetEvictionListener([this](CacheKind kind, const std::string& key) {
    if (kind == CacheKind::kHGraph) sessions_.RemoveHGraph(key);
    spdlog::info("cache evicted {} {}", CacheKindName(kind), key);
  });
}

PathMergerService::~PathMergerService() { pool_.WaitIdle(); }

void PathMergerService::DropHGraphs(const std::vector<std::string>& names) {
  for (const std::string& name : names) cache_.Erase(CacheKind::kHGraph, name);
}

void PathMergerService::ExpireIdleSessions() {
  const std::vector<std::string> dropped = sessions_.ExpireIdle(SessionRegistry::Clock::now());
  if (!dropped.empty()) spdlog::info("expired sessions dropped {} H-Graphs", dropped.size());
  DropHGraphs(dropped);
}

}  // namespace hgraph::server
