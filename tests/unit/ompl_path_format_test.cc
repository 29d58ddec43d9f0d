// `.path` files against OMPL 1.5's own code, both ways, for SE(2) and SE(3): what we write
// (WritePathsFile, as `hgraph merge --out-path x.path` does) is OMPL's PathGeometric::print of
// the same states, read back into OMPL states with OMPL's own copyFromReals; and what OMPL
// prints, we read back as the same path.
#include <gtest/gtest.h>
#include <ompl/base/ScopedState.h>
#include <ompl/base/SpaceInformation.h>
#include <ompl/base/spaces/SE2StateSpace.h>
#include <ompl/base/spaces/SE3StateSpace.h>
#include <ompl/geometric/PathGeometric.h>
#include <ompl/util/Console.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iterator>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "core/adapter/ompl_cfg.h"
#include "core/adapter/path_io.h"
#include "core/common/error.h"

namespace hgraph {
namespace {

namespace fs = std::filesystem;
namespace ob = ompl::base;
namespace og = ompl::geometric;

struct Problem {
  std::string name;
  Space space;
  ob::SpaceInformationPtr si;
};

Problem Se2() {
  auto space = std::make_shared<ob::SE2StateSpace>();
  ob::RealVectorBounds bounds(2);
  bounds.setLow(-10);
  bounds.setHigh(10);
  space->setBounds(bounds);
  auto si = std::make_shared<ob::SpaceInformation>(space);
  si->setup();  // computes the value locations copyFromReals and copyToReals use
  return {"se2", Space::SE2(Eigen::Vector2d(-10, -10), Eigen::Vector2d(10, 10)), si};
}

Problem Se3() {
  auto space = std::make_shared<ob::SE3StateSpace>();
  ob::RealVectorBounds bounds(3);
  bounds.setLow(-10);
  bounds.setHigh(10);
  space->setBounds(bounds);
  auto si = std::make_shared<ob::SpaceInformation>(space);
  si->setup();
  return {"se3", Space::SE3(Eigen::Vector3d::Constant(-10), Eigen::Vector3d::Constant(10)), si};
}

// A path of awkward numbers (no short decimal form, negative, tiny), in our layout.
InputPath RandomPath(const Space& space, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  InputPath path{.name = "merged"};
  for (int i = 0; i < 7; ++i) {
    Config q(space.dimension());
    for (int k = 0; k < q.size(); ++k) q[k] = 9.5 * u(rng);
    if (space.dimension() == 7) {
      q.tail<4>().normalize();
    } else {
      q[2] = M_PI * u(rng);
    }
    if (i == 3) q[0] = 1e-300;
    path.waypoints.push_back(q);
  }
  return path;
}

// OMPL's state from our configuration, through OMPL's own reading of a state's numbers (the
// order of StateSpace::copyFromReals: SE(2) x y yaw; SE(3) x y z, then the SO(3) x y z w).
og::PathGeometric ToOmpl(const Problem& p, const InputPath& path) {
  og::PathGeometric out(p.si);
  ob::State* state = p.si->allocState();
  for (const Config& q : path.waypoints) {
    p.si->getStateSpace()->copyFromReals(state, std::vector<double>(q.data(), q.data() + q.size()));
    out.append(state);
  }
  p.si->freeState(state);
  return out;
}

std::string OmplPrint(const og::PathGeometric& path, int precision) {
  std::ostringstream out;
  if (precision > 0) out << std::setprecision(precision);
  path.print(out);
  return out.str();
}

// Splits a printout into its text between numbers and its numbers.
void Split(const std::string& text, std::string* skeleton, std::vector<double>* numbers) {
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    const size_t open = line.find('[');
    const size_t close = line.rfind(']');
    if (open == std::string::npos || close == std::string::npos || close < open + 1) {
      *skeleton += line + "\n";
      continue;
    }
    *skeleton += line.substr(0, open + 1) + "#" + line.substr(close) + "\n";
    std::istringstream values(line.substr(open + 1, close - open - 1));
    std::string token;
    while (values >> token) numbers->push_back(std::stod(token));
  }
}

class OmplPathFormatTest : public testing::TestWithParam<Problem (*)()> {
 protected:
  static void SetUpTestSuite() { ompl::msg::setLogLevel(ompl::msg::LOG_WARN); }
  fs::path Dir() {
    const fs::path dir =
        fs::path(testing::TempDir()) / ("hgraph_path_format_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    return dir;
  }
};

// Ours -> OMPL: our .path is OMPL's printout line for line, its numbers exactly the path's, and
// OMPL's own state reading of them gives back the path's states.
TEST_P(OmplPathFormatTest, OurPathFileIsOmplsPrintout) {
  const Problem p = GetParam()();
  const InputPath path = RandomPath(p.space, 7);
  const std::string file = (Dir() / (p.name + ".path")).string();
  WritePathsFile(file, {path}, p.space);
  std::ifstream in(file);
  const std::string ours((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());

  const og::PathGeometric ompl_path = ToOmpl(p, path);
  std::string our_skeleton, ompl_skeleton;
  std::vector<double> our_numbers, ompl_numbers;
  Split(ours, &our_skeleton, &our_numbers);
  Split(OmplPrint(ompl_path, 17), &ompl_skeleton, &ompl_numbers);
  EXPECT_EQ(our_skeleton, ompl_skeleton) << ours;
  ASSERT_EQ(our_numbers.size(), ompl_numbers.size());
  for (size_t i = 0; i < our_numbers.size(); ++i) EXPECT_EQ(our_numbers[i], ompl_numbers[i]);

  // The numbers of each state, read into an OMPL state by OMPL, are the path's state.
  const size_t dim = static_cast<size_t>(p.space.dimension());
  ASSERT_EQ(our_numbers.size(), path.waypoints.size() * dim);
  ob::State* state = p.si->allocState();
  for (size_t i = 0; i < path.waypoints.size(); ++i) {
    const std::vector<double> reals(our_numbers.begin() + i * dim,
                                    our_numbers.begin() + (i + 1) * dim);
    p.si->getStateSpace()->copyFromReals(state, reals);
    EXPECT_TRUE(p.si->getStateSpace()->equalStates(state, ompl_path.getState(i))) << "state " << i;
  }
  p.si->freeState(state);

  // And we read our own file back as the same path.
  const auto back = LoadPathsFile(file, p.space);
  ASSERT_EQ(back.size(), 1u);
  ASSERT_EQ(back[0].waypoints.size(), path.waypoints.size());
  for (size_t i = 0; i < path.waypoints.size(); ++i) {
    EXPECT_EQ(back[0].waypoints[i], path.waypoints[i]) << "waypoint " << i;
  }
}

// OMPL -> ours: OMPL's printout, at full precision and at its default 6 digits, reads back as
// the path OMPL holds; several printouts in one file are several paths.
TEST_P(OmplPathFormatTest, OmplsPrintoutReadsBackAsTheSamePath) {
  const Problem p = GetParam()();
  const InputPath path = RandomPath(p.space, 11);
  const og::PathGeometric ompl_path = ToOmpl(p, path);
  const size_t dim = static_cast<size_t>(p.space.dimension());
  for (int precision : {17, 0}) {
    SCOPED_TRACE(precision);
    const std::string text = OmplPrint(ompl_path, precision);
    const auto read = ParseOmplStatePrint(text, p.name + ".path", p.space);
    ASSERT_EQ(read.size(), 1u);
    ASSERT_EQ(read[0].waypoints.size(), ompl_path.getStateCount());
    for (size_t i = 0; i < ompl_path.getStateCount(); ++i) {
      std::vector<double> reals;
      p.si->getStateSpace()->copyToReals(reals, ompl_path.getState(i));
      ASSERT_EQ(reals.size(), dim);
      for (size_t k = 0; k < dim; ++k) {
        if (precision == 17) {
          EXPECT_EQ(read[0].waypoints[i][k], reals[k]);
        } else {
          EXPECT_NEAR(read[0].waypoints[i][k], reals[k], 1e-5 * std::max(1.0, std::abs(reals[k])));
        }
      }
    }
  }
  const auto two = ParseOmplStatePrint(OmplPrint(ompl_path, 17) + OmplPrint(ompl_path, 17),
                                       p.name + ".path", p.space);
  ASSERT_EQ(two.size(), 2u);
  EXPECT_EQ(two[0].name, p.name + "-0");
  EXPECT_EQ(two[1].waypoints, two[0].waypoints);
}

INSTANTIATE_TEST_SUITE_P(Spaces, OmplPathFormatTest, testing::Values(&Se2, &Se3),
                         [](const testing::TestParamInfo<Problem (*)()>& param) {
                           return param.index == 0 ? std::string("SE2") : std::string("SE3");
                         });

}  // namespace
}  // namespace hgraph
