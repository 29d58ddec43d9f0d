// Saved and loaded H-Graphs (core/merge/snapshot.h): a loaded session answers every query as
// the saved one does, and bytes that are not a snapshot are refused, never trusted.
#include "core/merge/snapshot.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <memory>
#include <string>

#include "core/collision/collision_world.h"
#include "core/motion/local_planner.h"
#include "tests/unit/test_scenes.h"

namespace hgraph {
namespace {

MeasureSpec Clearance() { return MeasureSpec{.type = MeasureType::kInverseClearance, .k = 2}; }

class SnapshotTest : public ::testing::Test {
 protected:
  SnapshotTest()
      : world_(std::make_shared<const CollisionWorld>(testing::CirclesScene())),
        planner_(world_, LocalPlannerOptions{.resolution = 0.01}) {}

  HybridizationSession Merged(Variant variant = Variant::kEditDistance) const {
    MergeRequest request{.paths = testing::CirclePaths(), .measure = MeasureSpec{}};
    request.options.candidates.variant = variant;
    request.options.optimize_ms = 0;
    HybridizationSession session(planner_, request);
    session.Query(request.measure);
    return session;
  }

  std::shared_ptr<const CollisionWorld> world_;
  LocalPlanner planner_;
};

// A loaded H-Graph answers the merge's measure again with no check at all, and another measure
// with the same path and the same work as the saved one does.
TEST_F(SnapshotTest, LoadedSessionAnswersAsTheSavedOne) {
  for (Variant variant : {Variant::kEditDistance, Variant::kAllPairs}) {
    HybridizationSession saved = Merged(variant);
    const std::string bytes = SaveSession(saved);
    HybridizationSession loaded = LoadSession(planner_, bytes);
    EXPECT_EQ(loaded.graph().num_nodes(), saved.graph().num_nodes());
    EXPECT_EQ(loaded.graph().num_edges(), saved.graph().num_edges());
    EXPECT_EQ(SaveSession(loaded), bytes) << "a loaded session saves to the same bytes";

    const MergeResult again_saved = saved.Query(MeasureSpec{});
    const MergeResult again_loaded = loaded.Query(MeasureSpec{});
    EXPECT_EQ(again_loaded.path.waypoints, again_saved.path.waypoints);
    EXPECT_EQ(again_loaded.stats.collision_checks, 0);
    EXPECT_EQ(again_loaded.stats.distance_queries, 0);
    EXPECT_EQ(again_loaded.stats.edges_reused, again_saved.stats.edges_reused);

    const MergeResult clearance_saved = saved.Query(Clearance());
    const MergeResult clearance_loaded = loaded.Query(Clearance());
    EXPECT_GT(clearance_saved.stats.distance_queries, 0) << "the measure needs new profiles";
    EXPECT_EQ(clearance_loaded.path.waypoints, clearance_saved.path.waypoints);
    EXPECT_EQ(clearance_loaded.objective, clearance_saved.objective);
    EXPECT_EQ(clearance_loaded.stats.collision_checks, clearance_saved.stats.collision_checks);
    EXPECT_EQ(clearance_loaded.stats.distance_queries, clearance_saved.stats.distance_queries);
  }
}

// An H-Graph merged under a measure of clearance holds its edges' ceilings (the bounds the lazy
// search takes from witnesses), saved as their clearances on the profile's grid: loaded, they
// bound the edges exactly as the saved ones do, so that other measures of clearance take the
// same path with the same checks.
TEST_F(SnapshotTest, KeepsTheCeilingsOfAMergeUnderClearance) {
  MergeRequest request{.paths = testing::CirclePaths(), .measure = Clearance()};
  request.options.candidates.variant = Variant::kAllPairs;
  request.options.optimize_ms = 0;
  HybridizationSession saved(planner_, request);
  saved.Query(request.measure);
  const std::string bytes = SaveSession(saved);
  HybridizationSession loaded = LoadSession(planner_, bytes);
  EXPECT_EQ(SaveSession(loaded), bytes) << "a loaded session saves to the same bytes";

  const MergeResult again = loaded.Query(Clearance());
  EXPECT_EQ(again.path.waypoints, saved.Query(Clearance()).path.waypoints);
  EXPECT_EQ(again.stats.collision_checks, 0);
  EXPECT_EQ(again.stats.distance_queries, 0);
  for (const int k : {1, 3}) {
    const MeasureSpec measure{.type = MeasureType::kInverseClearance, .k = static_cast<double>(k)};
    const MergeResult from_saved = saved.Query(measure);
    const MergeResult from_loaded = loaded.Query(measure);
    EXPECT_EQ(from_loaded.path.waypoints, from_saved.path.waypoints) << "k " << k;
    EXPECT_EQ(from_loaded.stats.edges_checked, from_saved.stats.edges_checked) << "k " << k;
    EXPECT_EQ(from_loaded.stats.distance_queries, from_saved.stats.distance_queries) << "k " << k;
  }
  for (size_t n = 0; n < bytes.size(); n += 1 + n / 5) {
    EXPECT_THROW(LoadSession(planner_, bytes.substr(0, n)), SnapshotError) << n << " bytes";
  }
}

// Added paths are saved too, with their bridges' reports.
TEST_F(SnapshotTest, KeepsAddedPaths) {
  HybridizationSession saved = Merged();
  std::vector<InputPath> more = {testing::CirclePaths().front()};
  more.front().name = "again";
  saved.AddPaths(more);
  saved.Query(MeasureSpec{});
  HybridizationSession loaded = LoadSession(planner_, SaveSession(saved));
  EXPECT_EQ(loaded.graph().num_paths(), saved.graph().num_paths());
  const MergeResult result = loaded.Query(MeasureSpec{});
  EXPECT_EQ(result.stats.collision_checks, 0);
  EXPECT_EQ(result.inputs.size(), saved.Query(MeasureSpec{}).inputs.size());
}

// Every truncation, a flipped byte in the header, another format and trailing bytes are
// refused with SnapshotError.
TEST_F(SnapshotTest, RefusesBytesItCannotTrust) {
  const std::string bytes = SaveSession(Merged());
  ASSERT_GT(bytes.size(), 1000u);
  for (size_t n = 0; n < bytes.size(); n += 1 + n / 7) {
    EXPECT_THROW(LoadSession(planner_, bytes.substr(0, n)), SnapshotError) << n << " bytes";
  }
  std::string foreign = bytes;
  foreign[0] = 'X';
  EXPECT_THROW(LoadSession(planner_, foreign), SnapshotError);
  std::string other_format = bytes;
  other_format[8] = static_cast<char>(kSnapshotFormat + 1);
  try {
    LoadSession(planner_, other_format);
    FAIL() << "another format was loaded";
  } catch (const SnapshotError& e) {
    EXPECT_NE(std::string(e.what()).find("format"), std::string::npos) << e.what();
  }
  EXPECT_THROW(LoadSession(planner_, bytes + "x"), SnapshotError);
  EXPECT_THROW(LoadSession(planner_, std::string(4096, '\xff')), SnapshotError);
  // The formats before (2: every ceiling stored, as doubles, with its witnesses; 3: counts of
  // eight bytes) are refused, naming both formats.
  for (const int format : {2, 3}) {
    std::string previous = bytes;
    previous[8] = static_cast<char>(format);
    try {
      LoadSession(planner_, previous);
      FAIL() << "format " << format << " was loaded";
    } catch (const SnapshotError& e) {
      EXPECT_NE(std::string(e.what()).find("format " + std::to_string(format) +
                                           ", this server reads format 4"),
                std::string::npos)
          << e.what();
    }
  }
}

// A snapshot of a merge under clearance with any byte changed (ceilings' sizes, widths and
// values among them) loads or is refused with SnapshotError, never anything else (a crash, an
// allocation the bytes do not back; ASan runs this too).
TEST_F(SnapshotTest, EveryChangedByteLoadsOrIsRefused) {
  MergeRequest request{.paths = testing::CirclePaths(), .measure = Clearance()};
  request.options.candidates.variant = Variant::kAllPairs;
  request.options.optimize_ms = 0;
  HybridizationSession saved(planner_, request);
  saved.Query(request.measure);
  const std::string bytes = SaveSession(saved);
  int refused = 0;
  int loaded = 0;
  const size_t stride = std::max<size_t>(1, bytes.size() / 1500);
  for (size_t at = 8; at < bytes.size(); at += stride) {
    for (const char value : {'\x00', '\x03', '\xff'}) {
      if (bytes[at] == value) continue;
      std::string changed = bytes;
      changed[at] = value;
      try {
        LoadSession(planner_, changed);
        ++loaded;
      } catch (const SnapshotError&) {
        ++refused;
      }
    }
  }
  EXPECT_GT(refused, 0);
  EXPECT_GT(loaded, 0) << "a changed clearance is a value like any other";
}

// A snapshot of one space is refused by a checker of another (the configurations do not fit).
TEST_F(SnapshotTest, RefusesAnotherSpace) {
  const std::string bytes = SaveSession(Merged());
  auto scene = std::make_shared<Scene>(*testing::CirclesScene());
  scene->space = Space::RealVector(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(80, 80, 80));
  auto other = std::make_shared<const CollisionWorld>(scene);
  const LocalPlanner planner(other, LocalPlannerOptions{.resolution = 0.01});
  EXPECT_THROW(LoadSession(planner, bytes), SnapshotError);
}

}  // namespace
}  // namespace hgraph
