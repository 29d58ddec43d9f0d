// `--server HOST:PORT`: the CLI's subcommands run through hgraph-server instead of in process.
// RemoteClient speaks hgraph.v1.PathMerger (uploads only the blobs the server lacks, creates or
// reuses a session); WithServer adds --server to an in-process subcommand and dispatches. What
// needs the engine runs on the server (merge, plan, the checks of check and render); what needs
// only the scene file runs here (drawing, reading .cfg files).
#pragma once

#include <grpcpp/grpcpp.h>

#include <functional>
#include <memory>
#include <string>

#include "client/cli/command.h"
#include "core/common/error.h"
#include "hgraph/v1/service.grpc.pb.h"

namespace hgraph::cli {

// Whether a subcommand needs --server (requery, add-paths, health) or runs in process without it.
enum class ServerFlag { kOptional, kRequired };
// Registers the flags of every subcommand that talks to a server, each with one help text:
// --server, --timeout (a default already in *remote is shown), --tls-ca, --tls-cert, --tls-key
// and --token (also read from $HGRAPH_TOKEN; the flag wins).
void AddServerFlags(CLI::App* app, RemoteOptions* remote, ServerFlag server);

// A channel to remote.server: TLS when --tls-ca or --tls-cert is given (the server's certificate
// is verified against --tls-ca, or the system's roots without it), plaintext otherwise. Throws
// InputError naming the flag for a lone --tls-cert or --tls-key and Error(kNotFound) for an
// unreadable file.
std::shared_ptr<grpc::Channel> OpenChannel(const RemoteOptions& remote);

// Adds `authorization: Bearer <token>` when remote has a token (InputError("--token") if it
// cannot travel in a header), and the deadline of remote.timeout_s when it is > 0.
void PrepareCall(const RemoteOptions& remote, grpc::ClientContext* context);

// One channel to a server. Failed calls throw hgraph::Error whose message starts with the
// canonical code ("NOT_FOUND: session: ..."). Not thread safe; not copyable.
class RemoteClient {
 public:
  // The connection of `remote` (OpenChannel, PrepareCall). Every call carries remote.session
  // (or, when it is empty, the name of a new session chosen here: "sessions/<128 random bits>")
  // in the `x-hgraph-session` metadata, from the first upload on, so that a load balancer
  // hashing on it (deploy/nginx) sends the scene, the session and every later call to one
  // replica.
  explicit RemoteClient(const RemoteOptions& remote);
  RemoteClient(const RemoteClient&) = delete;
  RemoteClient& operator=(const RemoteClient&) = delete;

  // Replaces file-path meshes (relative to base_dir) by digests, uploads the missing blobs in
  // chunks, stores the scene and returns its digest.
  v1::Digest UploadScene(v1::Scene scene, const std::string& base_dir);
  // `session` if given (checked with GetSession), else a new session on the scene under the
  // name chosen at construction (CreateSessionRequest.session_id).
  std::string OpenSession(const v1::Digest& scene, const std::string& session);
  // The name sent in `x-hgraph-session`.
  const std::string& session() const { return session_; }

  // Streams the merge; on_progress sees every progress event.
  v1::MergePathsResponse Merge(v1::MergePathsRequest request,
                               const std::function<void(const v1::MergeProgress&)>& on_progress);
  v1::RequeryResponse Requery(const v1::RequeryRequest& request);
  v1::AddPathsResponse AddPaths(const v1::AddPathsRequest& request);
  v1::CheckPathsResponse CheckPaths(const v1::CheckPathsRequest& request);
  // Calls on_path for each path as it arrives.
  void Plan(const v1::PlanPathsRequest& request,
            const std::function<void(const v1::PlanPathsResponse&)>& on_path);
  // Streams a Solve; on_progress sees every progress event; returns the result event.
  v1::SolveResponse Solve(const v1::SolveRequest& request,
                          const std::function<void(const v1::SolveProgress&)>& on_progress);

 private:
  void Prepare(grpc::ClientContext* context) const;

  RemoteOptions remote_;
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<v1::PathMerger::Stub> stub_;
  std::string session_;
};

// A failed call the server is to blame for, or that never reached it (UNAVAILABLE, INTERNAL,
// DEADLINE_EXCEEDED, UNKNOWN, UNIMPLEMENTED, ...): main() exits kExitServerFailed for it.
class ServerFailure : public Error {
 public:
  using Error::Error;
};

// Adds the server flags (AddServerFlags) and --session to `local`'s app; with --server set,
// its run is local.run_remote (which it requires), else the in-process run.
Subcommand WithServer(Subcommand local);

// Uploads the scene file (meshes relative to its folder) and opens remote.session or a new
// session on it; prints "session <name>" on stderr and returns the name. *scene_out gets the
// scene as read.
std::string OpenSceneFile(RemoteClient& client, const std::string& scene_file,
                          const RemoteOptions& remote, v1::Scene* scene_out);

// CheckPaths as a PathChecker: the scene file is uploaded and the session opened on the first
// check.
PathChecker RemotePathChecker(const RemoteOptions& remote, const std::string& scene_file);

// The Subcommand of a subcommand whose engine work is checking paths in one scene file (check,
// render): `run_checked` with an empty checker in process, and with RemotePathChecker on
// *scene_file through --server. The file name is read when the subcommand runs, after parsing
// (share it with the flags that hold it: std::shared_ptr<const std::string>(flags, &flags->scene)).
Subcommand PathCheckingSubcommand(CLI::App* app, std::function<int(const PathChecker&)> run_checked,
                                  std::shared_ptr<const std::string> scene_file);

// The merge table of the in-process `merge`, from a proto result, then "hgraph <name>".
void PrintRemoteResult(const v1::MergeResult& result, const std::string& hgraph);

// `hgraph requery --server HOST:PORT --hgraph NAME --measure M`.
Subcommand AddRequeryCommand(CLI::App& parent);
// `hgraph add-paths --server HOST:PORT --hgraph NAME --scene S --paths P` (requery_command.cc).
Subcommand AddAddPathsCommand(CLI::App& parent);
// `hgraph health --server ADDR` (health_command.cc).
Subcommand AddHealthCommand(CLI::App& parent);

}  // namespace hgraph::cli
