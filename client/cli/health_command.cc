// `hgraph health --server ADDR`: asks the server's standard gRPC health service
// (grpc.health.v1.Health/Check) whether it is serving; for container HEALTHCHECKs and scripts.
// Exit 0 when SERVING, 1 otherwise (NOT_SERVING while the server drains, or no answer).
//
// Debian's gRPC installs no generated health stubs, so the call goes through the generic stub
// with the two tiny messages encoded here: HealthCheckRequest {string service = 1} and
// HealthCheckResponse {ServingStatus status = 1}, SERVING = 1.
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>

#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <mutex>
#include <string>

#include "client/cli/remote.h"

namespace hgraph::cli {
namespace {

constexpr int kServing = 1;

std::string EncodeRequest(const std::string& service) {
  std::string bytes;
  if (service.empty()) return bytes;  // proto3 leaves an empty string out
  bytes.push_back(0x0a);              // field 1, length-delimited
  size_t n = service.size();
  do {
    const unsigned char low = n & 0x7f;
    n >>= 7;
    bytes.push_back(static_cast<char>(n ? (low | 0x80) : low));
  } while (n);
  return bytes + service;
}

// The status field of a HealthCheckResponse; 0 (UNKNOWN) when absent.
int DecodeStatus(const std::string& bytes) {
  int status = 0;
  for (size_t at = 0; at < bytes.size();) {
    const unsigned char key = bytes[at++];
    uint64_t value = 0;
    int shift = 0;
    if ((key & 7) == 0) {
      while (at < bytes.size()) {
        const unsigned char b = bytes[at++];
        value |= static_cast<uint64_t>(b & 0x7f) << shift;
        shift += 7;
        if (!(b & 0x80)) break;
      }
      if ((key >> 3) == 1) status = static_cast<int>(value);
    } else {
      return status;  // nothing else is expected in this message
    }
  }
  return status;
}

int CheckHealth(const RemoteOptions& remote, const std::string& service) {
  const std::string& server = remote.server;
  grpc::GenericStub stub(OpenChannel(remote));
  grpc::ClientContext context;
  // The health service needs no token, but a front (a proxy checking tokens) may.
  PrepareCall(remote, &context);
  const std::string request = EncodeRequest(service);
  grpc::Slice slice(request);
  grpc::ByteBuffer request_buffer(&slice, 1);
  grpc::ByteBuffer response_buffer;
  std::mutex mutex;
  std::condition_variable done_cv;
  bool done = false;
  grpc::Status status;
  stub.UnaryCall(&context, "/grpc.health.v1.Health/Check", grpc::StubOptions(), &request_buffer,
                 &response_buffer, [&](grpc::Status s) {
                   std::lock_guard lock(mutex);
                   status = std::move(s);
                   done = true;
                   done_cv.notify_one();
                 });
  std::unique_lock lock(mutex);
  done_cv.wait(lock, [&] { return done; });
  if (!status.ok()) {
    std::printf("%s: health check failed: %s (code %d)\n", server.c_str(),
                status.error_message().c_str(), static_cast<int>(status.error_code()));
    return kExitCheckFailed;
  }
  std::vector<grpc::Slice> slices;
  std::string response;
  if (response_buffer.Dump(&slices).ok()) {
    for (const grpc::Slice& s : slices) {
      response.append(reinterpret_cast<const char*>(s.begin()), s.size());
    }
  }
  const int serving = DecodeStatus(response);
  const char* names[] = {"UNKNOWN", "SERVING", "NOT_SERVING", "SERVICE_UNKNOWN"};
  std::printf("%s: %s\n", server.c_str(), serving >= 0 && serving <= 3 ? names[serving] : "?");
  return serving == kServing ? kExitOk : kExitCheckFailed;
}

}  // namespace

Subcommand AddHealthCommand(CLI::App& parent) {
  CLI::App* app = parent.add_subcommand(
      "health", "Ask hgraph-server's gRPC health service whether it serves (exit 0 if SERVING)");
  auto remote = std::make_shared<RemoteOptions>(RemoteOptions{.timeout_s = 5.0});
  auto service = std::make_shared<std::string>();
  AddServerFlags(app, remote.get(), ServerFlag::kRequired);
  app->add_option("--service", *service,
                  "service name to ask about (empty = the whole server; or hgraph.v1.PathMerger)");
  return Subcommand{app, [remote, service] { return CheckHealth(*remote, *service); }};
}

}  // namespace hgraph::cli
