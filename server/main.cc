// hgraph-server: the PathMerger gRPC service, health checking, reflection and Prometheus
// metrics. SIGTERM (or SIGINT) shuts down gracefully: health goes NOT_SERVING while calls are
// still served for --drain-s (so that load balancers and Kubernetes readiness probes stop sending
// new calls here before any is refused; a second signal ends the drain early), then new calls
// are refused, in-flight calls get --grace-s to finish and are then cancelled, and the process
// exits 0.
#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/grpcpp.h>
#include <grpcpp/health_check_service_interface.h>
#include <grpcpp/impl/server_builder_option.h>
#include <grpcpp/impl/server_builder_plugin.h>
#include <signal.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <sys/stat.h>
#include <tbb/info.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "core/common/error.h"
#include "core/common/file_bytes.h"
#include "server/auth.h"
#include "server/mesh_importer.h"
#include "server/metrics.h"
#include "server/service.h"
#include "server/store.h"
#include "server/tls.h"

namespace {

// Linking gRPC's reflection library registers its plugin with every ServerBuilder (a static
// initializer); this option takes it out of one builder again.
class WithoutReflection final : public grpc::ServerBuilderOption {
 public:
  void UpdateArguments(grpc::ChannelArguments*) override {}
  void UpdatePlugins(std::vector<std::unique_ptr<grpc::ServerBuilderPlugin>>* plugins) override {
    std::erase_if(*plugins, [](const std::unique_ptr<grpc::ServerBuilderPlugin>& plugin) {
      return plugin->name() == "proto_server_reflection";
    });
  }
};

// What the health-only port answers to every call but grpc.health.v1's: UNIMPLEMENTED. (gRPC
// needs some callback service beside the health service to poll the port at all.)
class HealthOnly final : public grpc::CallbackGenericService {
 public:
  grpc::ServerGenericBidiReactor* CreateReactor(grpc::GenericCallbackServerContext*) override {
    class Refused final : public grpc::ServerGenericBidiReactor {
     public:
      Refused() {
        Finish(grpc::Status(grpc::StatusCode::UNIMPLEMENTED,
                            "this port (--health-listen) serves grpc.health.v1 only"));
      }
      void OnDone() override { delete this; }
    };
    return new Refused;
  }
};

struct Flags {
  std::string listen = "0.0.0.0:50051";
  std::string metrics_listen = "0.0.0.0:9464";
  std::string health_listen;
  int threads = 0;
  int max_pending = 64;
  int64_t max_message_bytes = int64_t{64} << 20;
  int max_paths = 256;
  int max_waypoints = 100000;
  int max_sessions = 1000;
  int tenant_max_sessions = 0;
  int64_t tenant_cache_bytes = 0;
  int64_t cache_bytes = int64_t{2} << 30;
  bool clearance_bound = false;
  int64_t max_blob_bytes = int64_t{256} << 20;
  double session_ttl_s = 3600;
  double grace_s = 10;
  double drain_s = 2;
  int progress_interval_ms = 100;
  std::string log_level = "info";
  std::string mesh_import_helper;
  int64_t mesh_import_memory_mb = 1024;
  int mesh_import_cpu_s = 20;
  double mesh_import_timeout_s = 30;
  hgraph::server::TlsFiles tls;
  std::string auth_tokens;
  bool reflection = false;
  double upload_idle_timeout_s = 30;
  std::string store = "memory";
  std::string store_password_file;
  std::string store_ca_file;
  int store_timeout_ms = 500;
};

}  // namespace

int main(int argc, char** argv) {
  Flags flags;
  CLI::App app("hgraph-server: the H-Graph path merging service (gRPC, hgraph.v1.PathMerger)",
               "hgraph-server");
  app.add_option("--listen", flags.listen, "gRPC address host:port (port 0 picks a free one)")
      ->capture_default_str();
  app.add_option("--metrics-listen", flags.metrics_listen,
                 "Prometheus /metrics address host:port (port 0 picks a free one; empty = off)")
      ->capture_default_str();
  // From the environment too, so that the image (Dockerfile: HGRAPH_HEALTH_LISTEN) keeps the
  // port its HEALTHCHECK probes whatever arguments a deployment passes.
  app.add_option("--health-listen", flags.health_listen,
                 "a second gRPC address, plaintext, serving only grpc.health.v1 (for probes that "
                 "cannot speak TLS, such as Kubernetes' native gRPC probes; port 0 picks a free "
                 "one; empty = off; the image sets HGRAPH_HEALTH_LISTEN to 0.0.0.0:50052)")
      ->envname("HGRAPH_HEALTH_LISTEN");
  app.add_option("--threads", flags.threads, "worker threads for all calls (0 = all cores)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--max-pending", flags.max_pending,
                 "calls queued or running on the workers before RESOURCE_EXHAUSTED")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  // gRPC takes the limit as an int.
  app.add_option("--max-message-bytes", flags.max_message_bytes,
                 "largest gRPC message received or sent")
      ->check(CLI::Range(int64_t{1}, int64_t{std::numeric_limits<int>::max()}))
      ->capture_default_str();
  app.add_option("--max-paths", flags.max_paths, "input paths per MergePaths batch")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--max-waypoints", flags.max_waypoints, "waypoints (nodes) per input path")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--max-sessions", flags.max_sessions, "live sessions")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--tenant-max-sessions", flags.tenant_max_sessions,
                 "live sessions per tenant (--auth-tokens; 0 = no quota beyond --max-sessions)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--tenant-cache-bytes", flags.tenant_cache_bytes,
                 "bytes of kept H-Graphs per tenant in the cache: past it, merges and additions "
                 "of that tenant fail RESOURCE_EXHAUSTED (0 = no quota beyond --cache-bytes)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--cache-bytes", flags.cache_bytes,
                 "memory budget of blobs, scenes, collision worlds and H-Graphs (LRU eviction)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_flag("--clearance-bound", flags.clearance_bound,
               "certify motions with a per-scene distance field first, FCL's exact distance only "
               "where it cannot decide (built once per scene, counted in --cache-bytes)");
  app.add_option("--max-blob-bytes", flags.max_blob_bytes, "largest uploaded blob")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--session-ttl-s", flags.session_ttl_s, "idle time before a session expires")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--grace-s", flags.grace_s,
                 "on SIGTERM, time in-flight calls get to finish before they are cancelled")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--drain-s", flags.drain_s,
                 "on SIGTERM, time health answers NOT_SERVING while calls are still accepted, "
                 "before shutdown starts (a second signal ends it early)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--progress-interval-ms", flags.progress_interval_ms,
                 "default minimum time between two progress events of a merge")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--mesh-import-helper", flags.mesh_import_helper,
                 "the hgraph-mesh-import executable that parses client meshes (default: beside "
                 "this binary)");
  app.add_option("--mesh-import-memory-mb", flags.mesh_import_memory_mb,
                 "address-space limit of each mesh import process")
      ->check(CLI::Range(int64_t{64}, int64_t{1} << 20))
      ->capture_default_str();
  app.add_option("--mesh-import-cpu-s", flags.mesh_import_cpu_s,
                 "CPU-time limit of each mesh import process")
      ->check(CLI::Range(1, 3600))
      ->capture_default_str();
  app.add_option("--mesh-import-timeout-s", flags.mesh_import_timeout_s,
                 "wall-clock limit of each mesh import (the call's deadline, if sooner, wins)")
      ->check(CLI::Range(0.1, 3600.0))
      ->capture_default_str();
  app.add_option("--tls-cert", flags.tls.cert,
                 "PEM certificate chain of the server: the gRPC port speaks TLS (with --tls-key)")
      ->check(CLI::ExistingFile);
  app.add_option("--tls-key", flags.tls.key, "PEM private key (unencrypted) of --tls-cert")
      ->check(CLI::ExistingFile);
  app.add_option("--tls-client-ca", flags.tls.client_ca,
                 "PEM CA certificate(s): mutual TLS, every client must present a certificate "
                 "signed by one of them (needs --tls-cert)")
      ->check(CLI::ExistingFile);
  app.add_option("--auth-tokens", flags.auth_tokens,
                 "file of \"TOKEN TENANT\" lines: every call needs \"authorization: Bearer "
                 "TOKEN\"; sessions and H-Graphs belong to the token's tenant (health stays open)")
      ->check(CLI::ExistingFile);
  app.add_flag("--reflection", flags.reflection,
               "serve gRPC reflection even with --auth-tokens (it is on without them; with them it "
               "would describe the API to callers without a token)");
  app.add_option("--upload-idle-timeout-s", flags.upload_idle_timeout_s,
                 "an UploadBlob stream that sends nothing for this long is aborted (ABORTED) and "
                 "its reserved bytes and admission slot released")
      ->check(CLI::Range(0.5, 86400.0))
      ->capture_default_str();
  app.add_option("--store", flags.store,
                 "what replicas share: \"memory\" (nothing: each replica holds what it built) or "
                 "\"redis://HOST[:PORT][/DB]\" (\"rediss://\" for TLS): blobs, scenes, sessions "
                 "and H-Graph snapshots, so that any replica answers for any session")
      ->capture_default_str();
  app.add_option("--store-password-file", flags.store_password_file,
                 "file holding the store's password (\"PASSWORD\" or \"USER PASSWORD\" for a "
                 "Redis ACL user), one line")
      ->check(CLI::ExistingFile);
  app.add_option("--store-ca-file", flags.store_ca_file,
                 "PEM CA certificate(s) to verify a rediss:// store with (default: the system's)")
      ->check(CLI::ExistingFile);
  app.add_option("--store-timeout-ms", flags.store_timeout_ms,
                 "each store operation fails after this long; the server then serves from memory "
                 "and retries the store a second later")
      ->check(CLI::Range(1, 60000))
      ->capture_default_str();
  app.add_option("--log-level", flags.log_level, "log verbosity")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error", "critical", "off"}))
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  // Logs go to stderr; stdout carries only the "ready" line.
  spdlog::set_default_logger(spdlog::stderr_color_mt("hgraph-server"));
  spdlog::set_level(spdlog::level::from_str(flags.log_level));
  spdlog::set_pattern("%Y-%m-%dT%H:%M:%S.%e %^%l%$ %v");

  // Every thread started from here on inherits the blocked mask, so the signals reach only the
  // sigtimedwait below (no async-signal-safety concerns in a handler).
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  hgraph::server::ServerOptions options{
      .threads = flags.threads > 0 ? flags.threads : tbb::info::default_concurrency(),
      .max_admitted = flags.max_pending,
      .max_paths = flags.max_paths,
      .max_waypoints = flags.max_waypoints,
      .max_sessions = flags.max_sessions,
      .cache_bytes = static_cast<size_t>(flags.cache_bytes),
      .max_blob_bytes = flags.max_blob_bytes,
      .session_ttl = std::chrono::milliseconds(static_cast<int64_t>(flags.session_ttl_s * 1e3)),
      .progress_interval_ms = flags.progress_interval_ms,
      .mesh_import = {.helper_path = flags.mesh_import_helper.empty()
                                         ? hgraph::server::DefaultMeshImportHelper()
                                         : flags.mesh_import_helper,
                      .memory_mb = flags.mesh_import_memory_mb,
                      .cpu_s = flags.mesh_import_cpu_s,
                      .timeout = std::chrono::milliseconds(
                          static_cast<int64_t>(flags.mesh_import_timeout_s * 1e3))},
      .clearance_bound = flags.clearance_bound,
      .upload_idle_timeout =
          std::chrono::milliseconds(static_cast<int64_t>(flags.upload_idle_timeout_s * 1e3)),
      .tenant_max_sessions = flags.tenant_max_sessions,
      .tenant_cache_bytes = static_cast<size_t>(flags.tenant_cache_bytes)};

  try {
    hgraph::server::MeshImporter(options.mesh_import).CheckHelper();
    // Checked before anything listens: a bad file is an error naming its flag.
    const hgraph::server::TransportMode transport = hgraph::server::TransportModeOf(flags.tls);
    const std::shared_ptr<grpc::ServerCredentials> credentials =
        hgraph::server::MakeServerCredentials(flags.tls);
    if (!flags.auth_tokens.empty()) {
      const hgraph::server::TokenTable tokens = hgraph::server::TokenTable::Load(flags.auth_tokens);
      // Counts only: the file's contents are secrets and never reach the log.
      spdlog::info("--auth-tokens: {} tokens for {} tenants", tokens.size(),
                   tokens.tenants().size());
      struct stat file {};
      if (::stat(flags.auth_tokens.c_str(), &file) == 0 && (file.st_mode & 077) != 0) {
        spdlog::warn("--auth-tokens: {} is readable by other users (chmod 600 it)",
                     flags.auth_tokens);
      }
      options.auth = hgraph::server::Authenticator(tokens);
    }
    const hgraph::server::StoreAddress store = hgraph::server::ParseStoreAddress(flags.store);
    if (!store.redis && !flags.store_password_file.empty()) {
      throw hgraph::InputError("--store-password-file",
                               "needs --store redis://... or rediss://...");
    }
    if (!store.tls && !flags.store_ca_file.empty()) {
      throw hgraph::InputError("--store-ca-file", "needs --store rediss://...");
    }
    if (store.redis) {
      hgraph::server::RedisOptions redis{
          .address = store,
          .ca_file = flags.store_ca_file,
          .timeout = std::chrono::milliseconds(flags.store_timeout_ms)};
      if (!flags.store_password_file.empty()) {
        const std::string text =
            hgraph::ReadFileBytes(flags.store_password_file, "--store-password-file");
        std::string line = text.substr(0, text.find('\n'));
        if (!line.empty() && line.back() == '\r') line.pop_back();
        const size_t space = line.find(' ');
        if (space != std::string::npos) {
          redis.username = line.substr(0, space);
          line = line.substr(space + 1);
        }
        if (line.empty()) {
          throw hgraph::InputError("--store-password-file", "holds no password on its first line");
        }
        redis.password = line;
      }
      options.store = hgraph::server::MakeRedisStore(redis);
      spdlog::info("--store: {} (blobs, scenes, sessions and H-Graphs shared; timeout {} ms)",
                   options.store->Describe(), flags.store_timeout_ms);
    }
    hgraph::server::Metrics metrics;
    hgraph::server::PathMergerService service(options, metrics);

    grpc::EnableDefaultHealthCheckService(true);
    // Reflection answers without a token: with tenants it is off unless asked for.
    const bool reflection = flags.auth_tokens.empty() || flags.reflection;
    grpc::reflection::InitProtoReflectionServerBuilderPlugin();
    grpc::ServerBuilder builder;
    if (!reflection) builder.SetOption(std::make_unique<WithoutReflection>());
    int port = 0;
    builder.AddListeningPort(flags.listen, credentials, &port);
    builder.SetMaxReceiveMessageSize(static_cast<int>(flags.max_message_bytes));
    builder.SetMaxSendMessageSize(static_cast<int>(flags.max_message_bytes));
    builder.RegisterService(&service);
    std::unique_ptr<grpc::Server> server = builder.BuildAndStart();
    if (!server || port == 0) {
      spdlog::error("cannot listen on {} (--listen) with {}", flags.listen,
                    hgraph::server::TransportModeName(transport));
      return 2;
    }
    grpc::HealthCheckServiceInterface* health = server->GetHealthCheckService();
    health->SetServingStatus("hgraph.v1.PathMerger", true);
    // Health only, in plaintext: it says whether this process serves and nothing else, so it
    // needs neither TLS nor a token.
    HealthOnly health_only;  // outlives health_server
    std::unique_ptr<grpc::Server> health_server;
    int health_port = 0;
    if (!flags.health_listen.empty()) {
      grpc::ServerBuilder health_builder;
      health_builder.SetOption(std::make_unique<WithoutReflection>());
      health_builder.RegisterCallbackGenericService(&health_only);
      health_builder.AddListeningPort(flags.health_listen, grpc::InsecureServerCredentials(),
                                      &health_port);
      health_server = health_builder.BuildAndStart();
      if (!health_server || health_port == 0) {
        spdlog::error("cannot listen on {} (--health-listen)", flags.health_listen);
        server->Shutdown();
        return 2;
      }
      health_server->GetHealthCheckService()->SetServingStatus("hgraph.v1.PathMerger", true);
    }
    const auto set_health = [&](bool serving) {
      health->SetServingStatus(serving);
      if (health_server) health_server->GetHealthCheckService()->SetServingStatus(serving);
    };

    std::unique_ptr<hgraph::server::MetricsHttpServer> metrics_http;
    if (!flags.metrics_listen.empty()) {
      metrics_http =
          std::make_unique<hgraph::server::MetricsHttpServer>(metrics, flags.metrics_listen);
    }
    const int metrics_port = metrics_http ? metrics_http->port() : 0;
    spdlog::info(
        "serving on port {} ({}, {}) with {} worker threads; metrics on port {}; health on port "
        "{}",
        port, hgraph::server::TransportModeName(transport),
        options.auth.enabled() ? "bearer tokens required" : "no authentication", options.threads,
        metrics_port, health_port);
    // One machine-readable line on stdout for scripts and tests that start the server.
    std::printf("hgraph-server ready grpc_port=%d metrics_port=%d health_port=%d\n", port,
                metrics_port, health_port);
    std::fflush(stdout);

    // The main thread waits for a signal and expires idle sessions and uploads once a second.
    const timespec tick{.tv_sec = 1, .tv_nsec = 0};
    int signal = -1;
    while (signal < 0) {
      signal = sigtimedwait(&signals, nullptr, &tick);
      if (signal < 0) {
        service.ExpireIdleSessions();
        service.ExpireIdleUploads();
        service.SyncStore();
      }
    }
    spdlog::info("received signal {}: draining for {} s, then shutting down (grace {} s)", signal,
                 flags.drain_s, flags.grace_s);
    set_health(false);
    // The drain: NOT_SERVING, but every call is still accepted and served.
    const auto drain_end = std::chrono::steady_clock::now() +
                           std::chrono::milliseconds(static_cast<int64_t>(flags.drain_s * 1e3));
    for (;;) {
      const auto left = std::chrono::duration_cast<std::chrono::nanoseconds>(
          drain_end - std::chrono::steady_clock::now());
      if (left.count() <= 0) break;
      const timespec wait{.tv_sec = static_cast<time_t>(left.count() / 1000000000),
                          .tv_nsec = static_cast<long>(left.count() % 1000000000)};
      const int again = sigtimedwait(&signals, nullptr, &wait);
      if (again > 0) {
        spdlog::info("received signal {} while draining: shutting down now", again);
        break;
      }
    }
    const auto grace = std::chrono::system_clock::now() +
                       std::chrono::milliseconds(static_cast<int64_t>(flags.grace_s * 1e3));
    // Merges that outlived their clients (hgraph_id) stop now: nobody could fetch their result.
    service.BeginShutdown();
    // Refuses new calls at once; cancels calls still running at the deadline, which stops their
    // merges through the cancel token.
    server->Shutdown(grace);
    server->Wait();
    if (health_server) health_server->Shutdown();
    service.WaitIdle();
    spdlog::info("shut down cleanly");
  } catch (const hgraph::Error& e) {
    spdlog::error("{}", e.what());
    return 2;
  }
  return 0;
}
