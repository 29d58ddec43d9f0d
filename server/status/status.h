// The one mapping between the engine's error codes and gRPC's canonical status codes, used by
// the server (to answer) and by the CLI's remote runs (to report and choose an exit code).
#pragma once

#include <grpcpp/support/status.h>

#include <chrono>
#include <string>
#include <utility>

#include "core/common/error.h"

namespace hgraph {

// The canonical name of a gRPC status code ("INVALID_ARGUMENT"); "UNKNOWN" for values outside
// the canonical set.
const char* GrpcCodeName(grpc::StatusCode code);

// The canonical code an engine error is answered with.
grpc::StatusCode ToGrpcCode(ErrorCode code);

// The engine error code a canonical status stands for on the client side. Codes the engine has
// no counterpart for (UNAVAILABLE, INTERNAL, ...) map to kFailedPrecondition.
ErrorCode FromGrpcCode(grpc::StatusCode code);

// An Error of the service that says more than its ErrorCode: the canonical code it is answered
// with (also those the engine has no ErrorCode for: ABORTED, ALREADY_EXISTS), the reason a client
// switches on (google.rpc.ErrorInfo.reason, domain "hgraph.v1"; hgraph/v1/service.proto lists
// them) and, for what is worth retrying as it is, the delay to retry after (RetryInfo). Copyable.
class ServiceError : public Error {
 public:
  ServiceError(grpc::StatusCode status, std::string reason, std::string field,
               const std::string& message,
               std::chrono::milliseconds retry_delay = std::chrono::milliseconds(0))
      : Error(FromGrpcCode(status), std::move(field), message),
        status_(status),
        reason_(std::move(reason)),
        retry_delay_(retry_delay) {}

  grpc::StatusCode status() const { return status_; }
  const std::string& reason() const { return reason_; }
  // 0: not worth retrying as it is.
  std::chrono::milliseconds retry_delay() const { return retry_delay_; }

 private:
  grpc::StatusCode status_;
  std::string reason_;
  std::chrono::milliseconds retry_delay_;
};

}  // namespace hgraph
