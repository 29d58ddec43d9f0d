#include "server/call_support.h"

#include <google/protobuf/io/coded_stream.h>
#include <google/protobuf/io/zero_copy_stream_impl_lite.h>
#include <spdlog/spdlog.h>

#include <new>
#include <string>
#include <utility>

#include "core/adapter/scene_proto.h"
#include "core/common/client_text.h"
#include "core/common/digest.h"
#include "google/rpc/error_details.pb.h"
#include "google/rpc/status.pb.h"

namespace hgraph::server {
namespace {

constexpr char kService[] = "hgraph.v1.PathMerger";
constexpr char kDomain[] = "hgraph.v1";
// How long a client told the server is busy waits before it retries (RetryInfo).
constexpr std::chrono::milliseconds kBusyRetryDelay{500};
// Every error message is escaped and bounded as a whole too (each client string in it already
// is, at kClientTextMaxBytes): well under gRPC's 8 KiB default metadata limit.
constexpr size_t kMaxMessageBytes = 2000;

const char* CallType(const std::string& method) {
  if (method == "MergePaths" || method == "PlanPaths" || method == "Solve") {
    return "server_stream";
  }
  if (method == "UploadBlob") return "client_stream";
  return "unary";
}

// The reason of an engine error that names no reason of its own.
const char* DefaultReason(ErrorCode code) {
  switch (code) {
    case ErrorCode::kInvalidArgument: return "INVALID_ARGUMENT";
    case ErrorCode::kNotFound: return "NOT_FOUND";
    case ErrorCode::kFailedPrecondition: return "FAILED_PRECONDITION";
    case ErrorCode::kCancelled: return "CANCELLED";
    case ErrorCode::kDeadlineExceeded: return "DEADLINE_EXCEEDED";
    // A limit of the request's own size: the same request fails the same way again.
    case ErrorCode::kResourceExhausted: return "LIMIT_EXCEEDED";
    case ErrorCode::kUnauthenticated: return "UNAUTHENTICATED";
    case ErrorCode::kPermissionDenied: return "PERMISSION_DENIED";
  }
  return "UNKNOWN";
}

}  // namespace

grpc::Status DetailedStatus(grpc::StatusCode code, const std::string& message,
                            const std::string& field, const std::string& reason,
                            std::chrono::milliseconds retry_delay) {
  if (code == grpc::StatusCode::OK) return grpc::Status::OK;
  google::rpc::Status details;
  details.set_code(static_cast<int>(code));
  details.set_message(message);
  google::rpc::ErrorInfo info;
  info.set_reason(reason);
  info.set_domain(kDomain);
  if (!field.empty()) (*info.mutable_metadata())["field"] = field;
  details.add_details()->PackFrom(info);
  if (!field.empty() &&
      (code == grpc::StatusCode::INVALID_ARGUMENT || code == grpc::StatusCode::RESOURCE_EXHAUSTED ||
       code == grpc::StatusCode::NOT_FOUND)) {
    google::rpc::BadRequest bad;
    google::rpc::BadRequest::FieldViolation* violation = bad.add_field_violations();
    violation->set_field(field);
    // The message without the "field: " it starts with.
    const std::string prefix = field + ": ";
    violation->set_description(message.rfind(prefix, 0) == 0 ? message.substr(prefix.size())
                                                             : message);
    details.add_details()->PackFrom(bad);
  }
  if (retry_delay.count() > 0) {
    google::rpc::RetryInfo retry;
    retry.mutable_retry_delay()->set_seconds(retry_delay.count() / 1000);
    retry.mutable_retry_delay()->set_nanos(static_cast<int32_t>(retry_delay.count() % 1000) *
                                           1000000);
    details.add_details()->PackFrom(retry);
  }
  return grpc::Status(code, message, details.SerializeAsString());
}

grpc::Status Invoke(const std::function<void()>& body, const CancelToken& token) {
  try {
    body();
    return grpc::Status::OK;
  } catch (const ServiceError& e) {
    return DetailedStatus(e.status(), ClientText(e.what(), kMaxMessageBytes), e.field(), e.reason(),
                          e.retry_delay());
  } catch (const Error& e) {
    grpc::StatusCode code = ToGrpcCode(e.code());
    if (code == grpc::StatusCode::CANCELLED && token.deadline_passed()) {
      return DetailedStatus(grpc::StatusCode::DEADLINE_EXCEEDED, "deadline exceeded", "",
                            "DEADLINE_EXCEEDED");
    }
    return DetailedStatus(code, ClientText(e.what(), kMaxMessageBytes), e.field(),
                          DefaultReason(e.code()));
  } catch (const std::bad_alloc&) {
    return DetailedStatus(grpc::StatusCode::RESOURCE_EXHAUSTED, "out of memory", "",
                          "OUT_OF_MEMORY");
  } catch (const std::exception& e) {
    // A broken invariant (InternalError) fails this call only; it is a bug worth a log line.
    const std::string message = ClientText(e.what(), kMaxMessageBytes);
    spdlog::error("internal error: {}", message);
    return DetailedStatus(grpc::StatusCode::INTERNAL, message, "", "INTERNAL");
  }
}

void WireDeadline(grpc::CallbackServerContext* context, const CancelToken& token) {
  const auto deadline = context->deadline();
  if (deadline == std::chrono::system_clock::time_point::max()) return;
  const auto remaining = deadline - std::chrono::system_clock::now();
  token.SetDeadline(Clock::now() + std::chrono::duration_cast<Clock::duration>(remaining));
}

grpc::Status Busy(const WorkerPool& pool) {
  return DetailedStatus(grpc::StatusCode::RESOURCE_EXHAUSTED,
                        "the server is busy: " + std::to_string(pool.max_admitted()) +
                            " calls are queued or running (--max-pending); retry later",
                        "", "SERVER_BUSY", kBusyRetryDelay);
}

void CheckPathCount(int64_t count, const std::string& field, const std::string& what,
                    const ServerOptions& options) {
  if (count <= options.max_paths) return;
  throw Error(ErrorCode::kResourceExhausted, field,
              std::to_string(count) + " " + what + " exceed the limit of " +
                  std::to_string(options.max_paths) + " (--max-paths)");
}

void CheckBatchLimits(const v1::PathSet& paths, const ServerOptions& options) {
  CheckPathCount(paths.paths_size(), "paths.paths", "paths per batch", options);
  for (int i = 0; i < paths.paths_size(); ++i) {
    if (paths.paths(i).waypoints_size() > options.max_waypoints) {
      throw Error(ErrorCode::kResourceExhausted, "paths.paths[" + std::to_string(i) + "].waypoints",
                  std::to_string(paths.paths(i).waypoints_size()) +
                      " waypoints exceed the limit of " + std::to_string(options.max_waypoints) +
                      " per path (--max-waypoints)");
    }
  }
}

void WithRequestPaths(const std::function<void()>& body) {
  try {
    body();
  } catch (const ServiceError&) {
    throw;
  } catch (const Error& e) {
    if (e.field() != "paths" && e.field().rfind("paths[", 0) != 0) throw;
    throw Error(e.code(), "paths." + e.field(), std::string(e.what()).substr(e.field().size() + 2));
  }
}

void EchoEvaluation(const v1::MergeOptions& options, v1::MergeResult* result) {
  result->set_evaluation(options.evaluation() == v1::EVALUATION_UNSPECIFIED ? v1::EVALUATION_LAZY
                                                                            : options.evaluation());
}

std::string RequestFingerprint(const google::protobuf::Message& request, int ignored) {
  std::unique_ptr<google::protobuf::Message> copy(request.New());
  copy->CopyFrom(request);
  if (ignored > 0) {
    const google::protobuf::FieldDescriptor* field =
        copy->GetDescriptor()->FindFieldByNumber(ignored);
    if (field != nullptr) copy->GetReflection()->ClearField(copy.get(), field);
  }
  std::string bytes;
  {
    google::protobuf::io::StringOutputStream stream(&bytes);
    google::protobuf::io::CodedOutputStream coded(&stream);
    coded.SetSerializationDeterministic(true);
    copy->SerializeToCodedStream(&coded);
  }
  return Sha256Hex(bytes);
}

Config EndpointOf(bool set, const v1::Configuration& given, const std::optional<Config>& scenes,
                  const std::string& field) {
  if (set) return ConfigFromProto(given);
  if (scenes) return *scenes;
  throw InputError(field, "must be set: the scene has no " + field + " of its own");
}

PathMergerService::CallBase::CallBase(PathMergerService* service,
                                      grpc::CallbackServerContext* context, std::string method,
                                      std::string session, bool wire_deadline)
    : service_(service),
      method_(std::move(method)),
      session_(std::move(session)),
      started_(service->RecordStart(method_)) {
  if (wire_deadline) WireDeadline(context, token_);
  auth_ = service->options().auth.Authenticate(*context, &tenant_);
}

bool PathMergerService::CallBase::Authenticated() {
  if (auth_.ok()) return true;
  Complete(auth_);
  return false;
}

bool PathMergerService::CallBase::Submit(std::function<void()> body) {
  const bool admitted =
      service_->pool().TrySubmit([this, body = std::move(body)](WorkerPool::Slot& slot) {
        const grpc::Status status = Invoke(body, token_);
        slot.Release();
        Complete(status);
      });
  if (!admitted) Complete(Busy(service_->pool()));
  return admitted;
}

bool PathMergerService::CallBase::Hold() {
  if (service_->pool().TryHold()) return true;
  Complete(Busy(service_->pool()));
  return false;
}

void PathMergerService::CallBase::SubmitHeld(std::function<void()> body) {
  service_->pool().SubmitHeld([this, body = std::move(body)](WorkerPool::Slot& slot) {
    const grpc::Status status = Invoke(body, token_);
    slot.Release();
    Complete(status);
  });
}

void PathMergerService::CallBase::RunHere(const std::function<void()>& body) {
  Complete(Invoke(body, token_));
}

grpc::Status PathMergerService::CallBase::Final(const grpc::Status& status) {
  grpc::Status out = status;
  if (!out.ok() && out.error_details().empty()) {
    out = DetailedStatus(out.error_code(), out.error_message(), "", GrpcCodeName(out.error_code()));
  }
  if (!recorded_.exchange(true)) service_->RecordCall(method_, session_, started_, out);
  return out;
}

// A session deleted (or expired) while the work ran gets no H-Graph, but the client still gets
// its result.
void PathMergerService::CallBase::Keep(const std::string& session, const std::string& name,
                                       std::shared_ptr<StoredHGraph> stored,
                                       v1::MergePathsResponse* out) {
  // What a repeat of the request answers.
  out->set_hgraph(name);
  out->set_generation(stored->generation);
  out->set_retention(v1::RETENTION_KEPT);
  out->set_shared(service_->shared_ != nullptr);
  stored->answer = *out;
  // In the shared store before the answer goes out (and before any other call can reach it
  // here): a client told of an H-Graph can re-query it on any replica.
  bool written = false;
  if (service_->shared_) {
    written = service_->SaveHGraph(name, *stored, /*cas=*/false) == SharedState::Write::kStored;
    if (!written) {
      out->set_shared(false);
      stored->answer.set_shared(false);
    }
  }
  // The name stays empty for readers older than `retention`, which says why.
  const auto not_kept = [this, out, written, &name](v1::Retention why) {
    if (written) service_->shared_->DeleteHGraph(name);
    out->clear_hgraph();
    out->clear_generation();
    out->clear_shared();
    out->set_retention(why);
  };
  // In the cache before the registry says kept: a GetHGraph in between sees the merge still
  // running, never a kept name with nothing behind it.
  const size_t bytes = stored->session->memory_bytes();
  if (!service_->cache_.Put(CacheKind::kHGraph, name, std::move(stored), bytes)) {
    // Larger than the whole budget: the result stands, but there is nothing to re-query.
    service_->sessions_.AbandonHGraph(name);
    spdlog::warn("{} session={} H-Graph of {} bytes exceeds --cache-bytes; not kept", method_,
                 session, bytes);
    return not_kept(v1::RETENTION_TOO_LARGE);
  }
  try {
    service_->sessions_.KeepHGraph(name);
    // Re-created since by another tenant: not this call's session any more.
    service_->sessions_.Touch(session, "session", tenant_);
  } catch (const Error& e) {
    if (e.code() != ErrorCode::kNotFound && e.code() != ErrorCode::kPermissionDenied) throw;
    // Deleted (or expired) while the work ran: DeleteSession could not drop what was not yet
    // kept, so this call does.
    spdlog::info("{} session={} was deleted while the call ran; H-Graph not kept", method_,
                 session);
    service_->cache_.Erase(CacheKind::kHGraph, name);
    return not_kept(v1::RETENTION_SESSION_ENDED);
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
