// The subcommands of the `hgraph` CLI. Each one registers its options on a CLI11 subcommand and
// returns the function that runs it; main() parses, picks the parsed subcommand and maps errors
// to exit codes. Adding a subcommand is one file and one line in main.cc.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>

namespace hgraph::cli {

// Exit codes shared by every subcommand.
inline constexpr int kExitOk = 0;
inline constexpr int kExitCheckFailed = 1;  // the command ran; what it checked is not valid
inline constexpr int kExitBadInput = 2;     // any hgraph::Error, bad flags, unreadable files

struct Subcommand {
  CLI::App* app = nullptr;
  // Runs after parsing; returns the exit code. Throws hgraph::Error for bad input.
  std::function<int()> run;
};

Subcommand AddMergeCommand(CLI::App& parent);
Subcommand AddCheckCommand(CLI::App& parent);
Subcommand AddPlanCommand(CLI::App& parent);
Subcommand AddRenderCommand(CLI::App& parent);
Subcommand AddImportCfgCommand(CLI::App& parent);

}  // namespace hgraph::cli
