#include "server/call_support.h"

#include <spdlog/spdlog.h>

#include <new>
#include <string>
#include <utility>

#include "core/common/client_text.h"

namespace hgraph::server {
namespace {

constexpr char kService[] = "hgraph.v1.PathMerger";
// Every error message is escaped and bounded as a whole too (each client string in it already
// is, at kClientTextMaxBytes): well under gRPC's 8 KiB default metadata limit.
constexpr size_t kMaxMessageBytes = 2000;

const char* CallType(const std::string& method) {
  if (method == "MergePaths" || method == "PlanPaths") return "server_stream";
  if (method == "UploadBlob") return "client_stream";
  return "unary";
}

}  // namespace

grpc::Status Invoke(const std::function<void()>& body, const CancelToken& token) {
  try {
    body();
    return grpc::Status::OK;
  } catch (const Error& e) {
    grpc::StatusCode code = ToGrpcCode(e.code());
    if (code == grpc::StatusCode::CANCELLED && token.deadline_passed()) {
      return grpc::Status(grpc::StatusCode::DEADLINE_EXCEEDED, "deadline exceeded");
    }
    return grpc::Status(code, ClientText(e.what(), kMaxMessageBytes));
  } catch (const std::bad_alloc&) {
    return grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED, "out of memory");
  } catch (const std::exception& e) {
    // A broken invariant (InternalError) fails this call only; it is a bug worth a log line.
    const std::string message = ClientText(e.what(), kMaxMessageBytes);
    spdlog::error("internal error: {}", message);
    return grpc::Status(grpc::StatusCode::INTERNAL, message);
  }
}

void WireDeadline(grpc::CallbackServerContext* context, const CancelToken& token) {
  const auto deadline = context->deadline();
  if (deadline == std::chrono::system_clock::time_point::max()) return;
  const auto remaining = deadline - std::chrono::system_clock::now();
  token.SetDeadline(Clock::now() + std::chrono::duration_cast<Clock::duration>(remaining));
}

grpc::Status Busy(const WorkerPool& pool) {
  return grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED,
                      "the server is busy: " + std::to_string(pool.max_admitted()) +
                          " calls are queued or running (--max-pending); retry later");
}

void CheckBatchLimits(const v1::PathSet& paths, const ServerOptions& options) {
  if (paths.paths_size() > options.max_paths) {
    throw Error(ErrorCode::kResourceExhausted, "paths.paths",
                std::to_string(paths.paths_size()) + " paths exceed the limit of " +
                    std::to_string(options.max_paths) + " per batch (--max-paths)");
  }
  for (int i = 0; i < paths.paths_size(); ++i) {
    if (paths.paths(i).waypoints_size() > options.max_waypoints) {
      throw Error(ErrorCode::kResourceExhausted, "paths.paths[" + std::to_string(i) + "].waypoints",
                  std::to_string(paths.paths(i).waypoints_size()) +
                      " waypoints exceed the limit of " + std::to_string(options.max_waypoints) +
                      " per path (--max-waypoints)");
    }
  }
}

MergeResult QueryStored(PathMergerService::StoredHGraph& stored, const MeasureSpec& measure,
                        const ProgressCallback& progress, const CancelToken& token,
                        std::optional<bool> report_clearance) {
  std::unique_ptr<HybridizationSession> copy;
  uint64_t version = 0;
  {
    std::lock_guard lock(stored.mutex);
    copy = std::make_unique<HybridizationSession>(stored.session->Clone());
    version = stored.version;
  }
  MergeResult result = copy->Query(measure, progress, token, report_clearance);
  {
    std::lock_guard lock(stored.mutex);
    if (stored.version == version) {
      // The old session goes when `copy` does, outside the lock.
      std::swap(stored.session, copy);
      ++stored.version;
    }
  }
  return result;
}

MergeResult AddToStored(PathMergerService::StoredHGraph& stored,
                        const std::vector<InputPath>& paths, const MeasureSpec& measure,
                        const CancelToken& token, int64_t* candidates_added,
                        std::optional<bool> report_clearance) {
  std::lock_guard adding(stored.adding_mutex);
  std::unique_ptr<HybridizationSession> copy;
  {
    std::lock_guard lock(stored.mutex);
    copy = std::make_unique<HybridizationSession>(stored.session->Clone());
  }
  *candidates_added = copy->AddPaths(paths, {}, token);
  MergeResult result = copy->Query(measure, {}, token, report_clearance);
  {
    std::lock_guard lock(stored.mutex);
    std::swap(stored.session, copy);
    ++stored.version;
  }
  return result;
}

Clock::time_point PathMergerService::RecordStart(const std::string& method) {
  families_.rpc_started.Increment(
      {{"grpc_type", CallType(method)}, {"grpc_service", kService}, {"grpc_method", method}});
  return Clock::now();
}

void PathMergerService::RecordCall(const std::string& method, const std::string& session,
                                   Clock::time_point started, const grpc::Status& status) {
  const double seconds = std::chrono::duration<double>(Clock::now() - started).count();
  const char* code = GrpcCodeName(status.error_code());
  const std::string type = CallType(method);
  families_.rpc_handled.Increment({{"grpc_type", type},
                                   {"grpc_service", kService},
                                   {"grpc_method", method},
                                   {"grpc_code", code}});
  families_.rpc_handling_seconds.Observe(
      {{"grpc_type", type}, {"grpc_service", kService}, {"grpc_method", method}}, seconds);
  if (status.ok()) {
    spdlog::info("{} session={} status={} duration_ms={:.1f}", method,
                 session.empty() ? "-" : ClientText(session), code, seconds * 1e3);
  } else {
    spdlog::info("{} session={} status={} duration_ms={:.1f} error=\"{}\"", method,
                 session.empty() ? "-" : ClientText(session), code, seconds * 1e3,
                 ClientText(status.error_message(), kMaxMessageBytes));
  }
}

void PathMergerService::RecordMerge(const std::string& method, const v1::MergeResult& result) {
  const Labels labels = {{"method", method}};
  families_.merges.Increment(labels);
  const v1::MergeStats& stats = result.stats();
  families_.collision_checks.Increment(labels, static_cast<double>(stats.collision_checks()));
  families_.distance_queries.Increment(labels, static_cast<double>(stats.distance_queries()));
  families_.edges_checked.Increment(labels, static_cast<double>(stats.edges_checked()));
  families_.edges_reused.Increment(labels, static_cast<double>(stats.edges_reused()));
  const v1::Timing& t = result.timing();
  const std::pair<const char*, double> phases[] = {
      {"validate", t.validate_ms()},     {"inputs", t.inputs_ms()}, {"align", t.align_ms()},
      {"candidates", t.candidates_ms()}, {"check", t.check_ms()},   {"search", t.search_ms()},
      {"evaluate", t.evaluate_ms()}};
  for (const auto& [phase, ms] : phases) {
    families_.merge_phase_seconds.Observe({{"method", method}, {"phase", phase}}, ms / 1e3);
  }
}

}  // namespace hgraph::server
