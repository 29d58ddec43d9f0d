// Solve on a real scene (the built-in maze): a portfolio of OMPL planners whose paths are merged
// as they arrive. Budgets are short and no assertion is about time.
#include "core/solve/solve.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "core/adapter/scene_proto.h"
#include "core/collision/collision_world.h"
#include "core/common/error.h"
#include "core/merge/path_check.h"
#include "core/motion/local_planner.h"

namespace hgraph {
namespace {

struct Fixture {
  std::shared_ptr<const Scene> scene;
  std::unique_ptr<LocalPlanner> planner;
  double resolution = 0;
};

Fixture LoadMaze() {
  const std::string file = std::string(HGRAPH_SOURCE_DIR) + "/scenes/maze/scene.json";
  Fixture f;
  f.resolution = SceneResolution(ReadSceneFile(file));
  f.scene = LoadSceneFile(file);
  f.planner = std::make_unique<LocalPlanner>(std::make_shared<const CollisionWorld>(f.scene),
                                             LocalPlannerOptions{.resolution = f.resolution});
  return f;
}

class SolveTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { maze_ = new Fixture(LoadMaze()); }
  static void TearDownTestSuite() {
    delete maze_;
    maze_ = nullptr;
  }
  static SolveRequest MazeRequest() {
    return SolveRequest{.start = *maze_->scene->start,
                        .goal = *maze_->scene->goal,
                        .merge = {.threads = 2},
                        .budget_s = 1.0,
                        .seed = 7,
                        .resolution = maze_->resolution};
  }
  static Fixture* maze_;
};
Fixture* SolveTest::maze_ = nullptr;

// Every run's path goes into one H-Graph; the result is certified, between the exact ends, no
// longer than any certified input, and each update improves on the one before; with the planners
// on OMPL's discrete check (the default) and on the certificate.
TEST_F(SolveTest, MergesThePortfolioIntoACertifiedPathNoLongerThanItsInputs) {
  for (const OmplMotionCheck plan_check :
       {OmplMotionCheck::kDiscrete, OmplMotionCheck::kCertified}) {
    SCOPED_TRACE(plan_check == OmplMotionCheck::kDiscrete ? "discrete" : "certified");
    SolveRequest request = MazeRequest();
    request.plan_check = plan_check;
    request.portfolio = {{.planner = PlannerType::kPRM, .runs = 3},
                         {.planner = PlannerType::kRRTConnect, .runs = 2}};
    std::vector<SolveUpdate> updates;
    std::vector<SolveRun> ended;
    request.on_update = [&](const SolveUpdate& u) { updates.push_back(u); };
    request.on_run = [&](const SolveRun& r) { ended.push_back(r); };
    const SolveResult result = Solve(*maze_->planner, request);
    ASSERT_TRUE(result.found) << result.message;
    ASSERT_NE(result.session, nullptr);
    EXPECT_EQ(result.runs.size(), 5u);
    EXPECT_EQ(ended.size(), result.runs.size());
    int found = 0;
    for (size_t i = 0; i < result.runs.size(); ++i) {
      EXPECT_EQ(result.runs[i].index, static_cast<int>(i));
      if (result.runs[i].found) ++found;
    }
    EXPECT_GE(found, 1);
    EXPECT_EQ(static_cast<int>(result.inputs.size()), found);
    EXPECT_EQ(result.session->graph().num_paths(), found);
    // The best result's report covers the paths merged when it was found.
    EXPECT_GE(static_cast<int>(result.result.inputs.size()), 1);
    EXPECT_LE(static_cast<int>(result.result.inputs.size()), found);

    const InputPath& path = result.result.path;
    EXPECT_EQ(path.waypoints.front(), *maze_->scene->start);
    EXPECT_EQ(path.waypoints.back(), *maze_->scene->goal);
    const PathCheckResult check = CheckPaths(*maze_->planner, {.paths = {path}});
    EXPECT_TRUE(check.paths[0].valid);
    EXPECT_TRUE(check.paths[0].certified);
    const Space& space = maze_->scene->space;
    EXPECT_NEAR(result.result.objective, PathLength(space, path), 1e-9);
    for (const SolveRun& run : result.runs) {
      if (run.found && run.certified) {
        EXPECT_LE(result.result.objective, run.length + 1e-9);
      }
    }
    // Each run says whether its path is certified, as CheckPaths finds it (a path planned on
    // OMPL's discrete check may graze an obstacle between samples; the merge takes its
    // certified stretches).
    for (const InputPath& input : result.inputs) {
      const auto run = std::find_if(result.runs.begin(), result.runs.end(),
                                    [&](const SolveRun& r) { return r.path_name == input.name; });
      ASSERT_NE(run, result.runs.end()) << input.name;
      const PathCheckResult own = CheckPaths(*maze_->planner, {.paths = {input}});
      EXPECT_EQ(own.paths[0].valid && own.paths[0].certified, run->certified) << input.name;
      if (plan_check == OmplMotionCheck::kCertified) {
        EXPECT_TRUE(run->certified) << input.name;
      }
    }
    ASSERT_EQ(static_cast<int>(updates.size()), result.updates);
    ASSERT_GE(updates.size(), 1u);
    for (size_t i = 1; i < updates.size(); ++i) {
      EXPECT_LT(updates[i].objective, updates[i - 1].objective);
    }
    EXPECT_NEAR(updates.back().objective, result.result.objective, 1e-9);
  }
}

// The H-Graph serves later queries and additions as a merge's does.
TEST_F(SolveTest, TheHGraphServesQueriesAndAdditions) {
  SolveRequest request = MazeRequest();
  request.portfolio = {{.planner = PlannerType::kRRTConnect, .runs = 3}};
  request.merge.optimize_ms = 0;
  SolveResult result = Solve(*maze_->planner, request);
  ASSERT_TRUE(result.found) << result.message;
  const MergeResult again = result.session->Query({});
  EXPECT_NEAR(again.objective, result.result.objective, 1e-9);
  const PlanResult more = PlanPaths(*maze_->planner, {.planner = PlannerType::kPRM,
                                                      .start = request.start,
                                                      .goal = request.goal,
                                                      .seed = 99,
                                                      .resolution = maze_->resolution});
  ASSERT_EQ(more.paths.size(), 1u);
  const int before = result.session->graph().num_paths();
  result.session->AddPaths(more.paths);
  EXPECT_EQ(result.session->graph().num_paths(), before + 1);
  EXPECT_LE(result.session->Query({}).objective, again.objective + 1e-9);
}

// The default portfolio runs every kind it names: below a long budget one RRT* run, which starts
// first (fewer optimizing runs than slots keep a slot each), and PRM's; from a long budget on,
// PRM's first and then BIT* and RRT*.
TEST_F(SolveTest, DefaultPortfolioRunsEveryKindItNames) {
  SolveRequest request = MazeRequest();
  const SolveResult result = Solve(*maze_->planner, request);
  ASSERT_TRUE(result.found) << result.message;
  ASSERT_FALSE(result.runs.empty());
  EXPECT_EQ(result.runs.front().planner, PlannerType::kRRTStar);
  int runs = 0;
  for (const PortfolioEntry& e : DefaultPortfolio()) {
    runs += e.runs;
    bool seen = false;
    for (const SolveRun& run : result.runs) seen = seen || run.planner == e.planner;
    EXPECT_TRUE(seen) << PlannerTypeName(e.planner);
  }
  EXPECT_EQ(static_cast<int>(result.runs.size()), runs);
  // A long budget adds BIT* and RRT*, which use the planning time PRM's runs leave.
  std::vector<PlannerType> kinds;
  for (const PortfolioEntry& e : DefaultPortfolio(2, kLongSolveBudgetS)) kinds.push_back(e.planner);
  EXPECT_EQ(kinds, (std::vector<PlannerType>{PlannerType::kPRM, PlannerType::kBITStar,
                                             PlannerType::kRRTStar}));
  kinds.clear();
  for (const PortfolioEntry& e : DefaultPortfolio()) kinds.push_back(e.planner);
  EXPECT_EQ(kinds, (std::vector<PlannerType>{PlannerType::kRRTStar, PlannerType::kPRM}));
  // With one slot, PRM alone (an optimizing run would wait for PRM's and get little time).
  for (const PortfolioEntry& e : DefaultPortfolio(1)) EXPECT_EQ(e.planner, PlannerType::kPRM);
}

// Optimizing runs fewer than the slots start first; as many as the slots or more start after
// the runs that stop at their first path. (Run indices are in the order the runs started.)
TEST_F(SolveTest, OptimizingRunsFewerThanTheSlotsStartFirst) {
  const auto first_started = [&](std::vector<PortfolioEntry> portfolio, int parallel) {
    SolveRequest request = MazeRequest();
    request.budget_s = 0.5;
    request.portfolio = std::move(portfolio);
    request.parallel = parallel;
    const SolveResult result = Solve(*maze_->planner, request);
    return result.runs.at(0).planner;
  };
  EXPECT_EQ(first_started({{.planner = PlannerType::kPRM, .runs = 2},
                           {.planner = PlannerType::kBITStar, .runs = 1}},
                          2),
            PlannerType::kBITStar);
  EXPECT_EQ(first_started({{.planner = PlannerType::kPRM, .runs = 2},
                           {.planner = PlannerType::kBITStar, .runs = 1}},
                          1),
            PlannerType::kPRM);
  EXPECT_EQ(first_started({{.planner = PlannerType::kPRM, .runs = 2},
                           {.planner = PlannerType::kBITStar, .runs = 1},
                           {.planner = PlannerType::kRRTStar, .runs = 1}},
                          2),
            PlannerType::kPRM);
}

TEST_F(SolveTest, BadRequestsNameTheField) {
  const auto field_of = [&](const SolveRequest& request) -> std::string {
    try {
      Solve(*maze_->planner, request);
    } catch (const InputError& e) {
      return e.field() + " | " + e.what();
    }
    return "no error";
  };
  SolveRequest r = MazeRequest();
  r.budget_s = 0;
  EXPECT_EQ(field_of(r).substr(0, 11), "budget_s | ") << field_of(r);
  r = MazeRequest();
  r.budget_s = 1e9;
  EXPECT_EQ(field_of(r).substr(0, 11), "budget_s | ");
  r = MazeRequest();
  r.portfolio = {{.planner = PlannerType::kPRM, .runs = 1},
                 {.planner = PlannerType::kRRT, .runs = 0}};
  EXPECT_EQ(field_of(r).substr(0, 20), "portfolio[1].runs | ") << field_of(r);
  r = MazeRequest();
  r.portfolio = {{.planner = PlannerType::kPRM, .runs = 40},
                 {.planner = PlannerType::kRRT, .runs = 40}};
  EXPECT_EQ(field_of(r).substr(0, 12), "portfolio | ") << field_of(r);
  r = MazeRequest();
  r.plan_fraction = 1.5;
  EXPECT_EQ(field_of(r).substr(0, 16), "plan_fraction | ");
  r = MazeRequest();
  r.merge.optimize_ms = 100;
  EXPECT_EQ(field_of(r).substr(0, 20), "merge.optimize_ms | ");
  r = MazeRequest();
  r.start = Eigen::Vector2d(0.1, 0.1);  // inside the outer wall
  EXPECT_NE(field_of(r).find("start | start: is in collision"), std::string::npos) << field_of(r);
  r = MazeRequest();
  r.goal = Eigen::Vector3d(1, 1, 1);
  EXPECT_EQ(field_of(r).substr(0, 7), "goal | ");
}

// A pool with no free thread (start_beside refuses every task): the calling thread plans every
// run itself, one at a time between merges, and still finds the certified path.
TEST_F(SolveTest, APoolWithoutAFreeThreadPlansOneRunAtATimeOnTheCaller) {
  SolveRequest request = MazeRequest();
  request.portfolio = {{.planner = PlannerType::kPRM, .runs = 3},
                       {.planner = PlannerType::kRRTConnect, .runs = 1}};
  request.parallel = 4;
  int offered = 0;
  request.start_beside = [&](std::function<void()>) {
    ++offered;
    return false;
  };
  const SolveResult result = Solve(*maze_->planner, request);
  ASSERT_TRUE(result.found) << result.message;
  EXPECT_GE(offered, 1);
  int started = 0;
  for (const SolveRun& run : result.runs) started += run.status.rfind("not started", 0) ? 1 : 0;
  EXPECT_GE(started, 1);
  EXPECT_EQ(result.runs_on_caller, started);
  EXPECT_EQ(result.most_runs_at_once, 1);
}

// With no free thread the calling thread plans the runs itself and merges nothing meanwhile: it
// takes the runs that stop at their first path before an optimizing one, which would hold it for
// the whole planning time (the default's RRT* run comes first with free threads).
TEST_F(SolveTest, TheCallerPlansFirstSolutionRunsBeforeOptimizingOnes) {
  SolveRequest request = MazeRequest();
  request.portfolio = {{.planner = PlannerType::kRRTStar, .runs = 1},
                       {.planner = PlannerType::kPRM, .runs = 2}};
  request.parallel = 2;
  request.start_beside = [](std::function<void()>) { return false; };
  const SolveResult result = Solve(*maze_->planner, request);
  ASSERT_EQ(result.runs.size(), 3u);
  EXPECT_EQ(result.runs[0].planner, PlannerType::kPRM);
  EXPECT_EQ(result.runs[1].planner, PlannerType::kPRM);
  EXPECT_EQ(result.runs[2].planner, PlannerType::kRRTStar);
  EXPECT_GE(result.runs_on_caller, 1);
  ASSERT_TRUE(result.found) << result.message;
}

// A pool of one worker beside the caller (a thread that takes a task only while it has none):
// at most two runs at once, however many `parallel` allows, and the worker's refusals are
// planned by the caller.
TEST_F(SolveTest, RunsGoToFreeWorkersOnlyAndTheCallerPlansTheRest) {
  std::mutex mutex;
  std::condition_variable ready;
  std::function<void()> queued;
  bool busy = false;
  bool quit = false;
  int ran = 0;
  std::thread worker([&] {
    std::unique_lock lock(mutex);
    for (;;) {
      ready.wait(lock, [&] { return quit || queued; });
      if (!queued) return;
      std::function<void()> task = std::move(queued);
      queued = nullptr;
      lock.unlock();
      task();
      lock.lock();
      busy = false;
      ++ran;
    }
  });
  SolveRequest request = MazeRequest();
  request.portfolio = {{.planner = PlannerType::kPRM, .runs = 6}};
  request.parallel = 6;
  int accepted = 0;
  request.start_beside = [&](std::function<void()> task) {
    std::lock_guard lock(mutex);
    if (busy) return false;
    busy = true;
    queued = std::move(task);
    ++accepted;
    ready.notify_all();
    return true;
  };
  const SolveResult result = Solve(*maze_->planner, request);
  {
    std::lock_guard lock(mutex);
    quit = true;
  }
  ready.notify_all();
  worker.join();
  EXPECT_EQ(ran, accepted);
  ASSERT_TRUE(result.found) << result.message;
  EXPECT_GE(accepted, 1);
  EXPECT_GE(result.most_runs_at_once, 1);
  EXPECT_LE(result.most_runs_at_once, 2);
  int started = 0;
  for (const SolveRun& run : result.runs) started += run.status.rfind("not started", 0) ? 1 : 0;
  EXPECT_LE(result.runs_on_caller, started);
  EXPECT_GE(started, 1);
}

// No path exists between two rooms: the budget ends with a result that says so, not an error.
TEST(SolveNoPathTest, ABudgetWithoutAPathEndsWithAResultThatSaysSo) {
  auto scene = std::make_shared<Scene>(Scene{
      .name = "two-rooms",
      .space = Space::RealVector(Eigen::Vector2d(0, 0), Eigen::Vector2d(10, 10)),
  });
  Obstacle wall{.name = "wall",
                .shape = Shape{.type = ShapeType::kBox, .box_size = Eigen::Vector3d(0.5, 20, 1)}};
  wall.pose.translation() = Eigen::Vector3d(5, 5, 0);
  scene->obstacles.push_back(wall);
  scene->robot.push_back(
      RobotBody{.name = "point", .shape = Shape{.type = ShapeType::kSphere, .radius = 0.1}});
  const LocalPlanner planner(std::make_shared<const CollisionWorld>(scene));
  int updates = 0;
  const SolveResult result =
      Solve(planner, {.start = Eigen::Vector2d(2, 5),
                      .goal = Eigen::Vector2d(8, 5),
                      .budget_s = 0.3,
                      .portfolio = {{.planner = PlannerType::kRRTConnect, .runs = 2},
                                    {.planner = PlannerType::kBITStar, .runs = 1}},
                      .on_update = [&](const SolveUpdate&) { ++updates; }});
  EXPECT_FALSE(result.found);
  EXPECT_EQ(result.session, nullptr);
  EXPECT_EQ(updates, 0);
  EXPECT_NE(result.message.find("no path found in 0.3 s"), std::string::npos) << result.message;
  EXPECT_EQ(result.runs.size(), 3u);
  for (const SolveRun& run : result.runs) EXPECT_FALSE(run.found);
}

// Paths that cannot be certified do not end the planning: a wall thinner than OMPL's discrete
// step seals one room from the other, so every path the planners find crosses it between samples
// and no query certifies a way from start to goal. The first run's path arrives, and the call
// (on_run) holds until the planning share (plan_fraction) has passed; the runs after it must
// still start and plan, since no certified path is known. (Counting any arrived path as found,
// the planning would stop there and the later runs would never start.)
TEST(SolveUncertifiedTest, PathsThatCannotBeCertifiedDoNotEndThePlanning) {
  auto scene = std::make_shared<Scene>(Scene{
      .name = "thin-wall",
      .space = Space::RealVector(Eigen::Vector2d(0, 0), Eigen::Vector2d(10, 10)),
  });
  Obstacle wall{.name = "wall",
                .shape = Shape{.type = ShapeType::kBox, .box_size = Eigen::Vector3d(0.002, 20, 1)}};
  wall.pose.translation() = Eigen::Vector3d(5, 5, 0);
  scene->obstacles.push_back(wall);
  scene->robot.push_back(
      RobotBody{.name = "point", .shape = Shape{.type = ShapeType::kSphere, .radius = 0.01}});
  // OMPL checks motions every 0.1 of the space's extent (1.4), the wall and robot 0.022 across.
  constexpr double kResolution = 0.1;
  const LocalPlanner planner(std::make_shared<const CollisionWorld>(scene),
                             LocalPlannerOptions{.resolution = kResolution});
  constexpr double kBudgetS = 2;
  constexpr double kPlanFraction = 0.1;
  const auto t0 = std::chrono::steady_clock::now();
  SolveRequest request{.start = Eigen::Vector2d(2, 5),
                       .goal = Eigen::Vector2d(8, 5),
                       .budget_s = kBudgetS,
                       .portfolio = {{.planner = PlannerType::kRRTConnect, .runs = 3}},
                       .plan_fraction = kPlanFraction,
                       .parallel = 1,
                       .seed = 5,
                       .resolution = kResolution,
                       .plan_check = OmplMotionCheck::kDiscrete};
  // One run at a time, on the calling thread.
  request.start_beside = [](std::function<void()>) { return false; };
  std::vector<SolveRun> ended;
  request.on_run = [&](const SolveRun& run) {
    ended.push_back(run);
    // The first path arrives before the planning share ends; hold until it has.
    if (ended.size() == 1) {
      std::this_thread::sleep_until(
          t0 + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                   std::chrono::duration<double>(2.5 * kPlanFraction * kBudgetS)));
    }
  };
  const SolveResult result = Solve(planner, request);
  ASSERT_EQ(result.runs.size(), 3u);
  ASSERT_FALSE(ended.empty());
  EXPECT_TRUE(ended.front().found) << ended.front().status;
  EXPECT_FALSE(ended.front().certified);
  for (const SolveRun& run : result.runs) {
    SCOPED_TRACE(run.index);
    EXPECT_NE(run.status.rfind("not started", 0), 0u) << run.status;
    EXPECT_TRUE(run.found) << run.status;
    EXPECT_FALSE(run.certified);
  }
  EXPECT_EQ(result.inputs.size(), 3u);
  EXPECT_FALSE(result.found);
  EXPECT_EQ(result.updates, 0);
  EXPECT_NE(result.message.find("have no certified way from start to goal"), std::string::npos)
      << result.message;
}

// A cancel stops every planner (a 30 s budget of optimizing planners) and the call, whether the
// runs go on threads of their own or on the calling thread (a pool with no free thread).
TEST_F(SolveTest, CancelStopsEveryPlanner) {
  for (const bool pool_busy : {false, true}) {
    SCOPED_TRACE(pool_busy ? "on the caller" : "on threads of their own");
    SolveRequest request = MazeRequest();
    request.budget_s = 30;
    request.portfolio = {{.planner = PlannerType::kBITStar, .runs = 2},
                         {.planner = PlannerType::kRRTStar, .runs = 2}};
    request.parallel = 4;
    if (pool_busy) request.start_beside = [](std::function<void()>) { return false; };
    auto solving = std::async(std::launch::async, [&] { return Solve(*maze_->planner, request); });
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    request.cancel.Cancel();
    try {
      solving.get();
      FAIL() << "no error";
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ErrorCode::kCancelled);
    }
  }
}

}  // namespace
}  // namespace hgraph
