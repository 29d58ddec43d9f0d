#include "server/status/status.h"

#include <gtest/gtest.h>

#include <string>

namespace hgraph {
namespace {

TEST(StatusMapping, EveryEngineCodeSurvivesTheRoundTrip) {
  for (ErrorCode code :
       {ErrorCode::kInvalidArgument, ErrorCode::kNotFound, ErrorCode::kFailedPrecondition,
        ErrorCode::kCancelled, ErrorCode::kDeadlineExceeded, ErrorCode::kResourceExhausted,
        ErrorCode::kUnauthenticated, ErrorCode::kPermissionDenied}) {
    EXPECT_EQ(FromGrpcCode(ToGrpcCode(code)), code) << GrpcCodeName(ToGrpcCode(code));
  }
}

TEST(StatusMapping, EngineCodesMapToTheirCanonicalCodes) {
  EXPECT_EQ(ToGrpcCode(ErrorCode::kInvalidArgument), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(ToGrpcCode(ErrorCode::kNotFound), grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(ToGrpcCode(ErrorCode::kFailedPrecondition), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_EQ(ToGrpcCode(ErrorCode::kCancelled), grpc::StatusCode::CANCELLED);
  EXPECT_EQ(ToGrpcCode(ErrorCode::kDeadlineExceeded), grpc::StatusCode::DEADLINE_EXCEEDED);
  EXPECT_EQ(ToGrpcCode(ErrorCode::kResourceExhausted), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_EQ(ToGrpcCode(ErrorCode::kUnauthenticated), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(ToGrpcCode(ErrorCode::kPermissionDenied), grpc::StatusCode::PERMISSION_DENIED);
}

TEST(StatusMapping, CodesWithoutAnEngineCounterpartAreFailures) {
  EXPECT_EQ(FromGrpcCode(grpc::StatusCode::UNAVAILABLE), ErrorCode::kFailedPrecondition);
  EXPECT_EQ(FromGrpcCode(grpc::StatusCode::INTERNAL), ErrorCode::kFailedPrecondition);
}

TEST(StatusMapping, NamesEveryCanonicalCode) {
  // The seventeen canonical codes, 0..16, each with its own name.
  const char* expected[] = {"OK",
                            "CANCELLED",
                            "UNKNOWN",
                            "INVALID_ARGUMENT",
                            "DEADLINE_EXCEEDED",
                            "NOT_FOUND",
                            "ALREADY_EXISTS",
                            "PERMISSION_DENIED",
                            "RESOURCE_EXHAUSTED",
                            "FAILED_PRECONDITION",
                            "ABORTED",
                            "OUT_OF_RANGE",
                            "UNIMPLEMENTED",
                            "INTERNAL",
                            "UNAVAILABLE",
                            "DATA_LOSS",
                            "UNAUTHENTICATED"};
  for (int i = 0; i <= 16; ++i) {
    EXPECT_EQ(std::string(GrpcCodeName(static_cast<grpc::StatusCode>(i))), expected[i]) << i;
  }
  EXPECT_EQ(std::string(GrpcCodeName(static_cast<grpc::StatusCode>(99))), "UNKNOWN");
}

}  // namespace
}  // namespace hgraph
