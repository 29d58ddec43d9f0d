#include "client/cli/remote.h"

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "client/cli/cli_common.h"
#include "core/adapter/json_io.h"
#include "core/adapter/merge_proto.h"
#include "core/adapter/ompl_cfg.h"
#include "core/adapter/path_io.h"
#include "core/adapter/scene_proto.h"
#include "core/common/digest.h"
#include "core/common/error.h"
#include "core/common/file_bytes.h"
#include "core/hgraph/bridge_candidates.h"
#include "core/measure/measure.h"
#include "server/status/status.h"

namespace hgraph::cli {
namespace {

// Well under gRPC's default 4 MiB message limit.
constexpr size_t kChunkBytes = size_t{1} << 20;

// True for the codes that say the request was judged and rejected (exit 2); every other code
// means the server was unreachable or failed (exit 3).
bool RejectsRequest(grpc::StatusCode code) {
  switch (code) {
    case grpc::StatusCode::INVALID_ARGUMENT:
    case grpc::StatusCode::NOT_FOUND:
    case grpc::StatusCode::RESOURCE_EXHAUSTED:
    case grpc::StatusCode::FAILED_PRECONDITION:
    case grpc::StatusCode::OUT_OF_RANGE:
    case grpc::StatusCode::ALREADY_EXISTS:
    case grpc::StatusCode::PERMISSION_DENIED:
    case grpc::StatusCode::UNAUTHENTICATED: return true;
    default: return false;
  }
}

void Check(const grpc::Status& status, const char* method) {
  if (status.ok()) return;
  const std::string message = std::string(GrpcCodeName(status.error_code())) + " from " + method +
                              ": " + status.error_message();
  if (!RejectsRequest(status.error_code())) {
    throw ServerFailure(FromGrpcCode(status.error_code()), "", message);
  }
  throw Error(FromGrpcCode(status.error_code()), "", message);
}

v1::Digest DigestOf(const std::string& bytes) {
  v1::Digest digest;
  digest.set_sha256(Sha256Hex(bytes));
  digest.set_size_bytes(static_cast<int64_t>(bytes.size()));
  return digest;
}

}  // namespace

void AddServerFlags(CLI::App* app, RemoteOptions* remote, ServerFlag server) {
  // Without --server a subcommand that may take it runs in process.
  CLI::Option* address =
      app->add_option("--server", remote->server, "Run through hgraph-server at HOST:PORT");
  if (server == ServerFlag::kRequired) address->required();
  app->add_option("--timeout", remote->timeout_s,
                  "With --server: deadline per call, seconds (0 = none)")
      ->capture_default_str();
  app->add_option("--tls-ca", remote->tls_ca,
                  "With --server: TLS, verifying the server's certificate against this PEM CA");
  app->add_option("--tls-cert", remote->tls_cert,
                  "With --server: TLS with this PEM client certificate (mutual TLS; with "
                  "--tls-key)");
  app->add_option("--tls-key", remote->tls_key, "With --server: PEM private key of --tls-cert");
  app->add_option("--token", remote->token,
                  "With --server: bearer token sent as \"authorization: Bearer TOKEN\" (prefer "
                  "$HGRAPH_TOKEN: a flag shows in the process list)")
      ->envname("HGRAPH_TOKEN");
}

std::shared_ptr<grpc::Channel> OpenChannel(const RemoteOptions& remote) {
  if (remote.tls_cert.empty() != remote.tls_key.empty()) {
    throw InputError(remote.tls_cert.empty() ? "--tls-cert" : "--tls-key",
                     "--tls-cert and --tls-key go together (the client certificate of mutual "
                     "TLS and its key)");
  }
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(64 << 20);
  args.SetMaxSendMessageSize(64 << 20);
  std::shared_ptr<grpc::ChannelCredentials> credentials = grpc::InsecureChannelCredentials();
  if (!remote.tls_ca.empty() || !remote.tls_cert.empty()) {
    grpc::SslCredentialsOptions tls;
    if (!remote.tls_ca.empty()) tls.pem_root_certs = ReadFileBytes(remote.tls_ca, "--tls-ca");
    if (!remote.tls_cert.empty()) {
      tls.pem_cert_chain = ReadFileBytes(remote.tls_cert, "--tls-cert");
      tls.pem_private_key = ReadFileBytes(remote.tls_key, "--tls-key");
    }
    credentials = grpc::SslCredentials(tls);
  }
  return grpc::CreateCustomChannel(remote.server, credentials, args);
}

void PrepareCall(const RemoteOptions& remote, grpc::ClientContext* context) {
  if (!remote.token.empty()) {
    // Visible ASCII only: anything else cannot travel in a header (and would be a typo).
    for (const char c : remote.token) {
      if (c <= 0x20 || c >= 0x7f) {
        throw InputError("--token", "must be visible ASCII characters without blanks");
      }
    }
    context->AddMetadata("authorization", "Bearer " + remote.token);
  }
  if (remote.timeout_s > 0) {
    context->set_deadline(std::chrono::system_clock::now() +
                          std::chrono::milliseconds(static_cast<int64_t>(remote.timeout_s * 1e3)));
  }
}

RemoteClient::RemoteClient(const RemoteOptions& remote)
    : remote_(remote),
      channel_(OpenChannel(remote)),
      stub_(v1::PathMerger::NewStub(channel_)),
      session_(remote.session.empty() ? "sessions/" + RandomHex128() : remote.session) {}

void RemoteClient::Prepare(grpc::ClientContext* context) const {
  context->AddMetadata("x-hgraph-session", session_);
  PrepareCall(remote_, context);
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
    // No extension: the format stays unset and the server names the mesh in its error.
    if (mesh->format().empty() && file.has_extension()) {
      mesh->set_format(file.extension().string().substr(1));
    }
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
  create.set_session_id(session_.substr(session_.find('/') + 1));
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

v1::AddPathsResponse RemoteClient::AddPaths(const v1::AddPathsRequest& request) {
  grpc::ClientContext context;
  Prepare(&context);
  v1::AddPathsResponse response;
  Check(stub_->AddPaths(&context, request, &response), "AddPaths");
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

v1::SolveResponse RemoteClient::Solve(
    const v1::SolveRequest& request,
    const std::function<void(const v1::SolveProgress&)>& on_progress) {
  grpc::ClientContext context;
  Prepare(&context);
  auto reader = stub_->Solve(&context, request);
  v1::SolveResponse event;
  v1::SolveResponse result;
  while (reader->Read(&event)) {
    if (event.has_result()) {
      result = std::move(event);
      event.Clear();
    } else {
      on_progress(event.progress());
    }
  }
  Check(reader->Finish(), "Solve");
  return result;
}

// The same table as the in-process merge, from the proto result.
void PrintRemoteResult(const v1::MergeResult& r, const std::string& hgraph) {
  PrintMergeTable(MergeResultFromProto(r));
  if (!hgraph.empty()) std::printf("hgraph %s\n", hgraph.c_str());
}

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

PathChecker RemotePathChecker(const RemoteOptions& remote, const std::string& scene_file) {
  struct State {
    explicit State(const RemoteOptions& remote) : client(remote) {}
    RemoteClient client;
    std::string session;
  };
  auto state = std::make_shared<State>(remote);
  return [state, remote, scene_file](const std::vector<InputPath>& paths,
                                     const CheckSettings& settings) {
    if (state->session.empty()) {
      v1::Scene scene;
      state->session = OpenSceneFile(state->client, scene_file, remote, &scene);
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

Subcommand PathCheckingSubcommand(CLI::App* app, std::function<int(const PathChecker&)> run_checked,
                                  std::shared_ptr<const std::string> scene_file) {
  return Subcommand{.app = app,
                    .run = [run_checked] { return run_checked({}); },
                    .run_checked = run_checked,
                    .run_remote =
                        [run_checked, scene_file](const RemoteOptions& remote) {
                          return run_checked(RemotePathChecker(remote, *scene_file));
                        }};
}

Subcommand WithServer(Subcommand local) {
  HGRAPH_CHECK(local.run_remote);
  auto remote = std::make_shared<RemoteOptions>();
  CLI::App* app = local.app;
  AddServerFlags(app, remote.get(), ServerFlag::kOptional);
  app->add_option("--session", remote->session,
                  "With --server: reuse this session (sessions/<id>) instead of creating one");
  auto run_local = std::move(local.run);
  auto run_remote = local.run_remote;
  local.run = [remote, run_local, run_remote] {
    return remote->server.empty() ? run_local() : run_remote(*remote);
  };
  return local;
}

}  // namespace hgraph::cli
