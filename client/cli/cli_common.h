// Helpers shared by the subcommands: loading a scene with its checker, progress on stderr, and
// number formatting for the human-readable tables.
#pragma once

#include <chrono>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "client/cli/command.h"
#include "client/cli/request_flags.h"
#include "core/collision/collision_world.h"
#include "core/common/error.h"
#include "core/common/progress.h"
#include "core/merge/merge.h"
#include "core/motion/local_planner.h"
#include "core/scene/scene.h"
#include "hgraph/v1/merge.pb.h"
#include "hgraph/v1/scene.pb.h"

namespace hgraph::cli {

// A scene file loaded and ready to check motions in. Not copyable (the planner points into the
// collision world).
struct LoadedScene {
  v1::Scene proto;
  std::shared_ptr<const Scene> scene;
  std::shared_ptr<const CollisionWorld> world;
  std::unique_ptr<LocalPlanner> planner;
  double resolution = 0;
};

// Builds the scene read from `path` (meshes relative to its folder), its collision world and a
// local planner at `resolution`. The proto is read first (ReadSceneFile) so that the caller can
// choose the resolution from it.
LoadedScene LoadScene(v1::Scene proto, const std::string& path, double resolution);

// Checks paths in process in the scene `proto` read from `scene_file` (meshes relative to its
// folder), with the engine's CheckPaths on all cores. The scene is built from the proto on first
// use unless the caller has built it already (`scene`).
PathChecker LocalPathChecker(v1::Scene proto, const std::string& scene_file,
                             std::shared_ptr<const Scene> scene = nullptr);

// `hgraph check`'s printout of a check, wherever it ran: one line per path (length and minimum
// clearance of each valid one, the first invalid edge of the others) and a summary. Returns
// kExitOk if every path is valid, else kExitCheckFailed.
int PrintCheck(const CheckRun& run, CheckMode mode);

// Prints progress reports on stderr. On a terminal one line is redrawn in place; otherwise
// (logs, CI) a plain line is written when a phase starts and then at most once a second.
// Thread safe: the engine reports from its worker threads.
class ProgressPrinter {
 public:
  explicit ProgressPrinter(bool enabled);
  ~ProgressPrinter();
  ProgressPrinter(const ProgressPrinter&) = delete;
  ProgressPrinter& operator=(const ProgressPrinter&) = delete;

  ProgressCallback callback();
  // Ends the redrawn line, if any, so that later output starts on a fresh line.
  void Finish();

 private:
  void Report(const Progress& progress);

  bool enabled_;
  bool tty_;
  std::mutex mutex_;
  std::string phase_;
  std::chrono::steady_clock::time_point last_print_;
  bool line_open_ = false;
};

// The human table of a merge: every input and the merged path under every measure, invalid
// inputs' first bad edge, the objective against the best input, stats and per-phase timing.
void PrintMergeTable(const MergeResult& result);

// --measure, --k and --safety, as merge and requery take them. Unset --k leaves measure.k unset
// (the engine's default). Not copyable.
struct MeasureFlags {
  std::string measure = "length";
  RequestFlags<v1::Measure> fields;  // --k, --safety

  void Add(CLI::App* app);
  // Throws InputError naming the flag.
  v1::Measure ToProto() const;
};

// Fixed-width number for tables: "inf" for infinity, "-" for NaN.
std::string Cell(double v, int width, int precision = 4);

}  // namespace hgraph::cli
