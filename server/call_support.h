// What every call of the PathMerger service shares: the mapping of engine errors to canonical
// statuses, the call's deadline on its cancel token, the "busy" answer of a full worker pool,
// and the H-Graphs kept for re-queries. Internal to server/ (the handlers include it).
#pragma once

#include <grpcpp/grpcpp.h>

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>

#include "core/common/error.h"
#include "core/common/progress.h"
#include "core/merge/merge.h"
#include "core/motion/local_planner.h"
#include "hgraph/v1/service.pb.h"
#include "server/scene_store.h"
#include "server/service.h"
#include "server/status/status.h"
#include "server/worker_pool.h"

namespace hgraph::server {

using Clock = std::chrono::steady_clock;

// Runs `body` and turns whatever it throws into a canonical status. A cancellation that comes
// from the passed deadline (gRPC cancels the call at the deadline too) is DEADLINE_EXCEEDED.
grpc::Status Invoke(const std::function<void()>& body, const CancelToken& token);

// The call's deadline, if any, on the token (the engine polls it).
void WireDeadline(grpc::CallbackServerContext* context, const CancelToken& token);

// RESOURCE_EXHAUSTED: the worker pool's admission queue is full.
grpc::Status Busy(const WorkerPool& pool);

// Checks a batch against the server's limits (--max-paths, --max-waypoints) before any work.
void CheckBatchLimits(const v1::PathSet& paths, const ServerOptions& options);

// An H-Graph kept for re-queries, with the local planner its edges were checked with.
struct PathMergerService::StoredHGraph {
  std::mutex mutex;         // guards session and version
  std::mutex adding_mutex;  // held by an AddPaths for its whole call: additions never race
  LoadedScene scene;
  std::unique_ptr<LocalPlanner> planner;
  std::unique_ptr<HybridizationSession> session;
  uint64_t version = 0;  // bumped each time a query's copy replaces `session`
};

// Searches a stored H-Graph under `measure` (Requery) without holding it: the query runs on a
// copy taken under the mutex, and the copy, with the edges the query checked, replaces the
// stored session if no other query did so meanwhile (else its checks are dropped; the answer
// stands either way). The copy costs memory for the length of the query, not the H-Graph's
// lock for every other caller.
// `report_clearance`: HybridizationSession::Query's.
MergeResult QueryStored(PathMergerService::StoredHGraph& stored, const MeasureSpec& measure,
                        const ProgressCallback& progress, const CancelToken& token,
                        std::optional<bool> report_clearance = std::nullopt);

// Adds paths to a stored H-Graph and searches it (AddPaths), on a copy as QueryStored does; the
// copy replaces the stored session whatever queries did meanwhile (their checks are dropped,
// the added paths never are). Returns the bridge candidates added through `candidates_added`.
// A Requery's or AddPaths' report_clearance: this query's, if the request sets it.
template <typename Request>
std::optional<bool> ReportClearance(const Request& request) {
  if (!request.has_report_clearance()) return std::nullopt;
  return request.report_clearance();
}

MergeResult AddToStored(PathMergerService::StoredHGraph& stored,
                        const std::vector<InputPath>& paths, const MeasureSpec& measure,
                        const CancelToken& token, int64_t* candidates_added,
                        std::optional<bool> report_clearance = std::nullopt);

}  // namespace hgraph::server
