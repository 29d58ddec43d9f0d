// Error types shared by the engine. Bad user input is reported by throwing InputError, whose
// message names the field and the problem; callers (CLI, service) map it to an exit code or to
// INVALID_ARGUMENT. Bugs in our own code are caught by HGRAPH_CHECK, which throws InternalError:
// the values an invariant guards may derive from a request, and a service must fail that call
// (INTERNAL, logged), never the process.
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
  kUnauthenticated,     // the caller did not prove who it is (a missing or invalid token)
  kPermissionDenied,    // the caller is known, but the resource belongs to someone else
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

// A broken internal invariant: a bug in hgraph, or a request-derived value that validation
// should have refused. Not an Error: callers report it as an internal failure. Copyable.
class InternalError : public std::logic_error {
 public:
  using std::logic_error::logic_error;
};

[[noreturn]] inline void CheckFailed(const char* condition, const char* file, int line) {
  throw InternalError(std::string("internal invariant failed: ") + condition + " at " + file + ":" +
                      std::to_string(line));
}

}  // namespace hgraph

// Always-on invariant check for conditions that only a bug in hgraph can break; throws
// InternalError.
#define HGRAPH_CHECK(condition) \
  ((condition) ? (void)0 : ::hgraph::CheckFailed(#condition, __FILE__, __LINE__))
