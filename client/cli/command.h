// The subcommands of the `hgraph` CLI. Each one registers its options on a CLI11 subcommand and
// returns the function that runs it; main() parses, picks the parsed subcommand and maps errors
// to exit codes. Adding a subcommand is one file and one line in main.cc.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>
#include <optional>
#include <vector>

#include "core/merge/path_check.h"

namespace hgraph::cli {

// Exit codes shared by every subcommand.
inline constexpr int kExitOk = 0;
inline constexpr int kExitCheckFailed = 1;  // the command ran; what it checked is not valid
inline constexpr int kExitBadInput = 2;     // any hgraph::Error, bad flags, unreadable files

// How a subcommand's paths are to be checked (core/merge/path_check.h).
struct CheckSettings {
  CheckMode mode = CheckMode::kCertified;
  std::optional<double> resolution;  // unset: the scene's, or 0.01
  double k = 3.0;
};

// A path check and the resolution it ran at.
struct CheckRun {
  PathCheckResult result;
  double resolution = 0;
};

// Checks paths in the subcommand's scene: in process (LocalPathChecker in cli_common.h) or with
// hgraph-server's CheckPaths (--server, remote.h). Throws hgraph::Error.
using PathChecker =
    std::function<CheckRun(const std::vector<InputPath>& paths, const CheckSettings& settings)>;

struct Subcommand {
  CLI::App* app = nullptr;
  // Runs after parsing; returns the exit code. Throws hgraph::Error for bad input.
  std::function<int()> run;
  // For subcommands whose engine work is checking paths (check, render): runs with the given
  // checker, or in process when it is empty. `run` is this with an empty checker; --server
  // passes the service's.
  std::function<int(const PathChecker&)> run_checked;
};

Subcommand AddMergeCommand(CLI::App& parent);
Subcommand AddCheckCommand(CLI::App& parent);
Subcommand AddPlanCommand(CLI::App& parent);
Subcommand AddRenderCommand(CLI::App& parent);
Subcommand AddImportCfgCommand(CLI::App& parent);

}  // namespace hgraph::cli
