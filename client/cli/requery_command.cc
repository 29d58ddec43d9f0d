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
namespace {

// The flags of a call on a stored H-Graph: where it is, the measure, where the result goes.
struct StoredHGraphFlags {
  RemoteOptions remote;
  std::string hgraph;
  std::string out;
  MeasureFlags measure;
  bool report_clearance = false;

  void Add(CLI::App* app) {
    AddServerFlags(app, &remote, ServerFlag::kRequired);
    app->add_option("--hgraph", hgraph, "H-Graph name from a merge (sessions/<id>/hgraphs/<n>)")
        ->required();
    measure.Add(app);
    app->add_flag(
        "--report-clearance", report_clearance,
        "Profile the path's clearance for the report under length, for this query (without "
        "it: as the merge that built the H-Graph asked)");
    app->add_option("--out", out, "Write the MergeResult JSON here");
  }
  // The H-Graph's session names the replica that holds it.
  RemoteOptions Remote() const {
    RemoteOptions r = remote;
    r.session = hgraph.substr(0, hgraph.find("/hgraphs/"));
    return r;
  }
  v1::Measure Measure() const {
    try {
      return measure.ToProto();
    } catch (const Error& e) {
      measure.fields.Rethrow(e);
    }
  }
  int Finish(const v1::MergeResult& result, const std::string& name) const {
    if (!out.empty()) WriteTextFile(out, ToJson(result));
    PrintRemoteResult(result, name);
    return kExitOk;
  }
};

}  // namespace

Subcommand AddRequeryCommand(CLI::App& parent) {
  CLI::App* app =
      parent.add_subcommand("requery",
                            "Search an H-Graph kept by hgraph-server under another measure (no new "
                            "collision checks where stored clearance profiles suffice)");
  auto f = std::make_shared<StoredHGraphFlags>();
  f->Add(app);
  return Subcommand{app, [f] {
                      RemoteClient client(f->Remote());
                      v1::RequeryRequest request;
                      request.set_hgraph(f->hgraph);
                      *request.mutable_measure() = f->Measure();
                      if (f->report_clearance) request.set_report_clearance(true);
                      const v1::RequeryResponse response = client.Requery(request);
                      return f->Finish(response.result(), response.hgraph());
                    }};
}

Subcommand AddAddPathsCommand(CLI::App& parent) {
  CLI::App* app = parent.add_subcommand(
      "add-paths",
      "Add input paths to an H-Graph kept by hgraph-server (edges checked before are kept), then "
      "search it under a measure");
  auto f = std::make_shared<StoredHGraphFlags>();
  auto scene = std::make_shared<std::string>();
  auto paths = std::make_shared<std::string>();
  app->add_option("--scene", *scene,
                  "Scene JSON or OMPL.app problem (.cfg) of the H-Graph: reads OMPL text paths")
      ->required();
  app->add_option("--paths", *paths,
                  "Paths to add: PathSet JSON, or OMPL text (one configuration per line, blank "
                  "lines between paths)")
      ->required();
  f->Add(app);
  return Subcommand{app, [f, scene, paths] {
                      const Space space =
                          SpaceFromProto(ReadSceneFile(*scene).space(), "scene.space");
                      const std::vector<InputPath> added = LoadPathsFile(*paths, space);
                      if (added.empty())
                        throw InputError("--paths", "no paths in '" + *paths + "'");
                      RemoteClient client(f->Remote());
                      v1::AddPathsRequest request;
                      request.set_hgraph(f->hgraph);
                      *request.mutable_paths() = PathsToProto(added);
                      *request.mutable_measure() = f->Measure();
                      if (f->report_clearance) request.set_report_clearance(true);
                      const v1::AddPathsResponse response = client.AddPaths(request);
                      return f->Finish(response.result(), response.hgraph());
                    }};
}

}  // namespace hgraph::cli
