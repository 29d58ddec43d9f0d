#include "server/call_support.h"

#include <spdlog/spdlog.h>

#include <new>
#include <string>
#include <utility>

namespace hgraph::server {
namespace {

constexpr char kService[] = "hgraph.v1.PathMerger";

}  // namespace

const char* CodeName(grpc::StatusCode code) {
  switch (code) {
    case grpc::StatusCode::OK: return "OK";
    case grpc::StatusCode::CANCELLED: return "CANCELLED";
    case grpc::StatusCode::UNKNOWN: return "UNKNOWN";
    case grpc::StatusCode::INVALID_ARGUMENT: return "INVALID_ARGUMENT";
    case grpc::StatusCode::DEADLINE_EXCEEDED: return "DEADLINE_EXCEEDED";
    case grpc::StatusCode::NOT_FOUND: return "NOT_FOUND";
    case grpc::StatusCode::ALREADY_EXISTS: return "ALREADY_EXISTS";
    case grpc::StatusCode::PERMISSION_DENIED: return "PERMISSION_DENIED";
    case grpc::StatusCode::UNAUTHENTICATED: return "UNAUTHENTICATED";
    case grpc::StatusCode::RESOURCE_EXHAUSTED: return "RESOURCE_EXHAUSTED";
    case grpc::StatusCode::FAILED_PRECONDITION: return "FAILED_PRECONDITION";
    case grpc::StatusCode::ABORTED: return "ABORTED";
    case grpc::StatusCode::OUT_OF_RANGE: return "OUT_OF_RANGE";
    case grpc::StatusCode::UNIMPLEMENTED: return "UNIMPLEMENTED";
    case grpc::StatusCode::INTERNAL: return "INTERNAL";
    case grpc::StatusCode::UNAVAILABLE: return "UNAVAILABLE";
    case grpc::StatusCode::DATA_LOSS: return "DATA_LOSS";
    default: return "UNKNOWN";
  }
}

grpc::StatusCode ToGrpcCode(ErrorCode code) {
  switch (code) {
    case ErrorCode::kInvalidArgument: return grpc::StatusCode::INVALID_ARGUMENT;
    case ErrorCode::kNotFound: return grpc::StatusCode::NOT_FOUND;
    case ErrorCode::kFailedPrecondition: return grpc::StatusCode::FAILED_PRECONDITION;
    case ErrorCode::kCancelled: return grpc::StatusCode::CANCELLED;
    case ErrorCode::kDeadlineExceeded: return grpc::StatusCode::DEADLINE_EXCEEDED;
    case ErrorCode::kResourceExhausted: return grpc::StatusCode::RESOURCE_EXHAUSTED;
    case ErrorCode::kUnauthenticated: return grpc::StatusCode::UNAUTHENTICATED;
    case ErrorCode::kPermissionDenied: return grpc::StatusCode::PERMISSION_DENIED;
  }
  return grpc::StatusCode::UNKNOWN;
}

grpc::Status Invoke(const std::function<void()>& body, const CancelToken& token) {
  try {
    body();
    return grpc::Status::OK;
  } catch (const Error& e) {
    grpc::StatusCode code = ToGrpcCode(e.code());
    if (code == grpc::StatusCode::CANCELLED && token.deadline_passed()) {
      return grpc::Status(grpc::StatusCode::DEADLINE_EXCEEDED, "deadline exceeded");
    }
    return grpc::Status(code, e.what());
  } catch (const std::bad_alloc&) {
    return grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED, "out of memory");
  } catch (const std::exception& e) {
    // A broken invariant (InternalError) fails this call only; it is a bug worth a log line.
    spdlog::error("internal error: {}", e.what());
    return grpc::Status(grpc::StatusCode::INTERNAL, e.what());
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

void PathMergerService::RecordCall(const std::string& method, const std::string& session,
                                   Clock::time_point started, const grpc::Status& status) {
  const double seconds = std::chrono::duration<double>(Clock::now() - started).count();
  const char* code = CodeName(status.error_code());
  const std::string type = method == "MergePaths" || method == "PlanPaths" ? "server_stream"
                           : method == "UploadBlob"                        ? "client_stream"
                                                                           : "unary";
  metrics_.Increment("grpc_server_started_total",
                     {{"grpc_type", type}, {"grpc_service", kService}, {"grpc_method", method}});
  metrics_.Increment("grpc_server_handled_total", {{"grpc_type", type},
                                                   {"grpc_service", kService},
                                                   {"grpc_method", method},
                                                   {"grpc_code", code}});
  metrics_.Observe("grpc_server_handling_seconds",
                   {{"grpc_type", type}, {"grpc_service", kService}, {"grpc_method", method}},
                   seconds);
  if (status.ok()) {
    spdlog::info("{} session={} status={} duration_ms={:.1f}", method,
                 session.empty() ? "-" : session, code, seconds * 1e3);
  } else {
    spdlog::info("{} session={} status={} duration_ms={:.1f} error=\"{}\"", method,
                 session.empty() ? "-" : session, code, seconds * 1e3, status.error_message());
  }
}

void PathMergerService::RecordMerge(const std::string& method, const v1::MergeResult& result) {
  const Labels labels = {{"method", method}};
  metrics_.Increment("hgraph_merges_total", labels);
  const v1::MergeStats& stats = result.stats();
  metrics_.Increment("hgraph_merge_collision_checks_total", labels,
                     static_cast<double>(stats.collision_checks()));
  metrics_.Increment("hgraph_merge_distance_queries_total", labels,
                     static_cast<double>(stats.distance_queries()));
  metrics_.Increment("hgraph_merge_edges_checked_total", labels,
                     static_cast<double>(stats.edges_checked()));
  metrics_.Increment("hgraph_merge_edges_reused_total", labels,
                     static_cast<double>(stats.edges_reused()));
  const v1::Timing& t = result.timing();
  const std::pair<const char*, double> phases[] = {
      {"validate", t.validate_ms()},     {"inputs", t.inputs_ms()}, {"align", t.align_ms()},
      {"candidates", t.candidates_ms()}, {"check", t.check_ms()},   {"search", t.search_ms()},
      {"evaluate", t.evaluate_ms()}};
  for (const auto& [phase, ms] : phases) {
    metrics_.Observe("hgraph_merge_phase_seconds", {{"method", method}, {"phase", phase}},
                     ms / 1e3);
  }
}

}  // namespace hgraph::server
