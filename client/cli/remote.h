// `--server HOST:PORT`: the CLI's subcommands run through hgraph-server instead of in process.
// RemoteClient speaks hgraph.v1.PathMerger (uploads only the blobs the server lacks, creates or
// reuses a session); WithServer adds --server to an in-process subcommand and dispatches. What
// needs the engine runs on the server (merge, plan, the checks of check and render); what needs
// only the scene file runs here (drawing, --shortcut after a remote merge, reading .cfg files).
#pragma once

#include <grpcpp/grpcpp.h>

#include <functional>
#include <memory>
#include <string>

#include "client/cli/command.h"
#include "hgraph/v1/service.grpc.pb.h"

namespace hgraph::cli {

// One channel to a server. Failed calls throw hgraph::Error whose message starts with the
// canonical code ("NOT_FOUND: session: ..."). Not thread safe; not copyable.
class RemoteClient {
 public:
  // timeout_s > 0 sets a deadline on every call. Every call carries `session` (or, when it is
  // empty, the name of a new session chosen here: "sessions/<128 random bits>") in the
  // `x-hgraph-session` metadata, from the first upload on, so that a load balancer hashing on it
  // (deploy/nginx) sends the scene, the session and every later call to one replica.
  RemoteClient(const std::string& target, double timeout_s, const std::string& session = "");
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
  v1::CheckPathsResponse CheckPaths(const v1::CheckPathsRequest& request);
  // Calls on_path for each path as it arrives.
  void Plan(const v1::PlanPathsRequest& request,
            const std::function<void(const v1::PlanPathsResponse&)>& on_path);

 private:
  void Prepare(grpc::ClientContext* context) const;

  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<v1::PathMerger::Stub> stub_;
  double timeout_s_;
  std::string session_;
};

// What --server does for a subcommand.
enum class RemoteKind {
  kMerge,      // MergePaths (streamed progress); --svg and --shortcut run here on the result
  kPlan,       // PlanPaths (one progress line per path)
  kCheck,      // the subcommand's run_checked with CheckPaths as its checker
  kImportCfg,  // the local import (if --out is given), then the scene stored and a session opened
};

// Adds --server, --session and --timeout to `local`'s app; with --server set, its run goes
// through the service (reading the subcommand's own flags by name), else runs in process.
// kCheck requires local.run_checked.
Subcommand WithServer(Subcommand local, RemoteKind kind);

// Flags every remote call takes.
struct RemoteOptions {
  std::string server;   // HOST:PORT
  std::string session;  // reuse this session instead of creating one
  double timeout_s = 0;
};

// The merge table of the in-process `merge`, from a proto result, then "hgraph <name>".
void PrintRemoteResult(const v1::MergeResult& result, const std::string& hgraph);
// The measure from the subcommand's --measure, --k and --safety flags.
v1::Measure MeasureFromFlags(CLI::App* app);

// `hgraph requery --server HOST:PORT --hgraph NAME --measure M`.
Subcommand AddRequeryCommand(CLI::App& parent);
// `hgraph health --server ADDR` (health_command.cc).
Subcommand AddHealthCommand(CLI::App& parent);

}  // namespace hgraph::cli
