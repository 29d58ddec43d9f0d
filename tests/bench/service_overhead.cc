// The service's overhead: the same merge in process (LocalPlanner + Merge) and through
// hgraph-server's PathMergerService on a loopback gRPC channel (request encoding, admission,
// session and scene-cache lookups, the worker pool, streamed progress, result encoding, storing
// the H-Graph), alternated run by run, medians reported. Not a test: it prints, never asserts.
//
//   service_overhead [--runs N] [--density D] [--threads T]
//
// The merge: the two OMPL circle paths with every edge cut into D pieces, all-pairs variant,
// inverse-clearance measure (so every edge gets a clearance profile), T worker threads.
#include <grpcpp/grpcpp.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "core/adapter/merge_proto.h"
#include "core/adapter/path_io.h"
#include "core/adapter/scene_proto.h"
#include "core/collision/collision_world.h"
#include "core/merge/merge.h"
#include "core/motion/local_planner.h"
#include "hgraph/v1/service.grpc.pb.h"
#include "server/metrics.h"
#include "server/service.h"

namespace {

using Clock = std::chrono::steady_clock;

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

std::vector<hgraph::InputPath> Densify(const std::vector<hgraph::InputPath>& paths, int pieces) {
  std::vector<hgraph::InputPath> out;
  for (const hgraph::InputPath& path : paths) {
    hgraph::InputPath dense{.name = path.name};
    for (size_t j = 0; j + 1 < path.waypoints.size(); ++j) {
      for (int i = 0; i < pieces; ++i) {
        const double t = static_cast<double>(i) / pieces;
        dense.waypoints.push_back((1 - t) * path.waypoints[j] + t * path.waypoints[j + 1]);
      }
    }
    dense.waypoints.push_back(path.waypoints.back());
    out.push_back(std::move(dense));
  }
  return out;
}

void CheckOk(const grpc::Status& status, const char* what) {
  if (!status.ok()) {
    std::fprintf(stderr, "%s failed: %s\n", what, status.error_message().c_str());
    std::exit(1);
  }
}

}  // namespace

int main(int argc, char** argv) {
  int runs = 15;
  int density = 4;
  int threads = 2;
  CLI::App app("service_overhead: the same merge in process and through gRPC");
  app.add_option("--runs", runs, "measured runs of each")->capture_default_str();
  app.add_option("--density", density, "pieces each input edge is cut into")->capture_default_str();
  app.add_option("--threads", threads, "worker threads of both")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  spdlog::set_level(spdlog::level::warn);  // no per-request log lines in the timing

  const std::string scene_file = std::string(HGRAPH_SOURCE_DIR) + "/tests/data/circles/scene.json";
  const std::string paths_file = std::string(HGRAPH_SOURCE_DIR) + "/tests/data/circles/paths.txt";
  const hgraph::v1::Scene scene_proto = hgraph::ReadSceneFile(scene_file);
  auto scene = hgraph::SceneFromProto(scene_proto, "", {});
  auto world = std::make_shared<const hgraph::CollisionWorld>(scene);
  const std::vector<hgraph::InputPath> paths =
      Densify(hgraph::LoadPathsFile(paths_file, scene->space), density);

  hgraph::v1::Measure measure;
  measure.set_type(hgraph::v1::Measure::TYPE_INVERSE_CLEARANCE);
  hgraph::v1::MergeOptions options;
  options.set_variant(hgraph::v1::VARIANT_ALL_PAIRS);
  options.set_threads(threads);

  // In process: what a library user does with a loaded scene.
  auto in_process = [&] {
    const hgraph::LocalPlanner planner(
        world, {.resolution = hgraph::ResolutionFromProto(options, scene_proto)});
    hgraph::MergeRequest request{.paths = paths,
                                 .measure = hgraph::MeasureFromProto(measure),
                                 .options = hgraph::MergeOptionsFromProto(options)};
    const Clock::time_point start = Clock::now();
    const hgraph::MergeResult result = hgraph::Merge(planner, request);
    const double ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
    return std::make_pair(ms, result.stats.collision_checks);
  };

  // Through the service, on loopback, with the scene already uploaded (as in a session).
  hgraph::server::Metrics metrics;
  hgraph::server::PathMergerService service(
      hgraph::server::ServerOptions{.threads = threads, .max_paths = 1000}, metrics);
  grpc::ServerBuilder builder;
  int port = 0;
  builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
  builder.SetMaxReceiveMessageSize(64 << 20);
  builder.SetMaxSendMessageSize(64 << 20);
  builder.RegisterService(&service);
  std::unique_ptr<grpc::Server> server = builder.BuildAndStart();
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(64 << 20);
  auto channel = grpc::CreateCustomChannel("127.0.0.1:" + std::to_string(port),
                                           grpc::InsecureChannelCredentials(), args);
  auto stub = hgraph::v1::PathMerger::NewStub(channel);
  hgraph::v1::PutSceneResponse put;
  {
    grpc::ClientContext context;
    hgraph::v1::PutSceneRequest request;
    *request.mutable_scene() = scene_proto;
    CheckOk(stub->PutScene(&context, request, &put), "PutScene");
  }
  hgraph::v1::Session session;
  {
    grpc::ClientContext context;
    hgraph::v1::CreateSessionRequest request;
    *request.mutable_scene() = put.digest();
    CheckOk(stub->CreateSession(&context, request, &session), "CreateSession");
  }
  hgraph::v1::MergePathsRequest merge_request;
  merge_request.set_session(session.name());
  *merge_request.mutable_paths() = hgraph::PathsToProto(paths);
  *merge_request.mutable_measure() = measure;
  *merge_request.mutable_options() = options;
  auto through_grpc = [&] {
    const Clock::time_point start = Clock::now();
    grpc::ClientContext context;
    auto reader = stub->MergePaths(&context, merge_request);
    hgraph::v1::MergePathsResponse event;
    int64_t checks = 0;
    while (reader->Read(&event)) {
      if (event.has_result()) checks = event.result().stats().collision_checks();
    }
    CheckOk(reader->Finish(), "MergePaths");
    const double ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
    return std::make_pair(ms, checks);
  };

  // Warm-up (page faults, TBB thread start, connection set-up), then alternate.
  in_process();
  through_grpc();
  std::vector<double> local_ms, remote_ms;
  int64_t local_checks = 0, remote_checks = 0;
  for (int r = 0; r < runs; ++r) {
    auto [l, lc] = in_process();
    auto [g, gc] = through_grpc();
    local_ms.push_back(l);
    remote_ms.push_back(g);
    local_checks = lc;
    remote_checks = gc;
  }
  server->Shutdown();
  const double local = Median(local_ms), remote = Median(remote_ms);
  std::printf("merge: %zu paths x %zu waypoints, all-pairs, inverse-clearance, %d threads\n",
              paths.size(), paths.front().waypoints.size(), threads);
  std::printf("collision checks per merge: in-process %lld, gRPC %lld\n",
              static_cast<long long>(local_checks), static_cast<long long>(remote_checks));
  std::printf("median of %d runs: in-process %.2f ms, gRPC %.2f ms, ratio %.3f\n", runs, local,
              remote, remote / local);
  return 0;
}
