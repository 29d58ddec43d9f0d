// `hgraph requery`: search an H-Graph kept by hgraph-server under another measure;
// `hgraph add-paths`: grow it with more input paths, then search it.
#include <memory>
#include <string>
#include <vector>

#include "client/cli/cli_common.h"
#include "client/cli/command.h"
#include "client/cli/remote.h"
#include "core/adapter/json_io.h"
#include "core/adapter/path_io.h"
#include "core/adapter/scene_proto.h"
#include "core/common/error.h"

namespace hgraph::cli {

Subcommand AddRequeryCommand(CLI::App& parent) {
  CLI::App* app =
      parent.add_subcommand("requery",
                            "Search an H-Graph kept by hgraph-server under another measure (no new "
                            "collision checks where stored clearance profiles suffice)");
  auto flags = std::make_shared<RemoteOptions>();
  auto hgraph = std::make_shared<std::string>();
  auto out = std::make_shared<std::string>();
  app->add_option("--server", flags->server, "hgraph-server at HOST:PORT")->required();
  app->add_option("--hgraph", *hgraph, "H-Graph name from a merge (sessions/<id>/hgraphs/<n>)")
      ->required();
  auto measure = std::make_shared<MeasureFlags>();
  measure->Add(app);
  app->add_option("--out", *out, "Write the MergeResult JSON here");
  app->add_option("--timeout", flags->timeout_s, "Deadline, seconds");
  AddConnectionFlags(app, flags.get());
  return Subcommand{app, [measure, flags, hgraph, out] {
                      // The H-Graph's session names the replica that holds it.
                      RemoteOptions remote = *flags;
                      remote.session = hgraph->substr(0, hgraph->find("/hgraphs/"));
                      RemoteClient client(remote);
                      v1::RequeryRequest request;
                      request.set_hgraph(*hgraph);
                      try {
                        *request.mutable_measure() = measure->ToProto();
                      } catch (const Error& e) {
                        RethrowWithFlag(e, {{"measure.k", "--k"}, {"measure.safety", "--safety"}});
                      }
                      const v1::RequeryResponse response = client.Requery(request);
                      if (!out->empty()) WriteTextFile(*out, ToJson(response.result()));
                      PrintRemoteResult(response.result(), response.hgraph());
                      return kExitOk;
                    }};
}

Subcommand AddAddPathsCommand(CLI::App& parent) {
  CLI::App* app = parent.add_subcommand(
      "add-paths",
      "Add input paths to an H-Graph kept by hgraph-server (edges checked before are kept), then "
      "search it under a measure");
  auto flags = std::make_shared<RemoteOptions>();
  auto hgraph = std::make_shared<std::string>();
  auto scene = std::make_shared<std::string>();
  auto paths = std::make_shared<std::string>();
  auto out = std::make_shared<std::string>();
  app->add_option("--server", flags->server, "hgraph-server at HOST:PORT")->required();
  app->add_option("--hgraph", *hgraph, "H-Graph name from a merge (sessions/<id>/hgraphs/<n>)")
      ->required();
  app->add_option("--scene", *scene,
                  "Scene JSON or OMPL.app problem (.cfg) of the H-Graph: reads OMPL text paths")
      ->required();
  app->add_option("--paths", *paths,
                  "Paths to add: PathSet JSON, or OMPL text (one configuration per line, blank "
                  "lines between paths)")
      ->required();
  auto measure = std::make_shared<MeasureFlags>();
  measure->Add(app);
  app->add_option("--out", *out, "Write the MergeResult JSON here");
  app->add_option("--timeout", flags->timeout_s, "Deadline, seconds");
  AddConnectionFlags(app, flags.get());
  return Subcommand{app, [measure, flags, hgraph, scene, paths, out] {
                      const Space space =
                          SpaceFromProto(ReadSceneFile(*scene).space(), "scene.space");
                      const std::vector<InputPath> added = LoadPathsFile(*paths, space);
                      if (added.empty())
                        throw InputError("--paths", "no paths in '" + *paths + "'");
                      RemoteOptions remote = *flags;
                      remote.session = hgraph->substr(0, hgraph->find("/hgraphs/"));
                      RemoteClient client(remote);
                      v1::AddPathsRequest request;
                      request.set_hgraph(*hgraph);
                      *request.mutable_paths() = PathsToProto(added);
                      try {
                        *request.mutable_measure() = measure->ToProto();
                      } catch (const Error& e) {
                        RethrowWithFlag(e, {{"measure.k", "--k"}, {"measure.safety", "--safety"}});
                      }
                      const v1::AddPathsResponse response = client.AddPaths(request);
                      if (!out->empty()) WriteTextFile(*out, ToJson(response.result()));
                      PrintRemoteResult(response.result(), response.hgraph());
                      return kExitOk;
                    }};
}

}  // namespace hgraph::cli
