// What the shared store (hgraph-server --store redis://...) costs and saves, on one large
// H-Graph: its snapshot's size, the time to write it to Redis and to read and load it back,
// against the time to merge it again; and a merge through PathMergerService with the store and
// without, alternated run by run, medians reported. Not a test: it prints, never asserts.
//
//   store_overhead --store redis://127.0.0.1:6379 [--runs N] [--density D] [--threads T]
//                  [--length]
//
// The merge: the two OMPL circle paths with every edge cut into D pieces (D = 10: about 30,000
// H-Graph edges), all-pairs, inverse clearance (--length: length, whose lazy merge checks so
// few edges of this point robot that it takes milliseconds: the least favourable case for the
// store, whose cost is per edge), T worker threads.
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
#include "core/merge/snapshot.h"
#include "core/motion/local_planner.h"
#include "hgraph/v1/service.grpc.pb.h"
#include "server/metrics.h"
#include "server/service.h"
#include "server/store.h"

namespace {

using Clock = std::chrono::steady_clock;

double Ms(Clock::time_point since) {
  return std::chrono::duration<double, std::milli>(Clock::now() - since).count();
}

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

// One in-process server on loopback with the given store (null: none), a session on the scene.
struct Replica {
  Replica(std::shared_ptr<hgraph::server::Store> store, int threads, const hgraph::v1::Scene& scene)
      : service(hgraph::server::ServerOptions{.threads = threads,
                                              .max_paths = 1000,
                                              .max_sessions = 100000,
                                              .store = std::move(store)},
                metrics) {
    grpc::ServerBuilder builder;
    int port = 0;
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
    builder.SetMaxReceiveMessageSize(64 << 20);
    builder.SetMaxSendMessageSize(64 << 20);
    builder.RegisterService(&service);
    server = builder.BuildAndStart();
    grpc::ChannelArguments args;
    args.SetMaxReceiveMessageSize(64 << 20);
    stub = hgraph::v1::PathMerger::NewStub(grpc::CreateCustomChannel(
        "127.0.0.1:" + std::to_string(port), grpc::InsecureChannelCredentials(), args));
    grpc::ClientContext put_context;
    hgraph::v1::PutSceneRequest put;
    *put.mutable_scene() = scene;
    hgraph::v1::PutSceneResponse digest;
    CheckOk(stub->PutScene(&put_context, put, &digest), "PutScene");
    grpc::ClientContext create_context;
    hgraph::v1::CreateSessionRequest create;
    *create.mutable_scene() = digest.digest();
    CheckOk(stub->CreateSession(&create_context, create, &session), "CreateSession");
  }
  ~Replica() { server->Shutdown(); }

  // The merge's time (ms) and answer.
  double Merge(hgraph::v1::MergePathsRequest request, hgraph::v1::MergePathsResponse* out) {
    request.set_session(session.name());
    const Clock::time_point start = Clock::now();
    grpc::ClientContext context;
    auto reader = stub->MergePaths(&context, request);
    hgraph::v1::MergePathsResponse event;
    while (reader->Read(&event)) {
      if (event.has_result()) *out = event;
    }
    CheckOk(reader->Finish(), "MergePaths");
    return Ms(start);
  }

  double Requery(const std::string& hgraph, const hgraph::v1::Measure& measure,
                 hgraph::v1::RequeryResponse* out) {
    const Clock::time_point start = Clock::now();
    grpc::ClientContext context;
    hgraph::v1::RequeryRequest request;
    request.set_hgraph(hgraph);
    *request.mutable_measure() = measure;
    CheckOk(stub->Requery(&context, request, out), "Requery");
    return Ms(start);
  }

  hgraph::server::Metrics metrics;
  hgraph::server::PathMergerService service;
  std::unique_ptr<grpc::Server> server;
  std::unique_ptr<hgraph::v1::PathMerger::Stub> stub;
  hgraph::v1::Session session;
};

}  // namespace

int main(int argc, char** argv) {
  int runs = 9;
  int density = 10;
  bool length = false;
  int threads = 2;
  std::string store_url;
  CLI::App app("store_overhead: what the shared store costs and saves on one large H-Graph");
  app.add_option("--store", store_url, "redis://HOST:PORT[/DB] of a Redis to use")->required();
  app.add_option("--runs", runs, "measured runs of each")->capture_default_str();
  app.add_option("--density", density, "pieces each input edge is cut into")->capture_default_str();
  app.add_option("--threads", threads, "worker threads")->capture_default_str();
  app.add_flag("--length", length, "merge under length instead of inverse clearance");
  CLI11_PARSE(app, argc, argv);
  spdlog::set_level(spdlog::level::warn);

  const std::string dir = std::string(HGRAPH_SOURCE_DIR) + "/tests/data/circles/";
  const hgraph::v1::Scene scene_proto = hgraph::ReadSceneFile(dir + "scene.json");
  auto scene = hgraph::SceneFromProto(scene_proto, "", {});
  auto world = std::make_shared<const hgraph::CollisionWorld>(scene);
  const std::vector<hgraph::InputPath> paths =
      Densify(hgraph::LoadPathsFile(dir + "paths.txt", scene->space), density);
  hgraph::v1::MergeOptions options;
  options.set_variant(hgraph::v1::VARIANT_ALL_PAIRS);
  options.set_threads(threads);
  options.set_optimize_ms(0);
  const hgraph::LocalPlanner planner(
      world, {.resolution = hgraph::ResolutionFromProto(options, scene_proto)});
  hgraph::v1::Measure measure;
  if (!length) measure.set_type(hgraph::v1::Measure::TYPE_INVERSE_CLEARANCE);
  const hgraph::MergeRequest request{.paths = paths,
                                     .measure = hgraph::MeasureFromProto(measure),
                                     .options = hgraph::MergeOptionsFromProto(options)};
  hgraph::server::RedisOptions redis{.address = hgraph::server::ParseStoreAddress(store_url),
                                     .timeout = std::chrono::seconds(10)};
  std::shared_ptr<hgraph::server::Store> store = hgraph::server::MakeRedisStore(redis);

  // 1. The snapshot in process: merge, save, write, read, load, query again.
  std::vector<double> merge_ms, save_ms, write_ms, read_ms, load_ms, query_ms;
  size_t bytes = 0;
  int edges = 0;
  for (int r = 0; r < runs; ++r) {
    Clock::time_point start = Clock::now();
    hgraph::HybridizationSession session(planner, request);
    session.Query(request.measure);
    merge_ms.push_back(Ms(start));
    edges = session.graph().num_edges();
    start = Clock::now();
    const std::string snapshot = hgraph::SaveSession(session);
    save_ms.push_back(Ms(start));
    bytes = snapshot.size();
    start = Clock::now();
    store->Set("hgraph:bench:snapshot", snapshot, std::chrono::minutes(5));
    write_ms.push_back(Ms(start));
    start = Clock::now();
    const std::string back = *store->Get("hgraph:bench:snapshot");
    read_ms.push_back(Ms(start));
    start = Clock::now();
    hgraph::HybridizationSession loaded = hgraph::LoadSession(planner, back);
    load_ms.push_back(Ms(start));
    start = Clock::now();
    const hgraph::MergeResult again = loaded.Query(request.measure);
    query_ms.push_back(Ms(start));
    if (again.stats.collision_checks != 0) std::fprintf(stderr, "the loaded query checked\n");
  }
  store->Delete({"hgraph:bench:snapshot"});
  std::printf("H-Graph: %zu paths x %zu waypoints, all-pairs, %s: %d edges\n", paths.size(),
              paths.front().waypoints.size(), length ? "length" : "inverse clearance", edges);
  std::printf("snapshot: %.2f MB (%.0f bytes per edge)\n", bytes / 1e6,
              static_cast<double>(bytes) / edges);
  std::printf(
      "median of %d runs (ms): merge %.1f | save %.1f, write %.1f | read %.1f, load %.1f, "
      "query %.2f\n",
      runs, Median(merge_ms), Median(save_ms), Median(write_ms), Median(read_ms), Median(load_ms),
      Median(query_ms));
  const double stored = Median(save_ms) + Median(write_ms);
  const double loading = Median(read_ms) + Median(load_ms) + Median(query_ms);
  std::printf(
      "write (save + SET) %.1f ms = %.3f of the merge; load (GET + load + query) %.1f ms "
      "= %.3f of merging again\n",
      stored, stored / Median(merge_ms), loading, loading / Median(merge_ms));

  // 2. Through the service: a merge without the store and with it, alternated; then a requery
  // on a replica that did not build the H-Graph (it loads it) against merging it again there.
  hgraph::v1::MergePathsRequest merge;
  *merge.mutable_paths() = hgraph::PathsToProto(paths);
  *merge.mutable_options() = options;
  *merge.mutable_measure() = measure;
  Replica plain(nullptr, threads, scene_proto);
  Replica shared(store, threads, scene_proto);
  Replica other(store, threads, scene_proto);
  hgraph::v1::MergePathsResponse answer;
  plain.Merge(merge, &answer);  // warm-up
  shared.Merge(merge, &answer);
  std::vector<double> plain_ms, shared_ms, requery_ms, remerge_ms;
  for (int r = 0; r < runs; ++r) {
    plain_ms.push_back(plain.Merge(merge, &answer));
    shared_ms.push_back(shared.Merge(merge, &answer));
    if (!answer.shared()) std::fprintf(stderr, "the merge was not stored\n");
    hgraph::v1::RequeryResponse requeried;
    // `other` holds the session after its first call; the H-Graph it loads.
    requery_ms.push_back(other.Requery(answer.hgraph(), merge.measure(), &requeried));
    if (requeried.result().stats().collision_checks() != 0) std::fprintf(stderr, "checked\n");
    hgraph::v1::MergePathsResponse remerged;
    remerge_ms.push_back(other.Merge(merge, &remerged));
  }
  std::printf(
      "through the service, median of %d runs (ms): merge without store %.1f, with %.1f "
      "(ratio %.3f); requery on another replica (load) %.1f, merge again there %.1f "
      "(ratio %.3f)\n",
      runs, Median(plain_ms), Median(shared_ms), Median(shared_ms) / Median(plain_ms),
      Median(requery_ms), Median(remerge_ms), Median(requery_ms) / Median(remerge_ms));
  return 0;
}
