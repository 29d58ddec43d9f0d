#include "client/cli/remote.h"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "client/cli/cli_common.h"
#include "client/cli/shortcut_step.h"
#include "core/adapter/json_io.h"
#include "core/adapter/merge_proto.h"
#include "core/adapter/ompl_cfg.h"
#include "core/adapter/path_io.h"
#include "core/adapter/scene_proto.h"
#include "core/common/digest.h"
#include "core/common/error.h"
#include "core/hgraph/bridge_candidates.h"
#include "core/measure/measure.h"

namespace hgraph::cli {
namespace {

// Well under gRPC's default 4 MiB message limit.
constexpr size_t kChunkBytes = size_t{1} << 20;

ErrorCode FromGrpc(grpc::StatusCode code) {
  switch (code) {
    case grpc::StatusCode::INVALID_ARGUMENT: return ErrorCode::kInvalidArgument;
    case grpc::StatusCode::NOT_FOUND: return ErrorCode::kNotFound;
    case grpc::StatusCode::CANCELLED: return ErrorCode::kCancelled;
    case grpc::StatusCode::DEADLINE_EXCEEDED: return ErrorCode::kDeadlineExceeded;
    case grpc::StatusCode::RESOURCE_EXHAUSTED: return ErrorCode::kResourceExhausted;
    default: return ErrorCode::kFailedPrecondition;
  }
}

const char* CodeName(grpc::StatusCode code) {
  switch (code) {
    case grpc::StatusCode::CANCELLED: return "CANCELLED";
    case grpc::StatusCode::INVALID_ARGUMENT: return "INVALID_ARGUMENT";
    case grpc::StatusCode::DEADLINE_EXCEEDED: return "DEADLINE_EXCEEDED";
    case grpc::StatusCode::NOT_FOUND: return "NOT_FOUND";
    case grpc::StatusCode::RESOURCE_EXHAUSTED: return "RESOURCE_EXHAUSTED";
    case grpc::StatusCode::FAILED_PRECONDITION: return "FAILED_PRECONDITION";
    case grpc::StatusCode::UNIMPLEMENTED: return "UNIMPLEMENTED";
    case grpc::StatusCode::UNAVAILABLE: return "UNAVAILABLE";
    case grpc::StatusCode::INTERNAL: return "INTERNAL";
    default: return "UNKNOWN";
  }
}

void Check(const grpc::Status& status, const char* method) {
  if (status.ok()) return;
  throw Error(FromGrpc(status.error_code()), "",
              std::string(CodeName(status.error_code())) + " from " + method + ": " +
                  status.error_message());
}

v1::Digest DigestOf(const std::string& bytes) {
  v1::Digest digest;
  digest.set_sha256(Sha256Hex(bytes));
  digest.set_size_bytes(static_cast<int64_t>(bytes.size()));
  return digest;
}

}  // namespace

RemoteClient::RemoteClient(const std::string& target, double timeout_s) : timeout_s_(timeout_s) {
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(64 << 20);
  args.SetMaxSendMessageSize(64 << 20);
  channel_ = grpc::CreateCustomChannel(target, grpc::InsecureChannelCredentials(), args);
  stub_ = v1::PathMerger::NewStub(channel_);
}

void RemoteClient::Prepare(grpc::ClientContext* context) const {
  if (timeout_s_ > 0) {
    context->set_deadline(std::chrono::system_clock::now() +
                          std::chrono::milliseconds(static_cast<int64_t>(timeout_s_ * 1e3)));
  }
}

v1::Digest RemoteClient::UploadScene(v1::Scene scene, const std::string& base_dir) {
  std::map<std::string, std::string> blobs;  // sha256 -> bytes
  v1::FindMissingBlobsRequest find;
  auto resolve = [&](v1::Shape* shape) {
    if (!shape->has_mesh() || !shape->mesh().has_path()) return;
    v1::MeshRef* mesh = shape->mutable_mesh();
    std::filesystem::path file = mesh->path();
    if (file.is_relative() && !base_dir.empty()) file = std::filesystem::path(base_dir) / file;
    std::string bytes = ReadTextFile(file.string());
    if (mesh->format().empty()) mesh->set_format(file.extension().string().substr(1));
    const v1::Digest digest = DigestOf(bytes);
    *mesh->mutable_digest() = digest;
    if (blobs.emplace(digest.sha256(), std::move(bytes)).second) *find.add_digests() = digest;
  };
  for (v1::Obstacle& obstacle : *scene.mutable_obstacles()) resolve(obstacle.mutable_shape());
  for (v1::RobotBody& body : *scene.mutable_robot()) resolve(body.mutable_shape());

  if (find.digests_size() > 0) {
    grpc::ClientContext context;
    Prepare(&context);
    v1::FindMissingBlobsResponse missing;
    Check(stub_->FindMissingBlobs(&context, find, &missing), "FindMissingBlobs");
    for (const v1::Digest& digest : missing.missing()) {
      const std::string& bytes = blobs.at(digest.sha256());
      grpc::ClientContext upload_context;
      Prepare(&upload_context);
      v1::UploadBlobResponse uploaded;
      auto writer = stub_->UploadBlob(&upload_context, &uploaded);
      for (size_t at = 0; at == 0 || at < bytes.size(); at += kChunkBytes) {
        v1::UploadBlobRequest chunk;
        if (at == 0) *chunk.mutable_digest() = digest;
        chunk.set_data(bytes.substr(at, kChunkBytes));
        if (!writer->Write(chunk)) break;  // the server finished early: Finish says why
      }
      writer->WritesDone();
      Check(writer->Finish(), "UploadBlob");
    }
  }
  grpc::ClientContext context;
  Prepare(&context);
  v1::PutSceneRequest put;
  *put.mutable_scene() = std::move(scene);
  v1::PutSceneResponse stored;
  Check(stub_->PutScene(&context, put, &stored), "PutScene");
  return stored.digest();
}

std::string RemoteClient::OpenSession(const v1::Digest& scene, const std::string& session) {
  grpc::ClientContext context;
  Prepare(&context);
  v1::Session out;
  if (!session.empty()) {
    v1::GetSessionRequest get;
    get.set_name(session);
    Check(stub_->GetSession(&context, get, &out), "GetSession");
    if (out.scene().sha256() != scene.sha256()) {
      throw InputError("--session",
                       session + " holds another scene (sha256 " + out.scene().sha256() + ")");
    }
    return out.name();
  }
  v1::CreateSessionRequest create;
  *create.mutable_scene() = scene;
  Check(stub_->CreateSession(&context, create, &out), "CreateSession");
  return out.name();
}

v1::MergePathsResponse RemoteClient::Merge(
    v1::MergePathsRequest request,
    const std::function<void(const v1::MergeProgress&)>& on_progress) {
  grpc::ClientContext context;
  Prepare(&context);
  auto reader = stub_->MergePaths(&context, request);
  v1::MergePathsResponse event;
  v1::MergePathsResponse result;
  while (reader->Read(&event)) {
    if (event.has_progress()) {
      if (on_progress) on_progress(event.progress());
    } else if (event.has_result()) {
      result = std::move(event);
    }
  }
  Check(reader->Finish(), "MergePaths");
  if (!result.has_result()) {
    throw Error(ErrorCode::kFailedPrecondition, "", "MergePaths ended without a result");
  }
  return result;
}

v1::RequeryResponse RemoteClient::Requery(const v1::RequeryRequest& request) {
  grpc::ClientContext context;
  Prepare(&context);
  v1::RequeryResponse response;
  Check(stub_->Requery(&context, request, &response), "Requery");
  return response;
}

v1::CheckPathsResponse RemoteClient::CheckPaths(const v1::CheckPathsRequest& request) {
  grpc::ClientContext context;
  Prepare(&context);
  v1::CheckPathsResponse response;
  Check(stub_->CheckPaths(&context, request, &response), "CheckPaths");
  return response;
}

void RemoteClient::Plan(const v1::PlanPathsRequest& request,
                        const std::function<void(const v1::PlanPathsResponse&)>& on_path) {
  grpc::ClientContext context;
  Prepare(&context);
  auto reader = stub_->PlanPaths(&context, request);
  v1::PlanPathsResponse event;
  while (reader->Read(&event)) on_path(event);
  Check(reader->Finish(), "PlanPaths");
}

namespace {

// Reads a flag of the wrapped subcommand by name (the in-process command owns its flags).
template <class T>
T Flag(CLI::App* app, const std::string& name, T fallback) {
  CLI::Option* option = app->get_option_no_throw(name);
  if (option == nullptr || option->count() == 0) return fallback;
  return option->as<T>();
}
bool Given(CLI::App* app, const std::string& name) {
  CLI::Option* option = app->get_option_no_throw(name);
  return option != nullptr && option->count() > 0;
}

}  // namespace

// The same table as the in-process merge, from the proto result.
void PrintRemoteResult(const v1::MergeResult& r, const std::string& hgraph) {
  PrintMergeTable(MergeResultFromProto(r));
  if (!hgraph.empty()) std::printf("hgraph %s\n", hgraph.c_str());
}

v1::Measure MeasureFromFlags(CLI::App* app) {
  const std::string name = Flag<std::string>(app, "--measure", "length");
  v1::Measure measure = MeasureToProto(MeasureSpec{.type = ParseMeasureType(name, "--measure")});
  measure.clear_k();
  if (Given(app, "--k")) measure.set_k(Flag<double>(app, "--k", 3));
  measure.set_safety(Flag<double>(app, "--safety", 0));
  return measure;
}

namespace {

// Uploads the scene file and opens the session; returns the session name and the scene.
std::string OpenSceneFile(RemoteClient& client, const std::string& scene_file,
                          const RemoteOptions& remote, v1::Scene* scene_out) {
  v1::Scene scene = ReadSceneFile(scene_file);
  *scene_out = scene;
  const v1::Digest digest = client.UploadScene(
      std::move(scene), std::filesystem::path(scene_file).parent_path().string());
  const std::string session = client.OpenSession(digest, remote.session);
  std::fprintf(stderr, "session %s\n", session.c_str());
  return session;
}

std::string OpenScene(RemoteClient& client, CLI::App* app, const RemoteOptions& remote,
                      v1::Scene* scene_out) {
  return OpenSceneFile(client, Flag<std::string>(app, "--scene", ""), remote, scene_out);
}

// CheckPaths as a PathChecker: the scene is uploaded and the session opened on the first check.
PathChecker RemotePathChecker(CLI::App* app, const RemoteOptions& remote) {
  struct State {
    explicit State(const RemoteOptions& remote) : client(remote.server, remote.timeout_s) {}
    RemoteClient client;
    std::string session;
  };
  auto state = std::make_shared<State>(remote);
  return [state, app, remote](const std::vector<InputPath>& paths, const CheckSettings& settings) {
    if (state->session.empty()) {
      v1::Scene scene;
      state->session = OpenScene(state->client, app, remote, &scene);
    }
    v1::CheckPathsRequest request;
    request.set_session(state->session);
    *request.mutable_paths() = PathsToProto(paths);
    if (settings.resolution) request.set_resolution(*settings.resolution);
    request.set_k(settings.k);
    request.set_sampled(settings.mode == CheckMode::kSampled);
    const v1::CheckPathsResponse response = state->client.CheckPaths(request);
    CheckRun run{.resolution = response.resolution()};
    for (const v1::InputReport& report : response.paths()) {
      run.result.paths.push_back(InputReportFromProto(report));
    }
    run.result.collision_checks = response.collision_checks();
    run.result.distance_queries = response.distance_queries();
    run.result.elapsed_ms = response.elapsed_ms();
    return run;
  };
}

int RunRemoteMerge(CLI::App* app, const RemoteOptions& remote) {
  RemoteClient client(remote.server, remote.timeout_s);
  v1::Scene scene;
  const std::string scene_file = Flag<std::string>(app, "--scene", "");
  const std::string session = OpenSceneFile(client, scene_file, remote, &scene);

  v1::MergePathsRequest request;
  request.set_session(session);
  const Space space = SpaceFromProto(scene.space(), "scene.space");
  const std::vector<InputPath> paths = LoadPathsFile(Flag<std::string>(app, "--paths", ""), space);
  *request.mutable_paths() = PathsToProto(paths);
  double resolution = 0;
  try {
    *request.mutable_measure() = MeasureFromFlags(app);
    v1::MergeOptions* options = request.mutable_options();
    options->set_variant(VariantToProto(
        ParseVariant(Flag<std::string>(app, "--variant", "edit-distance"), "--variant")));
    if (Given(app, "--radius")) options->set_radius(Flag<double>(app, "--radius", 0));
    if (Given(app, "--phi")) options->set_phi(Flag<int>(app, "--phi", 5));
    if (Given(app, "--gap-init")) options->set_gap_init(Flag<double>(app, "--gap-init", 0));
    if (Given(app, "--gap-extend")) options->set_gap_extend(Flag<double>(app, "--gap-extend", 0));
    if (Given(app, "--resolution")) options->set_resolution(Flag<double>(app, "--resolution", 0));
    if (Given(app, "--endpoint-tolerance")) {
      options->set_endpoint_tolerance(Flag<double>(app, "--endpoint-tolerance", 0));
    }
    if (Given(app, "--max-node-spacing")) {
      options->set_max_node_spacing(Flag<double>(app, "--max-node-spacing", 0));
    }
    options->set_evaluation(ParseEvaluation(Flag<std::string>(app, "--evaluation", "lazy"),
                                            "--evaluation") == Evaluation::kEager
                                ? v1::EVALUATION_EAGER
                                : v1::EVALUATION_LAZY);
    options->set_report_inputs(Flag<bool>(app, "--report-inputs", false));
    if (Given(app, "--optimize-ms"))
      options->set_optimize_ms(Flag<double>(app, "--optimize-ms", 0));
    options->set_threads(Flag<int>(app, "--threads", 0));
    // The resolution the server will use, for --shortcut here.
    resolution = ResolutionFromProto(*options, scene);
  } catch (const Error& e) {
    RethrowWithFlag(e, {{"measure.k", "--k"},
                        {"measure.safety", "--safety"},
                        {"options.resolution", "--resolution"}});
  }

  ProgressPrinter printer(!Flag<bool>(app, "--quiet", false));
  const ProgressCallback report = printer.callback();
  const v1::MergePathsResponse response = client.Merge(request, [&](const v1::MergeProgress& p) {
    if (!report) return;  // --quiet
    report(Progress{.phase = p.phase(),
                    .done = p.done(),
                    .total = p.total(),
                    .collision_checks = p.collision_checks(),
                    .distance_queries = p.distance_queries(),
                    .elapsed_ms = p.elapsed_ms()});
  });
  printer.Finish();

  const std::string out = Flag<std::string>(app, "--out", "");
  if (!out.empty()) WriteTextFile(out, ToJson(response.result()));
  // --shortcut and --svg need the scene, which this side holds: they run here, on the result.
  const MergeResult result = MergeResultFromProto(response.result());
  const bool shortcut = Flag<bool>(app, "--shortcut", false);
  const std::string svg = Flag<std::string>(app, "--svg", "");
  std::optional<LoadedScene> loaded;
  ShortcutStep step;
  if (shortcut) {
    loaded.emplace(LoadScene(scene, scene_file, resolution));
    step = ShortcutMergedPath(*loaded->planner, result, result.measure, resolution,
                              Flag<uint64_t>(app, "--shortcut-seed", 1));
  }
  const std::string out_path = Flag<std::string>(app, "--out-path", "");
  if (!out_path.empty()) WritePathsFile(out_path, {shortcut ? step.path : result.path});
  if (!svg.empty()) {
    const std::shared_ptr<const Scene> drawn =
        loaded ? loaded->scene
               : SceneFromProto(scene, std::filesystem::path(scene_file).parent_path().string(),
                                BlobResolver());
    WriteTextFile(svg, RenderSvg(*drawn, MergePicture(paths, result, shortcut ? &step : nullptr)));
  }
  PrintRemoteResult(response.result(), response.hgraph());
  if (shortcut) PrintShortcutRow(step, result);
  return kExitOk;
}

int RunRemotePlan(CLI::App* app, const RemoteOptions& remote) {
  RemoteClient client(remote.server, remote.timeout_s);
  v1::Scene scene;
  v1::PlanPathsRequest request;
  request.set_session(OpenScene(client, app, remote, &scene));
  request.set_planner(Flag<std::string>(app, "--planner", ""));
  request.set_count(Flag<int>(app, "--count", 1));
  request.set_time_per_path_s(Flag<double>(app, "--time", 0));
  request.set_seed(Flag<uint64_t>(app, "--seed", 1));
  request.set_simplify(Flag<bool>(app, "--simplify", false));
  // Progress: a bar on a terminal, a line per path otherwise (stderr), as for a merge.
  ProgressPrinter printer(!Flag<bool>(app, "--quiet", false));
  const ProgressCallback report = printer.callback();
  const auto started = std::chrono::steady_clock::now();
  const auto progress = [&](int64_t done) {
    if (!report) return;
    report(Progress{.phase = "plan",
                    .done = done,
                    .total = request.count(),
                    .elapsed_ms = std::chrono::duration<double, std::milli>(
                                      std::chrono::steady_clock::now() - started)
                                      .count()});
  };
  progress(0);
  std::vector<InputPath> paths;
  client.Plan(request, [&](const v1::PlanPathsResponse& event) {
    v1::PathSet one;
    *one.add_paths() = event.path();
    paths.push_back(PathsFromProto(one).front());
    progress(static_cast<int64_t>(paths.size()));
    printer.Finish();
    std::printf("%s: %d waypoints, %.1f ms\n", event.path().name().c_str(),
                event.path().waypoints_size(), event.elapsed_ms());
    std::fflush(stdout);
  });
  printer.Finish();
  const std::string out = Flag<std::string>(app, "--out", "");
  if (!out.empty()) WritePathsFile(out, paths);
  std::printf("%zu paths planned\n", paths.size());
  return kExitOk;
}

// The import ran here (and wrote --out if given); the scene goes to the server with its meshes
// as blobs. It goes as the --out file will read back: JSON does not keep every bit of a message
// (-0 reads back as 0), and a later `--session ... --scene <out>` must find the same digest.
int RunRemoteImportCfg(CLI::App* app, const RemoteOptions& remote) {
  const std::string cfg = Flag<std::string>(app, "cfg", "");
  v1::Scene scene;
  ParseJson(ToJson(ReadOmplAppProblem(cfg)), cfg, &scene);
  RemoteClient client(remote.server, remote.timeout_s);
  const v1::Digest digest =
      client.UploadScene(std::move(scene), std::filesystem::path(cfg).parent_path().string());
  const std::string session = client.OpenSession(digest, remote.session);
  std::printf("scene sha256 %s (%lld bytes) stored on %s\n", digest.sha256().c_str(),
              static_cast<long long>(digest.size_bytes()), remote.server.c_str());
  std::printf("session %s\n", session.c_str());
  return kExitOk;
}

}  // namespace

Subcommand WithServer(Subcommand local, RemoteKind kind) {
  HGRAPH_CHECK(kind != RemoteKind::kCheck || local.run_checked);
  auto remote = std::make_shared<RemoteOptions>();
  CLI::App* app = local.app;
  app->add_option("--server", remote->server,
                  "Run through hgraph-server at HOST:PORT instead of in process");
  app->add_option("--session", remote->session,
                  "With --server: reuse this session (sessions/<id>) instead of creating one");
  app->add_option("--timeout", remote->timeout_s, "With --server: deadline per call, seconds");
  auto run_local = std::move(local.run);
  auto run_checked = local.run_checked;
  local.run = [app, kind, remote, run_local, run_checked] {
    if (remote->server.empty()) return run_local();
    switch (kind) {
      case RemoteKind::kMerge: return RunRemoteMerge(app, *remote);
      case RemoteKind::kPlan: return RunRemotePlan(app, *remote);
      case RemoteKind::kCheck: return run_checked(RemotePathChecker(app, *remote));
      case RemoteKind::kImportCfg:
        if (Given(app, "--out")) run_local();
        return RunRemoteImportCfg(app, *remote);
    }
    return kExitBadInput;
  };
  return local;
}

}  // namespace hgraph::cli
