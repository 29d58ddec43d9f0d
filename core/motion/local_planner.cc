#include "core/motion/local_planner.h"

#include <tbb/enumerable_thread_specific.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <vector>

#include "core/common/error.h"
#include "core/common/limits.h"
#include "core/common/parallel.h"
#include "core/distance/clearance_bound.h"

namespace hgraph {
namespace {

// Interior indices 1..segments-1 of the sample grid in van der Corput order (0.5, 0.25, 0.75,
// 0.125, 0.625, ...), so that the checks spread over the motion as early as possible. For a grid
// that is not a power of two, the dyadic points are rounded to the grid; since their spacing is
// at most one grid step, every index is reached.
std::vector<int> BisectionOrder(int segments) {
  std::vector<int> order;
  if (segments < 2) return order;
  order.reserve(segments - 1);
  int bits = 0;
  while ((int64_t{1} << bits) < segments) ++bits;
  const int64_t dyadic = int64_t{1} << bits;
  std::vector<bool> seen(segments + 1, false);
  for (int64_t i = 1; i < dyadic; ++i) {
    int64_t j = 0;  // i with its `bits` low bits reversed
    for (int b = 0; b < bits; ++b) j |= ((i >> b) & 1) << (bits - 1 - b);
    const int k = static_cast<int>((2 * j * segments + dyadic) / (2 * dyadic));
    if (k <= 0 || k >= segments || seen[k]) continue;
    seen[k] = true;
    order.push_back(k);
  }
  HGRAPH_CHECK(static_cast<int>(order.size()) == segments - 1);
  return order;
}

}  // namespace

namespace {

// Per robot body, what bounds how far its points move when its frame turns: its radius about the
// frame's origin (CollisionWorld::BodyRadius), and the points whose convex hull holds it, in the
// frame (a mesh's vertices, a box's corners; none for a sphere or a cylinder, which keep the
// radius).
struct RobotReach {
  std::vector<double> radius;
  std::vector<std::vector<Eigen::Vector3d>> points;
};

std::vector<Eigen::Vector3d> ExtremePoints(const RobotBody& body) {
  std::vector<Eigen::Vector3d> points;
  if (body.shape.type == ShapeType::kMesh) {
    for (const Eigen::Vector3d& v : body.shape.mesh->vertices) points.push_back(body.offset * v);
  } else if (body.shape.type == ShapeType::kBox) {
    for (int corner = 0; corner < 8; ++corner) {
      const Eigen::Vector3d p(corner & 1 ? 0.5 : -0.5, corner & 2 ? 0.5 : -0.5,
                              corner & 4 ? 0.5 : -0.5);
      points.push_back(body.offset * p.cwiseProduct(body.shape.box_size));
    }
  }
  return points;
}

}  // namespace

struct LocalPlanner::Impl {
  CollisionContext& Context(const CollisionWorld& world) {
    std::unique_ptr<CollisionContext>& context = contexts.local();
    if (context == nullptr) context = world.MakeContext();
    return *context;
  }

  tbb::enumerable_thread_specific<std::unique_ptr<CollisionContext>> contexts;
  std::atomic<int64_t> collision_checks{0};
  std::atomic<int64_t> distance_queries{0};
  std::atomic<int64_t> bound_queries{0};
  std::vector<int> body_component;
  RobotReach reach;
};

namespace {

// Below this angle a motion's rotation axis is not used (the radius about the frame's origin
// bounds the turn instead: Eigen's slerp interpolates linearly there, and the turn is tiny).
constexpr double kAxisMinAngle = 1e-4;

// The largest distance of the points from the axis through the origin (`axis` a unit vector),
// at most `radius`, rounded up.
double RadiusAbout(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& axis,
                   double radius) {
  double farthest = 0;
  for (const Eigen::Vector3d& p : points)
    farthest = std::max(farthest, axis.cross(p).squaredNorm());
  return std::min(radius, std::sqrt(farthest) + 1e-9 * radius);
}

// How far any point of the robot can move along the straight motion from a to b: per body, its
// component's translation plus the component's rotation angle times the body's distance from
// the rotation's axis. A straight motion turns the frame about one axis fixed in the frame
// (slerp; SO(2): the z axis), so a point p of the body moves at most |dx| + angle |axis x p|:
// for an elongated body turning about its long axis far less than its radius about the origin.
double RobotMotionBound(const Space& space, const std::vector<int>& body_component,
                        const RobotReach& reach, const Config& a, const Config& b) {
  double bound = 0;
  for (size_t i = 0; i < body_component.size(); ++i) {
    const int c = body_component[i];
    const double angle = space.RotationAngle(c, a, b);
    double radius = reach.radius[i];
    if (angle > kAxisMinAngle && !reach.points[i].empty()) {
      const Eigen::Matrix3d turn =
          space.Pose(c, a).linear().transpose() * space.Pose(c, b).linear();
      radius = RadiusAbout(reach.points[i], Eigen::AngleAxisd(turn).axis(), radius);
    }
    bound += space.TranslationDistance(c, a, b) + radius * angle;
  }
  return bound;
}

// One CheckEdge call: the motion, the thread's context and what it has found so far.
class EdgeCheck {
 public:
  EdgeCheck(const Space& space, const std::vector<int>& body_component, const RobotReach& reach,
            CollisionContext& context, const Config& from, const Config& to,
            const CancelToken* cancel, const ClearanceBound* bound = nullptr,
            std::atomic<int64_t>* bound_total = nullptr, double rel_err = 0, bool threshold = false,
            bool warm_start = false)
      : space_(space),
        body_component_(body_component),
        reach_(reach),
        context_(context),
        from_(from),
        to_(to),
        cancel_(cancel),
        bound_(bound),
        bound_total_(bound_total),
        rel_err_(rel_err),
        threshold_(threshold),
        warm_start_(warm_start) {}
  ~EdgeCheck() {
    if (bound_total_ != nullptr) *bound_total_ += bound_queries_;
  }
  EdgeCheck(const EdgeCheck&) = delete;
  EdgeCheck& operator=(const EdgeCheck&) = delete;

  // A clearance for a certificate, at most the exact one: the bound's where it is positive (a
  // bound at or below 0 decides nothing, and only an exact query may find a collision), else
  // the exact one.
  struct Bounded {
    double t = 0;
    double clearance = 0;
    bool exact = false;
  };
  Bounded CertClearance(double t, const Config& q) {
    if (bound_ != nullptr) {
      ++bound_queries_;
      const double lower = bound_->LowerBound(q);
      if (lower > 0) return Bounded{.t = t, .clearance = lower, .exact = false};
    }
    if ((rel_err_ > 0 || threshold_) && whole_bound_ > 0) {
      // Past the cap a sample certifies the whole motion on its own (either way from t), so
      // nothing beyond it is worth measuring. Without an early stop a value below the cap is
      // exact; with one, only a 0 (contact) is.
      const double cap = kCapMargin * whole_bound_ * std::max(t, 1 - t);
      const double lower = rel_err_ == 0 && warm_start_
                               ? context_.ClearanceFrom(q, cap, &hint_)
                               : context_.ClearanceLowerBound(q, rel_err_, cap);
      return Bounded{
          .t = t, .clearance = lower, .exact = lower <= 0 || (rel_err_ == 0 && lower < cap)};
    }
    return Bounded{.t = t, .clearance = Exact(q), .exact = true};
  }
  // The exact clearance at q, from the last query's nearest points when warm starts are on.
  double Exact(const Config& q) {
    return warm_start_ ? context_.ClearanceFrom(q, std::numeric_limits<double>::infinity(), &hint_)
                       : context_.Clearance(q);
  }
  // Replaces a bound by the exact clearance. Returns false (and records where) if the sample
  // is in contact.
  bool MakeExact(Bounded& s, const Config& q) {
    if (!s.exact) {
      s.clearance = Exact(q);
      s.exact = true;
    }
    if (s.clearance <= 0) {
      invalid_at_ = s.t;
      return false;
    }
    return true;
  }

  // Refine for the certificate without a profile: the same halvings, on bounds first; a stretch
  // the bounds cannot certify has its ends measured exactly before it is halved, so it is halved
  // exactly where exact clearances would halve it. `lo` and `hi` keep what was measured.
  bool Certify(Bounded& lo, const Config& q_lo, Bounded& hi, const Config& q_hi, int depth,
               int max_depth) {
    const double need = MotionBound(q_lo, q_hi);
    if (lo.clearance + hi.clearance > need) return true;
    if (!MakeExact(lo, q_lo) || !MakeExact(hi, q_hi)) return false;
    if (lo.clearance + hi.clearance > need) return true;
    if (depth >= max_depth) {
      certified_ = false;
      return true;
    }
    const double t = 0.5 * (lo.t + hi.t);
    const Config q_mid = At(t);
    Bounded mid = CertClearance(t, q_mid);
    if (mid.exact && mid.clearance <= 0) {
      invalid_at_ = t;
      return false;
    }
    if (!Certify(lo, q_lo, mid, q_mid, depth + 1, max_depth)) return false;
    return Certify(mid, q_mid, hi, q_hi, depth + 1, max_depth);
  }

  Config At(double t) const { return space_.Interpolate(from_, to_, t); }

  // Advancement gives up where a step would be shorter than this fraction of the motion: the
  // profile's finest refinement.
  static double Finest(int segments) {
    return 1.0 / (static_cast<double>(segments) * (1 << LocalPlanner::kMaxRefineDepth));
  }
  // The share of the free stretch a step of advancement takes.
  static constexpr double kMargin = 0.999;

  // Every kCancelStride queries, throws if the caller stopped the check.
  void Tick() {
    if (cancel_ != nullptr && ++ticks_ % kCancelStride == 0) cancel_->ThrowIfStopped();
  }

  double MotionBound(const Config& a, const Config& b) const {
    return RobotMotionBound(space_, body_component_, reach_, a, b);
  }

  // Certifies the stretch between two profile samples, halving it while the certificate fails,
  // at most max_depth times. Appends the midpoints it queries to `out` in order of t. Returns
  // false if one collides.
  bool Refine(const ClearanceSample& lo, const Config& q_lo, const ClearanceSample& hi,
              const Config& q_hi, int depth, std::vector<ClearanceSample>& out,
              int max_depth = LocalPlanner::kMaxRefineDepth) {
    if (lo.clearance + hi.clearance > MotionBound(q_lo, q_hi)) return true;
    if (depth >= max_depth) {
      certified_ = false;
      return true;
    }
    const ClearanceSample mid{.t = 0.5 * (lo.t + hi.t)};
    const Config q_mid = At(mid.t);
    const double clearance = Exact(q_mid);
    if (clearance <= 0) {
      invalid_at_ = mid.t;
      return false;
    }
    const ClearanceSample sample{.t = mid.t, .clearance = clearance};
    if (!Refine(lo, q_lo, sample, q_mid, depth + 1, out, max_depth)) return false;
    out.push_back(sample);
    return Refine(sample, q_mid, hi, q_hi, depth + 1, out, max_depth);
  }

  // The samples at the resolution, ends first (the end state is the one most likely to be new
  // to the caller), then the interior in bisection order: the t of the first in collision, or
  // -1 if every one is valid. With `beside` (and samples enough to share) another thread free
  // for it takes the interior samples with this one, in the same order from one cursor; the
  // answer is the same, since every sample before the first in collision is checked either way.
  // `context_here` and `checks_elsewhere` as in AdvanceByDirection.
  double FirstInvalidSample(int segments, const EdgeKnown& known, bool beside,
                            const std::function<CollisionContext&()>& context_here,
                            std::atomic<int64_t>* checks_elsewhere) {
    if (!known.to_valid && !context_.Valid(to_)) return 1.0;
    if (!known.from_valid && !context_.Valid(from_)) return 0.0;
    const std::vector<int> order = BisectionOrder(segments);
    std::atomic<size_t> next{0};
    std::atomic<size_t> first_invalid{order.size()};
    const auto scan = [&](CollisionContext& context) {
      for (size_t i = next++; i < first_invalid.load(); i = next++) {
        if (cancel_ != nullptr) cancel_->ThrowIfStopped();
        if (context.Valid(At(static_cast<double>(order[i]) / segments))) continue;
        for (size_t known_first = first_invalid.load();
             i < known_first && !first_invalid.compare_exchange_weak(known_first, i);) {
        }
        return;
      }
    };
    if (beside && segments >= kShareSamples) {
      const auto share = [&] {
        OnThisThread(true, context_here, checks_elsewhere, &CollisionContext::collision_checks,
                     scan);
      };
      RunBeside(true, share, share);
    } else {
      scan(context_);
    }
    const size_t found = first_invalid.load();
    return found < order.size() ? static_cast<double>(order[found]) / segments : -1;
  }

  // What conservative advancement established: a certificate, or a point in contact
  // (invalid_at >= 0), or neither (it stalled where steps would shrink below the profile's
  // finest refinement).
  struct Advanced {
    bool certified = false;
    double invalid_at = -1;
  };
  // Conservative advancement (EdgeProof::kCertificate), two-sided: the motion bound is linear in
  // t along a straight motion, so a clearance c at t frees the robot for c / bound of the way on
  // either side of t. The next sample goes where, were its clearance c too, the two would just
  // cover the stretch between them; a stretch they do not cover is halved (Certify) down to the
  // profile's finest refinement. Where clearance changes slowly this takes half the queries of
  // advancing by c / bound from each sample.
  Advanced Advance(int segments) {
    const double bound = MotionBound(from_, to_);
    whole_bound_ = bound;
    const double finest = Finest(segments);
    Bounded a = CertClearance(0, from_);
    if (a.exact && a.clearance <= 0) return Advanced{.invalid_at = 0.0};
    Config q_a = from_;
    while (a.t < 1) {
      Tick();
      double reach = bound > 0 ? kMargin * a.clearance / bound : 1.0;
      // A bound too small to step on is measured exactly before advancement gives up.
      if (reach < finest && !a.exact) {
        if (!MakeExact(a, q_a)) return Advanced{.invalid_at = a.t};
        reach = bound > 0 ? kMargin * a.clearance / bound : 1.0;
      }
      if (reach < finest) return Advanced{};
      const double t_b = std::min(1.0, a.t + 2 * reach);
      Config q_b = t_b == 1.0 ? to_ : At(t_b);
      Bounded b = CertClearance(t_b, q_b);
      if (b.exact && b.clearance <= 0) return Advanced{.invalid_at = b.t};
      // Halvings of [a.t, b.t] that stay at least `finest` long.
      const int depth = std::max(0, static_cast<int>(std::floor(std::log2((b.t - a.t) / finest))));
      if (!Certify(a, q_a, b, q_b, 0, depth)) return Advanced{.invalid_at = invalid_at_};
      if (!certified_) return Advanced{};
      a = b;
      q_a = std::move(q_b);
    }
    return Advanced{.certified = true};
  }

  // Conservative advancement along the separating directions (LocalPlannerOptions::
  // direction_bound), from both ends of the motion: each front steps just short of where
  // CollisionContext::FreeFraction says the rest of the way to the other end is free, and the
  // motion is certified once the fronts pass each other (or one passes the far end). The front
  // from `from` runs first; the one from `to` runs beside it on another thread when `beside` and
  // one is free (`context_here` gives that thread's context, and the queries it runs there are
  // added to `queries_elsewhere`), else afterwards, from where the first stopped. Either way the
  // verdict is the same: certified exactly when the point where the first front stalls (or the
  // far end) lies beyond the point where the second one stalls, so a motion that grazes an
  // obstacle is certified from whichever side reaches past the graze. Without `both_ends`, the
  // first front alone.
  Advanced AdvanceByDirection(int segments, bool both_ends, bool beside,
                              const std::function<CollisionContext&()>& context_here,
                              std::atomic<int64_t>* queries_elsewhere,
                              std::atomic<int64_t>* checks_elsewhere) {
    const double finest = Finest(segments);
    Fronts fronts;
    RunBeside(
        beside,
        [&] {
          OnThisThread(
              beside, context_here, queries_elsewhere, &CollisionContext::distance_queries,
              [&](CollisionContext& context) { AdvanceFront(context, false, finest, &fronts); });
          if (!fronts.Met() && !fronts.contact.load()) {
            OnThisThread(beside, context_here, checks_elsewhere,
                         &CollisionContext::collision_checks,
                         [&](CollisionContext& context) { ProbeStall(context, finest, &fronts); });
          }
        },
        [&] {
          // Only where the reverse motion is the same curve (not two turns of exactly half a
          // revolution, which could go either way round).
          if (!both_ends || fronts.contact.load() || fronts.collides.load() >= 0 ||
              !SameReversed()) {
            return;
          }
          OnThisThread(
              beside, context_here, queries_elsewhere, &CollisionContext::distance_queries,
              [&](CollisionContext& context) { AdvanceFront(context, true, finest, &fronts); });
        });
    if (fronts.contact.load()) return Advanced{.invalid_at = 0.0};
    if (fronts.collides.load() >= 0) return Advanced{.invalid_at = fronts.collides.load()};
    return Advanced{.certified = fronts.Met()};
  }

  // The clearance profile: a distance query at each point of the resolution's grid (or its
  // clearance from `known`, sorted by t, may be null), then every stretch between two refined
  // (Refine) into `profile`. False (invalid_at set) if a point is in contact.
  bool Profile(int segments, const std::vector<ClearanceSample>* known,
               std::vector<ClearanceSample>* profile) {
    std::vector<Config> grid;
    std::vector<ClearanceSample> samples;
    grid.reserve(segments + 1);
    samples.reserve(segments + 1);
    size_t next_known = 0;
    for (int k = 0; k <= segments; ++k) {
      Tick();
      const double t = static_cast<double>(k) / segments;
      grid.push_back(k == 0 ? from_ : k == segments ? to_ : At(t));
      while (known != nullptr && next_known < known->size() && (*known)[next_known].t < t) {
        ++next_known;
      }
      const double clearance =
          known != nullptr && next_known < known->size() && (*known)[next_known].t == t
              ? (*known)[next_known].clearance
              : Exact(grid.back());
      // Touching contact: valid for FCL's collision test, but not free.
      if (clearance <= 0) {
        invalid_at_ = t;
        return false;
      }
      samples.push_back({.t = t, .clearance = clearance});
    }
    profile->reserve(samples.size());
    for (int k = 0; k < segments; ++k) {
      Tick();
      profile->push_back(samples[k]);
      if (!Refine(samples[k], grid[k], samples[k + 1], grid[k + 1], 0, *profile)) return false;
    }
    profile->push_back(samples.back());
    return true;
  }

  bool certified() const { return certified_; }
  double invalid_at() const { return invalid_at_; }

 private:
  // Where the two fronts of AdvanceByDirection stand: the one from `from` has shown [0, forward]
  // free, the one from `to` [backward, 1] (past the far end: 2 and -1).
  struct Fronts {
    std::atomic<double> forward{0.0};
    std::atomic<double> backward{1.0};
    std::atomic<bool> contact{false};    // `from` in contact: the motion is invalid
    std::atomic<double> collides{-1.0};  // where ProbeStall found the motion in collision
    bool Met() const { return forward.load() >= backward.load(); }
  };

  // One front of AdvanceByDirection, on `context` (the running thread's): from its end of the
  // motion towards the other, until the fronts meet, `from` is found in contact, or a step would
  // be shorter than `finest` (it stalls there). The front from `from` goes on a little past
  // `to`, so that it covers the end state too; the one from `to` likewise past `from`.
  void AdvanceFront(CollisionContext& context, bool backward, double finest, Fronts* fronts) const {
    constexpr double kPastEnd = 1.001;
    std::atomic<double>& mine = backward ? fronts->backward : fronts->forward;
    const Config& target = backward ? from_ : to_;
    double t = backward ? 1.0 : 0.0;
    Config q = backward ? to_ : from_;
    while (!fronts->Met() && !fronts->contact.load() && fronts->collides.load() < 0) {
      if (cancel_ != nullptr) cancel_->ThrowIfStopped();
      const double s = context.FreeFraction(q, target, kPastEnd);
      if (s > 1) {
        mine.store(backward ? -1.0 : 2.0);
        return;
      }
      if (s <= 0 && !backward && t == 0) {
        fronts->contact.store(true);
        return;
      }
      const double step = kMargin * s * (backward ? t : 1 - t);
      if (step < finest) return;
      t = backward ? t - step : t + step;
      mine.store(t);
      q = At(t);
    }
  }

  // After the front from `from` stalled at t: collision checks at t + finest * 2^j, j = 0, 1,
  // ..., short of `to`. A motion that stalls because it runs into an obstacle (rather than
  // grazing one) is in collision just past where its front stalls, and one found there makes the
  // second front needless. Where the checks go depends on t alone, so the verdict does not
  // depend on the second front's progress.
  void ProbeStall(CollisionContext& context, double finest, Fronts* fronts) const {
    const double stalled = fronts->forward.load();
    for (double offset = finest; stalled + offset < 1 && !fronts->Met(); offset *= 2) {
      if (cancel_ != nullptr) cancel_->ThrowIfStopped();
      const double t = stalled + offset;
      if (!context.Valid(At(t))) {
        fronts->collides.store(t);
        return;
      }
    }
  }

  // Runs work(context) on the context of the thread running it: this check's own in the calling
  // thread (`shared` false), else `context_here`'s, and where that is not this check's own, adds
  // what `count` counted there to `elsewhere`.
  template <class Work>
  void OnThisThread(bool shared, const std::function<CollisionContext&()>& context_here,
                    std::atomic<int64_t>* elsewhere, int64_t (CollisionContext::*count)() const,
                    const Work& work) const {
    CollisionContext& context = shared ? context_here() : context_;
    const int64_t before = (context.*count)();
    work(context);
    if (&context != &context_) *elsewhere += (context.*count)() - before;
  }

  // Whether the motion from `to` back to `from` passes where this one does (its midpoint; the
  // tolerance is far above the rounding of a rotation's distance, far below half a turn).
  bool SameReversed() const {
    const Config there = At(0.5);
    const Config back = space_.Interpolate(to_, from_, 0.5);
    return space_.Distance(there, back) <= 1e-6 * (1 + space_.Distance(from_, to_));
  }

  const Space& space_;
  const std::vector<int>& body_component_;
  const RobotReach& reach_;
  CollisionContext& context_;
  const Config& from_;
  const Config& to_;
  const CancelToken* cancel_;
  const ClearanceBound* bound_;
  std::atomic<int64_t>* bound_total_;
  const double rel_err_;
  const bool threshold_;
  const bool warm_start_;
  // Where the last query found the clearance: the next one starts from its points' distance.
  ClearanceWitness hint_;
  double whole_bound_ = 0;  // the motion bound of the whole edge (Advance)
  // A sample with the motion bound of the whole edge, times max(t, 1 - t), as clearance covers
  // it alone with advancement's margin (0.999) to spare.
  static constexpr double kCapMargin = 1.01;
  static constexpr int64_t kCancelStride = 16;
  // Fewer interior samples than this are not shared with another thread (FirstInvalidSample).
  static constexpr int kShareSamples = 8;
  bool certified_ = true;
  double invalid_at_ = -1;
  int64_t bound_queries_ = 0;
  int64_t ticks_ = 0;
};

}  // namespace

LocalPlanner::LocalPlanner(std::shared_ptr<const CollisionWorld> world, LocalPlannerOptions options)
    : world_(std::move(world)), options_(options), impl_(std::make_unique<Impl>()) {
  HGRAPH_CHECK(world_ != nullptr);
  HGRAPH_CHECK(options_.clearance_bound == nullptr ||
               &options_.clearance_bound->world() == world_.get());
  if (!std::isfinite(options_.resolution) || options_.resolution <= 0) {
    throw InputError("resolution",
                     "must be positive and finite, got " + std::to_string(options_.resolution));
  }
  if (!std::isfinite(options_.certificate_rel_err) || options_.certificate_rel_err < 0) {
    throw InputError("certificate_rel_err",
                     "must be >= 0 and finite, got " + limits::Num(options_.certificate_rel_err));
  }
  const Scene& scene = world_->scene();
  for (size_t i = 0; i < scene.robot.size(); ++i) {
    impl_->body_component.push_back(scene.robot[i].component);
    impl_->reach.radius.push_back(world_->BodyRadius(static_cast<int>(i)));
    impl_->reach.points.push_back(ExtremePoints(scene.robot[i]));
  }
}

LocalPlanner::~LocalPlanner() = default;

std::shared_ptr<const ClearanceBound> BuildClearanceBound(
    const std::shared_ptr<const CollisionWorld>& world, int threads) {
  return ClearanceBound::Build(world, ClearanceBoundOptions{.threads = threads});
}

size_t ClearanceBoundBytes(const ClearanceBound& bound) { return bound.memory_bytes(); }

const Space& LocalPlanner::space() const { return world_->space(); }

int LocalPlanner::SampleCount(double length) const {
  // Lengths and the resolution derive from the request: refuse, rather than assert, an edge
  // that would need too many samples.
  const double step = options_.resolution * space().MaxExtent();
  const double segments = step > 0 ? std::ceil(length / step) : 1.0;
  if (!std::isfinite(length) || length < 0 || !(segments <= limits::kMaxSamplesPerEdge)) {
    throw InputError("resolution", "an edge of length " + limits::Num(length) + " needs " +
                                       limits::Num(segments) + " collision samples at resolution " +
                                       limits::Num(options_.resolution) + ", more than " +
                                       limits::Num(limits::kMaxSamplesPerEdge) +
                                       "; raise the resolution or shorten the edge");
  }
  return std::max(1, static_cast<int>(segments)) + 1;
}

EdgeReport LocalPlanner::CheckEdge(const EdgeCheckRequest& request) const {
  HGRAPH_CHECK(request.from != nullptr && request.to != nullptr);
  const Space& s = space();
  const Config& from = *request.from;
  const Config& to = *request.to;
  HGRAPH_CHECK(from.size() == s.dimension() && to.size() == s.dimension());

  CollisionContext& context = impl_->Context(*world_);
  const int64_t checks_before = context.collision_checks();
  const int64_t queries_before = context.distance_queries();
  EdgeReport report;
  report.length = s.Distance(from, to);
  // A certificate's second front may run on another thread (EdgeCheckRequest::threads), on that
  // thread's context.
  const bool beside = request.threads > 1;
  const std::function<CollisionContext&()> context_here = [this]() -> CollisionContext& {
    return impl_->Context(*world_);
  };
  std::atomic<int64_t> checks_elsewhere{0};
  std::atomic<int64_t> queries_elsewhere{0};
  const auto finish = [&]() {
    report.collision_checks = context.collision_checks() - checks_before + checks_elsewhere.load();
    report.distance_queries =
        context.distance_queries() - queries_before + queries_elsewhere.load();
    impl_->collision_checks += report.collision_checks;
    impl_->distance_queries += report.distance_queries;
    return report;
  };
  const auto invalid = [&](double t) {
    report.state = EdgeState::kInvalid;
    report.invalid_at = t;
    report.has_clearance = false;
    report.profile.clear();
    report.certified = false;
    return finish();
  };

  // Three stages, each skipped where the request knows or does not ask for its answer: the
  // samples at the resolution, conservative advancement for a certificate, the profile.
  const int segments = SampleCount(report.length) - 1;
  EdgeCheck check(s, impl_->body_component, impl_->reach, context, from, to, request.cancel,
                  nullptr, nullptr, 0, false, options_.warm_start);
  if (!request.known.samples_valid) {
    const double t =
        check.FirstInvalidSample(segments, request.known, beside, context_here, &checks_elsewhere);
    if (t >= 0) return invalid(t);
  }
  report.state = EdgeState::kValid;
  if (request.proof == EdgeProof::kSamples) return finish();
  const auto by_direction = [&](EdgeCheck& advance) {
    return advance.AdvanceByDirection(segments, options_.advance_from_both_ends, beside,
                                      context_here, &queries_elsewhere, &checks_elsewhere);
  };
  if (request.proof != EdgeProof::kProfile) {
    EdgeCheck advance(s, impl_->body_component, impl_->reach, context, from, to, request.cancel,
                      options_.clearance_bound.get(), &impl_->bound_queries,
                      options_.certificate_rel_err, options_.certificate_threshold,
                      options_.warm_start);
    const EdgeCheck::Advanced advanced = options_.direction_bound && world_->CanAdvance()
                                             ? by_direction(advance)
                                             : advance.Advance(segments);
    if (advanced.invalid_at >= 0) return invalid(advanced.invalid_at);
    if (advanced.certified) {
      report.certified = true;
      report.advancement = Advancement::kCertified;
      return finish();
    }
    report.advancement = Advancement::kStalled;
    if (request.proof == EdgeProof::kCertificateOrGiveUp) return finish();
  }
  if (!check.Profile(segments, request.known.clearances, &report.profile)) {
    return invalid(check.invalid_at());
  }
  report.has_clearance = true;
  report.certified = check.certified();
  if (!report.certified && options_.direction_bound && world_->CanAdvance()) {
    // The profile's stretches did not add up; advancement along the separating directions may
    // still certify the motion (a slide along a wall), as it does without a profile.
    EdgeCheck advance(s, impl_->body_component, impl_->reach, context, from, to, request.cancel);
    report.certified = by_direction(advance).certified;
  }
  return finish();
}

bool LocalPlanner::IsValid(const Config& q) const {
  ++impl_->collision_checks;
  return impl_->Context(*world_).Valid(q);
}

double LocalPlanner::Clearance(const Config& q) const {
  ++impl_->distance_queries;
  return impl_->Context(*world_).Clearance(q);
}

double LocalPlanner::ClearanceAndWitness(const Config& q, ClearanceWitness* witness) const {
  ++impl_->distance_queries;
  return impl_->Context(*world_).Clearance(q, witness);
}

void LocalPlanner::LowerToWitnesses(const Config& from, const Config& to,
                                    const std::vector<ClearanceWitness>& witnesses,
                                    std::vector<ClearanceSample>* points) const {
  const size_t bodies = impl_->body_component.size();
  std::vector<char> used(bodies, 0);
  bool any = false;
  for (const ClearanceWitness& w : witnesses) {
    if (w.body < 0) continue;
    used[w.body] = 1;
    if (w.other_body >= 0) used[w.other_body] = 1;
    any = true;
  }
  if (!any) return;
  const Space& s = space();
  std::vector<Eigen::Isometry3d> poses(bodies, Eigen::Isometry3d::Identity());
  for (ClearanceSample& point : *points) {
    const Config q = s.Interpolate(from, to, point.t);
    for (size_t b = 0; b < bodies; ++b) {
      if (used[b]) poses[b] = world_->BodyPose(static_cast<int>(b), q);
    }
    for (const ClearanceWitness& w : witnesses) {
      if (w.body >= 0) {
        point.clearance = std::min(point.clearance, CollisionWorld::WitnessDistance(w, poses));
      }
    }
  }
}

double LocalPlanner::MotionBound(const Config& a, const Config& b) const {
  return RobotMotionBound(space(), impl_->body_component, impl_->reach, a, b);
}

std::vector<ClearanceSample> LocalPlanner::ProbeClearance(
    const Config& from, const Config& to, const std::vector<double>& fractions,
    const std::vector<ClearanceSample>& known, ProbeOrder order,
    std::vector<ClearanceWitness>* witnesses) const {
  const Space& s = space();
  HGRAPH_CHECK(from.size() == s.dimension() && to.size() == s.dimension());
  // The profile's grid (CheckEdge): t = k / segments, the configuration interpolated from `from`.
  const int segments = SampleCount(s.Distance(from, to)) - 1;
  std::vector<int> ks;
  for (double f : fractions) {
    const int k = static_cast<int>(std::lround(std::clamp(f, 0.0, 1.0) * segments));
    const double t = static_cast<double>(k) / segments;
    const bool seen = std::any_of(known.begin(), known.end(),
                                  [t](const ClearanceSample& sample) { return sample.t == t; });
    if (k > 0 && k < segments && !seen && std::find(ks.begin(), ks.end(), k) == ks.end()) {
      ks.push_back(k);
    }
  }
  // A scan for contact keeps the caller's order (the likeliest points first).
  if (order != ProbeOrder::kCollisionOnly) std::sort(ks.begin(), ks.end());
  CollisionContext& context = impl_->Context(*world_);
  std::vector<ClearanceSample> out;
  out.reserve(ks.size());
  int64_t checks = 0;
  int64_t queries = 0;
  for (int k : ks) {
    const double t = static_cast<double>(k) / segments;
    const Config q = s.Interpolate(from, to, t);
    if (order != ProbeOrder::kDistanceOnly) {
      ++checks;
      if (!context.Valid(q)) {
        out.push_back({.t = t, .clearance = 0});
        break;
      }
      if (order == ProbeOrder::kCollisionOnly) continue;
    }
    ++queries;
    ClearanceWitness witness;
    out.push_back(
        {.t = t, .clearance = context.Clearance(q, witnesses != nullptr ? &witness : nullptr)});
    if (witness.body >= 0) witnesses->push_back(witness);
    if (order == ProbeOrder::kCollisionFirst && out.back().clearance <= 0) break;
  }
  impl_->collision_checks += checks;
  impl_->distance_queries += queries;
  return out;
}

int64_t LocalPlanner::total_collision_checks() const { return impl_->collision_checks.load(); }
int64_t LocalPlanner::total_distance_queries() const { return impl_->distance_queries.load(); }
int64_t LocalPlanner::total_bound_queries() const { return impl_->bound_queries.load(); }

}  // namespace hgraph
