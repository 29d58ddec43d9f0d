// `hgraph import-cfg`: an OMPL.app problem (.cfg + COLLADA meshes) as a Scene JSON file.
#include <cstdio>
#include <filesystem>
#include <string>

#include "client/cli/command.h"
#include "client/cli/remote.h"
#include "core/adapter/json_io.h"
#include "core/adapter/ompl_cfg.h"
#include "core/adapter/scene_proto.h"
#include "core/common/error.h"

namespace hgraph::cli {
namespace {

struct ImportCfgFlags {
  std::string cfg;
  std::string out;
};

int RunImportCfg(const ImportCfgFlags& f) {
  if (f.out.empty()) throw InputError("--out", "is required unless --server is given");
  v1::Scene scene = ReadOmplAppProblem(f.cfg);
  // Build it once so that a problem that would not load is reported now, not at the first merge.
  SceneFromProto(scene, std::filesystem::path(f.cfg).parent_path().string(), BlobResolver());
  // The meshes stay where they are, referenced relative to the new file.
  RebaseMeshPaths(std::filesystem::path(f.cfg).parent_path().string(),
                  std::filesystem::path(f.out).parent_path().string(), &scene);
  WriteTextFile(f.out, ToJson(scene));
  std::printf("wrote %s: %s, space %s, robot %s, world %s\n", f.out.c_str(), scene.name().c_str(),
              scene.space().components(0).type() == v1::Component::TYPE_SE3 ? "SE(3)" : "SE(2)",
              scene.robot(0).shape().mesh().path().c_str(),
              scene.obstacles(0).shape().mesh().path().c_str());
  return kExitOk;
}

// The import runs here (and writes --out if given); the scene goes to the server with its meshes
// as blobs. It goes as the --out file will read back: JSON does not keep every bit of a message
// (-0 reads back as 0), and a later `--session ... --scene <out>` must find the same digest.
int RunRemoteImportCfg(const ImportCfgFlags& f, const RemoteOptions& remote) {
  if (!f.out.empty()) RunImportCfg(f);
  v1::Scene scene;
  ParseJson(ToJson(ReadOmplAppProblem(f.cfg)), f.cfg, &scene);
  RemoteClient client(remote);
  const v1::Digest digest =
      client.UploadScene(std::move(scene), std::filesystem::path(f.cfg).parent_path().string());
  const std::string session = client.OpenSession(digest, remote.session);
  std::printf("scene sha256 %s (%lld bytes) stored on %s\n", digest.sha256().c_str(),
              static_cast<long long>(digest.size_bytes()), remote.server.c_str());
  std::printf("session %s\n", session.c_str());
  return kExitOk;
}

}  // namespace

Subcommand AddImportCfgCommand(CLI::App& parent) {
  auto flags = std::make_shared<ImportCfgFlags>();
  CLI::App* app = parent.add_subcommand(
      "import-cfg",
      "Convert an OMPL.app problem (.cfg with COLLADA meshes) to a Scene JSON file; with "
      "--server, also store it (meshes as blobs) on the server and open a session on it.");
  app->add_option("cfg", flags->cfg, "OMPL.app problem file")->required();
  app->add_option("--out", flags->out,
                  "Scene JSON to write (meshes referenced by path); required without --server");
  return Subcommand{
      .app = app,
      .run = [flags] { return RunImportCfg(*flags); },
      .run_remote =
          [flags](const RemoteOptions& remote) { return RunRemoteImportCfg(*flags, remote); }};
}

}  // namespace hgraph::cli
