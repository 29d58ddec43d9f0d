#include <cstdio>
#include <exception>
#include <string>
#include <vector>

#include "client/cli/command.h"
#include "client/cli/remote.h"
#include "core/common/error.h"

int main(int argc, char** argv) {
  using namespace hgraph::cli;
  CLI::App app(
      "hgraph: merge motion paths into one path of higher quality (H-Graph path "
      "hybridization)",
      "hgraph");
  app.require_subcommand(1);
  std::vector<Subcommand> subcommands = {
      WithServer(AddMergeCommand(app)),
      WithServer(AddCheckCommand(app)),
      WithServer(AddPlanCommand(app)),
      WithServer(AddSolveCommand(app)),
      WithServer(AddRenderCommand(app)),
      WithServer(AddViewCommand(app)),
      WithServer(AddImportCfgCommand(app)),
      AddRequeryCommand(app),
      AddAddPathsCommand(app),
      AddHealthCommand(app),
  };
  // -q/--quiet is common to every subcommand, so that a script can pass the same flags to all of
  // them; those with no progress to hide (requery, check, ...) accept it and print as before.
  bool no_progress_anyway = false;
  for (Subcommand& sub : subcommands) {
    sub.app->add_flag("-q,--quiet", sub.quiet != nullptr ? *sub.quiet : no_progress_anyway,
                      "No progress on stderr");
  }

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "error: %s (see hgraph --help)\n", e.what());
    return kExitBadInput;
  }

  // Every failure leaves through here with a one-line message; the engine never aborts on input.
  try {
    for (const Subcommand& sub : subcommands) {
      if (sub.app->parsed()) return sub.run();
    }
  } catch (const ServerFailure& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return kExitServerFailed;
  } catch (const hgraph::Error& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return kExitBadInput;
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "error: out of memory\n");
    return kExitBadInput;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return kExitBadInput;
  }
  return kExitBadInput;
}
