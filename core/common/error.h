// Error types shared by the engine. Bad user input is reported by throwing InputError, whose
// message names the field and the problem; callers (CLI, service) map it to an exit code or to
// INVALID_ARGUMENT. Bugs in our own code are caught by HGRAPH_CHECK, which aborts.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>

namespace hgraph {

// Kinds of failure a caller must tell apart; they map one to one onto gRPC canonical codes.
enum class ErrorCode {
  kInvalidArgument,     // the request is malformed: a field has a bad value
  kNotFound,            // a referenced file or resource does not exist
  kFailedPrecondition,  // the request is well formed but cannot be served in this state
  kCancelled,           // the caller cancelled the work
  kDeadlineExceeded,    // the work ran past its deadline
  kResourceExhausted,   // a limit was hit
};

// An error caused by the caller's input or by the outside world, never by a bug here.
// Copyable and movable.
class Error : public std::runtime_error {
 public:
  Error(ErrorCode code, std::string field, const std::string& message)
      : std::runtime_error(field.empty() ? message : field + ": " + message),
        code_(code),
        field_(std::move(field)) {}

  ErrorCode code() const { return code_; }
  // The dotted path of the offending field ("paths[2].waypoints[0]"), or empty.
  const std::string& field() const { return field_; }

 private:
  ErrorCode code_;
  std::string field_;
};

// Shorthand for the most common case: a field of the request has a bad value.
class InputError : public Error {
 public:
  InputError(std::string field, const std::string& message)
      : Error(ErrorCode::kInvalidArgument, std::move(field), message) {}
};

[[noreturn]] inline void CheckFailed(const char* condition, const char* file, int line) {
  std::fprintf(stderr, "hgraph: internal invariant failed: %s at %s:%d\n", condition, file, line);
  std::abort();
}

}  // namespace hgraph

// Always-on invariant check for conditions that only a bug in hgraph can break.
#define HGRAPH_CHECK(condition) \
  ((condition) ? (void)0 : ::hgraph::CheckFailed(#condition, __FILE__, __LINE__))
