// The subcommands of the `hgraph` CLI. Each one registers its options on a CLI11 subcommand and
// returns the function that runs it; main() parses, picks the parsed subcommand and maps errors
// to exit codes. Adding a subcommand is one file and one line in main.cc.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "core/merge/path_check.h"

namespace hgraph::cli {

// Exit codes shared by every subcommand, the same in process and with --server.
inline constexpr int kExitOk = 0;
// The command ran; what it checked is not valid, or it found less than it was asked for.
inline constexpr int kExitCheckFailed = 1;
inline constexpr int kExitBadInput = 2;  // any hgraph::Error, bad flags, unreadable files
// --server: the server could not be reached or failed (UNAVAILABLE, INTERNAL, DEADLINE_EXCEEDED,
// UNKNOWN, UNIMPLEMENTED, ...), as opposed to rejecting the request (exit 2).
inline constexpr int kExitServerFailed = 3;

// Flags every remote call takes (--server, --session, --timeout, and the connection's security:
// --tls-ca, --tls-cert, --tls-key, --token; remote.h registers and applies them).
struct RemoteOptions {
  std::string server;   // HOST:PORT
  std::string session;  // reuse this session instead of creating one
  double timeout_s = 0;
  std::string tls_ca;    // PEM CA that signed the server's certificate: TLS
  std::string tls_cert;  // PEM client certificate (mutual TLS), with tls_key
  std::string tls_key;
  std::string token;  // bearer token (or $HGRAPH_TOKEN): `authorization: Bearer <token>`
};

// How a subcommand's paths are to be checked (core/merge/path_check.h).
struct CheckSettings {
  CheckMode mode = CheckMode::kCertified;
  std::optional<double> resolution;  // unset: the scene's, or 0.01
  double k = kDefaultInverseClearanceK;
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
  // The same subcommand through hgraph-server: the same request builder, printout and exit
  // codes as `run`, with the engine work done by the service (WithServer in remote.h calls it
  // when --server is given).
  std::function<int(const RemoteOptions&)> run_remote;
  // Where -q/--quiet goes, for a subcommand that prints progress (main() registers the flag on
  // every subcommand); nullptr for one that prints none.
  bool* quiet = nullptr;
};

Subcommand AddMergeCommand(CLI::App& parent);
Subcommand AddCheckCommand(CLI::App& parent);
Subcommand AddPlanCommand(CLI::App& parent);
Subcommand AddSolveCommand(CLI::App& parent);
Subcommand AddRenderCommand(CLI::App& parent);
Subcommand AddViewCommand(CLI::App& parent);
Subcommand AddImportCfgCommand(CLI::App& parent);

}  // namespace hgraph::cli
