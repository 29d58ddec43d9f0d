#include "core/plan/ompl_bridge.h"

#include <ompl/base/DiscreteMotionValidator.h>
#include <ompl/base/spaces/RealVectorStateSpace.h>
#include <ompl/base/spaces/SE2StateSpace.h>
#include <ompl/base/spaces/SE3StateSpace.h>
#include <ompl/base/spaces/SO2StateSpace.h>
#include <ompl/base/spaces/SO3StateSpace.h>
#include <ompl/util/Console.h>
#include <ompl/util/RandomNumbers.h>

#include <algorithm>
#include <cmath>
#include <deque>
#include <string>
#include <utility>

#include "core/common/error.h"

namespace hgraph::plan_internal {
namespace ob = ompl::base;
namespace og = ompl::geometric;

namespace {

ob::RealVectorBounds Bounds(const ComponentSpec& c) {
  ob::RealVectorBounds bounds(static_cast<unsigned int>(c.lower.size()));
  for (int k = 0; k < c.lower.size(); ++k) {
    bounds.setLow(k, c.lower[k]);
    bounds.setHigh(k, c.upper[k]);
  }
  return bounds;
}

class CheckerValidity final : public ob::StateValidityChecker {
 public:
  CheckerValidity(const ob::SpaceInformationPtr& si, const MotionChecker& checker)
      : ob::StateValidityChecker(si), checker_(checker) {
    specs_.clearanceComputationType = ob::StateValidityCheckerSpecs::EXACT;
  }
  bool isValid(const ob::State* state) const override {
    return checker_.IsValid(FromOmpl(checker_.space(), state));
  }
  double clearance(const ob::State* state) const override {
    return checker_.Clearance(FromOmpl(checker_.space(), state));
  }

 private:
  const MotionChecker& checker_;
};

class CheckerMotion final : public ob::MotionValidator {
 public:
  CheckerMotion(const ob::SpaceInformationPtr& si, const MotionChecker& checker,
                std::function<bool()> stopped)
      : ob::MotionValidator(si), checker_(checker), stopped_(std::move(stopped)) {}

  bool checkMotion(const ob::State* s1, const ob::State* s2) const override {
    if (Stopped()) return Count(false);
    const Space& space = checker_.space();
    return Count(Certified(FromOmpl(space, s1), FromOmpl(space, s2)));
  }

  // OMPL wants the last valid state along the motion (random bounces of PRM's expansion step).
  // The local planner reports where it found a collision, not the first one, so this walks from
  // s1 at the local planner's sample spacing and certifies the motion up to the last free sample.
  bool checkMotion(const ob::State* s1, const ob::State* s2,
                   std::pair<ob::State*, double>& last_valid) const override {
    if (Stopped()) {
      last_valid.second = 0;
      if (last_valid.first != nullptr) si_->copyState(last_valid.first, s1);
      return Count(false);
    }
    const Space& space = checker_.space();
    const Config a = FromOmpl(space, s1);
    const Config b = FromOmpl(space, s2);
    if (Certified(a, b)) return Count(true);
    const unsigned int steps = std::max(1u, si_->getStateSpace()->validSegmentCount(s1, s2));
    unsigned int free = 0;
    while (free < steps && checker_.IsValid(space.Interpolate(a, b, double(free + 1) / steps))) {
      ++free;
    }
    // Back off until the shortened motion is certified too (a grazing contact between samples).
    while (free > 0 && !Certified(a, space.Interpolate(a, b, double(free) / steps))) --free;
    last_valid.second = double(free) / steps;
    if (last_valid.first != nullptr) {
      ToOmpl(space, space.Interpolate(a, b, last_valid.second), last_valid.first);
    }
    return Count(false);
  }

 private:
  // The validity a merge applies to its input edges (the stretches between samples proven free,
  // touching contact rejected), without the clearance profile a planner does not need: the
  // certificate comes from conservative advancement, a few distance queries per motion in open
  // space instead of one per sample. The plain sampled check lets thin parts graze corners
  // between samples, and a path that grazes would be reported invalid by the merge it was
  // planned for.
  // A motion on which conservative advancement stalls (it grazes an obstacle) is refused without
  // the profile kCertificate would fall back to: a profile costs hundreds of distance queries
  // (PRM checks up to ten motions per milestone and polls its stop only between milestones, so a
  // few such profiles ran a 1 s planner to 1.9 s), and a planner has other motions to try. A
  // profile may also find a motion free at every sample yet certify no cover of it; a merge would
  // not take such a motion either.
  bool Certified(const Config& a, const Config& b) const {
    const EdgeReport report =
        checker_.CheckEdge({.from = &a, .to = &b, .proof = EdgeProof::kCertificateOrGiveUp});
    return report.state == EdgeState::kValid && report.certified;
  }

  bool Stopped() const { return stopped_ && stopped_(); }

  bool Count(bool valid) const {
    // OMPL's counters are plain members; PRM calls us from two threads, but under its graph
    // mutex, so they are not raced.
    if (valid) {
      ++valid_;
    } else {
      ++invalid_;
    }
    return valid;
  }

  const MotionChecker& checker_;
  const std::function<bool()> stopped_;
};

}  // namespace

ob::StateSpacePtr MakeStateSpace(const Space& space, double resolution) {
  auto compound = std::make_shared<ob::CompoundStateSpace>();
  for (int i = 0; i < space.num_components(); ++i) {
    const ComponentSpec& c = space.component(i);
    ob::StateSpacePtr sub;
    double weight = 1.0;
    switch (c.type) {
      case ComponentType::kRealVector: {
        auto rn = std::make_shared<ob::RealVectorStateSpace>(c.dimension);
        rn->setBounds(Bounds(c));
        sub = rn;
        weight = c.translation_weight;
        break;
      }
      case ComponentType::kSO2:
        sub = std::make_shared<ob::SO2StateSpace>();
        weight = c.rotation_weight;
        break;
      case ComponentType::kSO3:
        sub = std::make_shared<ob::SO3StateSpace>();
        weight = c.rotation_weight;
        break;
      case ComponentType::kSE2: {
        auto se2 = std::make_shared<ob::SE2StateSpace>();
        se2->setBounds(Bounds(c));
        se2->setSubspaceWeight(0, c.translation_weight);
        se2->setSubspaceWeight(1, c.rotation_weight);
        sub = se2;
        break;
      }
      case ComponentType::kSE3: {
        auto se3 = std::make_shared<ob::SE3StateSpace>();
        se3->setBounds(Bounds(c));
        se3->setSubspaceWeight(0, c.translation_weight);
        se3->setSubspaceWeight(1, c.rotation_weight);
        sub = se3;
        break;
      }
    }
    if (!c.name.empty()) sub->setName(c.name + "_" + std::to_string(i));
    compound->addSubspace(sub, weight);
  }
  compound->lock();
  compound->setLongestValidSegmentFraction(resolution);
  return compound;
}

void ToOmpl(const Space& space, const Config& q, ob::State* state) {
  auto* compound = state->as<ob::CompoundState>();
  for (int i = 0; i < space.num_components(); ++i) {
    const int o = space.offset(i);
    ob::State* s = compound->components[i];
    switch (space.component(i).type) {
      case ComponentType::kRealVector: {
        auto* rn = s->as<ob::RealVectorStateSpace::StateType>();
        for (int k = 0; k < space.size(i); ++k) rn->values[k] = q[o + k];
        break;
      }
      case ComponentType::kSO2: s->as<ob::SO2StateSpace::StateType>()->value = q[o]; break;
      case ComponentType::kSO3: {
        auto* r = s->as<ob::SO3StateSpace::StateType>();
        r->x = q[o];
        r->y = q[o + 1];
        r->z = q[o + 2];
        r->w = q[o + 3];
        break;
      }
      case ComponentType::kSE2: {
        auto* se2 = s->as<ob::SE2StateSpace::StateType>();
        se2->setXY(q[o], q[o + 1]);
        se2->setYaw(q[o + 2]);
        break;
      }
      case ComponentType::kSE3: {
        auto* se3 = s->as<ob::SE3StateSpace::StateType>();
        se3->setXYZ(q[o], q[o + 1], q[o + 2]);
        auto& r = se3->rotation();
        r.x = q[o + 3];
        r.y = q[o + 4];
        r.z = q[o + 5];
        r.w = q[o + 6];
        break;
      }
    }
  }
}

Config FromOmpl(const Space& space, const ob::State* state) {
  Config q(space.dimension());
  const auto* compound = state->as<ob::CompoundState>();
  for (int i = 0; i < space.num_components(); ++i) {
    const int o = space.offset(i);
    const ob::State* s = compound->components[i];
    switch (space.component(i).type) {
      case ComponentType::kRealVector: {
        const auto* rn = s->as<ob::RealVectorStateSpace::StateType>();
        for (int k = 0; k < space.size(i); ++k) q[o + k] = rn->values[k];
        break;
      }
      case ComponentType::kSO2: q[o] = s->as<ob::SO2StateSpace::StateType>()->value; break;
      case ComponentType::kSO3: {
        const auto* r = s->as<ob::SO3StateSpace::StateType>();
        q.segment<4>(o) << r->x, r->y, r->z, r->w;
        break;
      }
      case ComponentType::kSE2: {
        const auto* se2 = s->as<ob::SE2StateSpace::StateType>();
        q.segment<3>(o) << se2->getX(), se2->getY(), se2->getYaw();
        break;
      }
      case ComponentType::kSE3: {
        const auto* se3 = s->as<ob::SE3StateSpace::StateType>();
        const auto& r = se3->rotation();
        q.segment<7>(o) << se3->getX(), se3->getY(), se3->getZ(), r.x, r.y, r.z, r.w;
        break;
      }
    }
  }
  return q;
}

ob::SpaceInformationPtr MakeSpaceInformation(const MotionChecker& checker, double resolution,
                                             OmplMotionCheck motion_check,
                                             std::function<bool()> stopped) {
  if (!(resolution > 0) || !std::isfinite(resolution)) {
    throw InputError("resolution",
                     "must be positive and finite, got " + std::to_string(resolution));
  }
  auto si = std::make_shared<ob::SpaceInformation>(MakeStateSpace(checker.space(), resolution));
  si->setStateValidityChecker(std::make_shared<CheckerValidity>(si, checker));
  if (motion_check == OmplMotionCheck::kDiscrete) {
    si->setMotionValidator(std::make_shared<ob::DiscreteMotionValidator>(si));
  } else {
    si->setMotionValidator(std::make_shared<CheckerMotion>(si, checker, std::move(stopped)));
  }
  si->setup();
  return si;
}

og::PathGeometric ToOmplPath(const ob::SpaceInformationPtr& si, const Space& space,
                             const InputPath& path) {
  og::PathGeometric out(si);
  ob::State* state = si->allocState();
  for (const Config& q : path.waypoints) {
    ToOmpl(space, q, state);
    out.append(state);  // copies
  }
  si->freeState(state);
  return out;
}

InputPath FromOmplPath(const Space& space, const og::PathGeometric& path, std::string name) {
  InputPath out{.name = std::move(name)};
  out.waypoints.reserve(path.getStateCount());
  for (std::size_t k = 0; k < path.getStateCount(); ++k) {
    out.waypoints.push_back(FromOmpl(space, path.getState(k)));
  }
  return out;
}

std::unique_lock<std::mutex> LockOmplRandomness() {
  static std::mutex mutex;
  return std::unique_lock<std::mutex>(mutex);
}

void PrepareSamplers(const ob::SpaceInformationPtr& si, int count) {
  struct Prepared {
    std::mutex mutex;
    std::deque<ob::StateSamplerPtr> samplers;
  };
  auto prepared = std::make_shared<Prepared>();
  const ob::StateSpacePtr& space = si->getStateSpace();
  for (int i = 0; i < count; ++i) prepared->samplers.push_back(space->allocDefaultStateSampler());
  space->setStateSamplerAllocator([prepared](const ob::StateSpace* s) -> ob::StateSamplerPtr {
    std::lock_guard lock(prepared->mutex);
    if (prepared->samplers.empty()) return s->allocDefaultStateSampler();
    ob::StateSamplerPtr sampler = std::move(prepared->samplers.front());
    prepared->samplers.pop_front();
    return sampler;
  });
}

void SeedOmpl(uint64_t seed) {
  // OMPL seeds are 32-bit and must not be 0; fold the 64-bit seed (SplitMix64 finaliser).
  uint64_t z = seed + 0x9e3779b97f4a7c15ULL;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  z ^= z >> 31;
  uint32_t folded = static_cast<uint32_t>(z ^ (z >> 32));
  if (folded == 0) folded = 1;
  const ompl::msg::LogLevel level = ompl::msg::getLogLevel();
  ompl::msg::setLogLevel(ompl::msg::LOG_NONE);
  ompl::RNG::setSeed(folded);
  ompl::msg::setLogLevel(level);
}

void QuietOmplLogging() {
  static std::once_flag once;
  std::call_once(once, [] {
    if (ompl::msg::getLogLevel() < ompl::msg::LOG_WARN) ompl::msg::setLogLevel(ompl::msg::LOG_WARN);
  });
}

}  // namespace hgraph::plan_internal
