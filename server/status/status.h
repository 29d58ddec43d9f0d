// The one mapping between the engine's error codes and gRPC's canonical status codes, used by
// the server (to answer) and by the CLI's remote runs (to report and choose an exit code).
#pragma once

#include <grpcpp/support/status.h>

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

}  // namespace hgraph
