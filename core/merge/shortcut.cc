#include "core/merge/shortcut.h"

#include <algorithm>
#include <numeric>
#include <random>

#include "core/common/error.h"
#include "core/common/parallel.h"
#include "core/measure/measure.h"

namespace hgraph {
namespace {

// The check of the straight motion from a to b: certified, with a clearance profile when a
// safety clearance must be kept. Without one, a motion whose certificate stalls (it grazes an
// obstacle) is given up at once (kCertifiedQuick): only proven motions are taken, and the random
// pairs and corners offer others. On the 21 kept benchmark problems (hgraph-bench seeds 1-3,
// defaults, one thread) this took the post-optimization's cost from 613k to 576k (collision
// checks + 10 x distance queries) and the merges' time by 8%, for a geometric mean of the length
// ratios to OMPL of 0.9446 against 0.9443. With `lazy` (ShortcutRequest::lazy, or sampled), at
// the samples only.
EdgeReport Check(const MotionChecker& checker, const Config& a, const Config& b, double safety,
                 bool lazy, int threads, const CancelToken& cancel) {
  return checker.CheckEdge(EdgeCheckRequest{.from = &a,
                                            .to = &b,
                                            .proof = safety > 0 ? EdgeProof::kProfile
                                                     : lazy     ? EdgeProof::kSamples
                                                                : EdgeProof::kCertificateOrGiveUp,
                                            .cancel = &cancel,
                                            .threads = threads});
}

// The certificate of a motion that `at_samples` found valid at its samples (kCertificateOrGiveUp,
// without checking them again); the report counts both checks.
EdgeReport Certify(const MotionChecker& checker, const Config& a, const Config& b,
                   const EdgeReport& at_samples, int threads, const CancelToken& cancel) {
  EdgeReport report = checker.CheckEdge(EdgeCheckRequest{.from = &a,
                                                         .to = &b,
                                                         .proof = EdgeProof::kCertificateOrGiveUp,
                                                         .known = {.samples_valid = true},
                                                         .cancel = &cancel,
                                                         .threads = threads});
  report.collision_checks += at_samples.collision_checks;
  report.distance_queries += at_samples.distance_queries;
  return report;
}

// Whether a path may take the motion: proven free (and keeping `safety`), or with `lazy` valid at
// its samples; with `sampled` (ShortcutRequest::sampled) valid at its samples, also with a
// profile whose certificate failed.
bool MayTake(const EdgeReport& report, double safety, bool lazy, bool sampled) {
  const bool usable = sampled ? report.usable_at_samples() : report.usable();
  return report.state == EdgeState::kValid && (report.certified || lazy || sampled) && usable &&
         (safety <= 0 || (report.has_clearance && MinClearance(report) >= safety));
}

// The stretch of an accepted motion (`whole`) from `from` to `to`: it keeps the motion's verdict
// (a merge profiles its output's edges at the end, which would find anything a sampled check
// missed); a certificate holds for every stretch of the motion, a profile does not map onto one.
// With `sampled` a piece of a motion without a certificate is unchecked (ShortcutRequest::sampled).
EdgeReport Piece(const Space& space, const EdgeReport& whole, const Config& from, const Config& to,
                 bool sampled) {
  const bool certified = whole.certified && !whole.has_clearance;
  return EdgeReport{.state = sampled && !certified ? EdgeState::kUnchecked : whole.state,
                    .length = space.Distance(from, to),
                    .certified = certified,
                    .advancement = certified ? whole.advancement : Advancement::kUnknown};
}

double PathLength(const std::vector<EdgeReport>& edges) {
  double total = 0;
  for (const EdgeReport& e : edges) total += e.length;
  return total;
}

// Random pairs tried per pass by default: this many per waypoint, at least kMinAttempts. With
// the merge's rounds (each re-hybridized, then a polish of corner cuts), 5 and 30 did as well as
// 10 and 50 for 11% less work on the 14 kept benchmark problems (hgraph-bench seeds 1 and 2:
// collision checks + 10 x distance queries 524k against 589k before the polish; lengths, as a
// geometric mean of the ratios to the best OMPL pipeline, 0.942 against 0.946).
constexpr int kAttemptsPerWaypoint = 5;
constexpr int kMinAttempts = 30;
// The smallest fraction of an edge a corner cut tries, and the least a cut must be able to gain,
// as a fraction of the path's length, to be checked at all (a cut f of the way gains about f
// times the f = 1 cut, so flat corners and small fractions are skipped). On the 14 kept
// benchmark problems 1e-4 took the polish's cost from 524k to 433k (collision checks + 10 x
// distance queries) for a geometric mean of the length ratios to OMPL of 0.9429 against 0.9423;
// 3e-4: 406k, 0.9439; 1e-3: 387k, 0.9468.
constexpr double kMinCornerCut = 1.0 / 16;
constexpr double kMinCornerGain = 1e-4;

// A random shortcut of a batch: from a (fraction t0 of edge e0) to b (t1 of edge e1), straight
// or through `points` (a partial shortcut's waypoints), what it gains, and the checks of its
// motions in order, up to the first one not proven free.
struct Candidate {
  size_t e0 = 0;
  size_t e1 = 0;
  double t0 = 0;
  double t1 = 0;
  Config a;
  Config b;
  std::vector<Config> points;
  double gain = 0;
  std::vector<EdgeReport> reports;
  bool free = false;
  // Valid at its samples, its certificates not yet asked for (Shortening::CheckCandidates).
  bool at_samples = false;
  bool checked = false;  // CheckCandidates has run on it
};

// One call of ShortcutCertified: the request, and the path being shortened (the result's path,
// ids, sources and edges, kept in step), through its three phases.
class Shortening {
 public:
  Shortening(const MotionChecker& checker, const ShortcutRequest& request,
             const CancelToken& cancel);
  // Phase 1: waypoints dropped where their neighbours connect.
  void DropWaypoints();
  // Phase 2: seeded random pairs of points along the path, some of them partial shortcuts.
  void TryRandomPairs();
  // Phase 3 (corners_only): every corner cut where a cut is proven free.
  void CutCorners();
  ShortcutResult Finish() { return std::move(out_); }

 private:
  // A corner cut (CutCorners): the points a fraction f of the corner's edges away from it, and
  // the check of the motion that joins them.
  struct Cut {
    Config a;
    Config b;
    double f = 0;
    EdgeReport report;
    bool free = false;
    int checks = 0;
  };

  // Past the request's `until`: nothing new is started.
  bool OutOfTime() const {
    return request_.until && std::chrono::steady_clock::now() >= *request_.until;
  }
  // Whether CheckMotion gives up where a certificate stalls (EdgeProof::kCertificateOrGiveUp).
  bool GivesUp() const { return request_.safety <= 0 && !lazy_ && !request_.sampled; }
  EdgeReport CheckMotion(const Config& a, const Config& b) const {
    return Check(checker_, a, b, request_.safety, lazy_ || request_.sampled, threads_, cancel_);
  }
  bool MayTake(const EdgeReport& report) const {
    return hgraph::MayTake(report, request_.safety, lazy_, request_.sampled);
  }
  EdgeReport PieceOf(const EdgeReport& whole, const Config& from, const Config& to) const {
    return Piece(space_, whole, from, to, request_.sampled);
  }
  // The motions joining the neighbours of the waypoints `tried`: reports the caller knows where
  // they settle the question (from_caller), checks otherwise.
  std::vector<EdgeReport> JoinNeighbours(const std::vector<size_t>& tried,
                                         std::vector<char>* from_caller,
                                         std::vector<char>* at_samples) const;
  // With certificates JoinNeighbours checks the joins at their samples only (`at_samples`):
  // certifies those a pass would drop, until every one it would drop is free.
  void CertifyDrops(const std::vector<size_t>& tried, std::vector<EdgeReport>* joined,
                    std::vector<char>* at_samples) const;
  // Drops the waypoints `drops` (ascending), each one's two edges replaced by `reports`.
  void Drop(const std::vector<size_t>& drops, std::vector<EdgeReport>* reports,
            std::vector<char>* settled);
  // Edge index and fraction of a position `s` along the path.
  void Locate(double s, size_t* edge, double* t) const;
  // Up to kShortcutBatch random pairs that would gain if free, counting `attempt` up to
  // `attempts`.
  std::vector<Candidate> DrawBatch(int attempts, int* attempt);
  // The partial shortcut of `c` moving `part` straight from c.a to c.b (its points), and its
  // length; `along` is the path's length from a to b.
  double Partial(const Space::Part& part, double along, Candidate* c) const;
  // Checks the motions of the candidates `which` in order, up to the first not proven free; with
  // certificates, at their samples only (Candidate::at_samples), for TakeFromBatch to certify.
  void CheckCandidates(std::vector<Candidate>* batch, const std::vector<size_t>& which);
  // The free candidates that gain most, no two sharing an edge of the path, from the path's end
  // backwards (so that applying them in turn keeps the others' edge indices valid). Checks the
  // candidates that would be taken, then certifies those valid at their samples, until every
  // one it takes is free.
  std::vector<size_t> TakeFromBatch(std::vector<Candidate>* batch);
  // Replaces the stretch of the path between c.a and c.b by the candidate's motions.
  void Splice(Candidate& c);
  // The corner cut at every interior waypoint: the largest f proven free, or none.
  std::vector<Cut> FindCuts() const;
  // The path with the free cuts taken.
  void ApplyCuts(std::vector<Cut>& cuts);

  const MotionChecker& checker_;
  const ShortcutRequest& request_;
  const CancelToken& cancel_;
  const Space& space_;
  const int threads_;
  const bool lazy_;
  ShortcutResult out_;
  std::vector<Config>& q_ = out_.path.waypoints;
  std::vector<int>& ids_ = out_.ids;
  std::vector<WaypointSource>& sources_ = out_.sources;
  std::vector<EdgeReport>& edges_ = out_.edges;
  std::mt19937_64 rng_;
};

Shortening::Shortening(const MotionChecker& checker, const ShortcutRequest& request,
                       const CancelToken& cancel)
    : checker_(checker),
      request_(request),
      cancel_(cancel),
      space_(checker.space()),
      threads_(request.threads == 0 ? DefaultConcurrency() : std::max(1, request.threads)),
      lazy_(request.lazy && request.safety <= 0),
      rng_(request.seed) {
  out_.path = request.path;
  HGRAPH_CHECK(q_.size() >= 2);
  ids_ = request.ids;
  if (ids_.size() != q_.size()) ids_.assign(q_.size(), -1);
  sources_ = request.sources;
  if (sources_.size() != q_.size()) sources_.assign(q_.size(), WaypointSource{});
  edges_ = request.edges;
  if (edges_.size() != q_.size() - 1) {
    edges_.assign(q_.size() - 1, EdgeReport{});
    for (size_t j = 0; j + 1 < q_.size(); ++j) edges_[j].length = space_.Distance(q_[j], q_[j + 1]);
  }
}

void Shortening::DropWaypoints() {
  // Waypoints whose neighbours connect directly. A pass checks every waypoint not yet settled
  // and drops those whose check passed, left to right, never two neighbours (the second one's
  // check joined a waypoint the first one removed); a drop unsettles the neighbours.
  std::vector<char> settled(q_.size(), request_.corners_only ? 1 : 0);
  while (!OutOfTime()) {
    cancel_.ThrowIfStopped();
    std::vector<size_t> tried;
    for (size_t j = 1; j + 1 < q_.size(); ++j) {
      if (settled[j]) continue;
      if (space_.Distance(q_[j - 1], q_[j + 1]) >= edges_[j - 1].length + edges_[j].length) {
        settled[j] = 1;
        continue;
      }
      tried.push_back(j);
    }
    if (tried.empty()) break;
    std::vector<char> from_caller;
    std::vector<char> at_samples;
    std::vector<EdgeReport> joined = JoinNeighbours(tried, &from_caller, &at_samples);
    CertifyDrops(tried, &joined, &at_samples);
    std::vector<size_t> drops;
    std::vector<EdgeReport> drop_reports;
    for (size_t k = 0; k < tried.size(); ++k) {
      const size_t j = tried[k];
      if (!from_caller[k]) {
        ++out_.edges_checked;
        if (ids_[j - 1] >= 0 && ids_[j + 1] >= 0) {
          out_.id_checks.emplace_back(ids_[j - 1], ids_[j + 1], joined[k]);
        }
      }
      settled[j] = 1;
      if (!MayTake(joined[k]) && !at_samples[k]) continue;
      if (!drops.empty() && drops.back() + 1 == j) {
        settled[j] = 0;  // its left neighbour goes: try again with the new one
        continue;
      }
      HGRAPH_CHECK(!at_samples[k]);  // CertifyDrops certified every join a pass drops
      drops.push_back(j);
      drop_reports.push_back(std::move(joined[k]));
    }
    Drop(drops, &drop_reports, &settled);
  }
}

std::vector<EdgeReport> Shortening::JoinNeighbours(const std::vector<size_t>& tried,
                                                   std::vector<char>* from_caller,
                                                   std::vector<char>* at_samples) const {
  std::vector<EdgeReport> joined(tried.size());
  from_caller->assign(tried.size(), 0);
  at_samples->assign(tried.size(), 0);
  for (size_t k = 0; k < tried.size(); ++k) {
    const size_t j = tried[k];
    if (!request_.known || ids_[j - 1] < 0 || ids_[j + 1] < 0) continue;
    const EdgeReport* known = request_.known(ids_[j - 1], ids_[j + 1]);
    // Taken when it settles the question: free, or not free whatever the safety. Where the check
    // would give up on a stalled certificate, a known motion answers as that check would: by
    // what advancement concluded on it (a profile's certificate, found for another query, would
    // make the answer depend on what was asked before).
    if (known == nullptr || (!MayTake(*known) && known->state != EdgeState::kInvalid &&
                             (request_.sampled ? known->usable_at_samples() : known->usable()))) {
      continue;
    }
    if (GivesUp() && known->state == EdgeState::kValid) {
      if (known->advancement == Advancement::kUnknown) continue;
      if (known->advancement == Advancement::kStalled) {
        joined[k] = EdgeReport{.state = EdgeState::kValid,
                               .length = known->length,
                               .advancement = Advancement::kStalled};
        (*from_caller)[k] = 1;
        continue;
      }
    }
    joined[k] = *known;
    (*from_caller)[k] = 1;
  }
  // With certificates the samples come first, as in a batch of random pairs: CertifyDrops
  // certifies those a pass would drop.
  const bool samples_first = GivesUp();
  ParallelFor(threads_, tried.size(), [&](size_t k) {
    if ((*from_caller)[k] || cancel_.stopped()) return;
    const size_t j = tried[k];
    if (samples_first) {
      joined[k] = Check(checker_, q_[j - 1], q_[j + 1], 0, true, threads_, cancel_);
      (*at_samples)[k] = joined[k].state == EdgeState::kValid;
    } else {
      joined[k] = CheckMotion(q_[j - 1], q_[j + 1]);
    }
  });
  cancel_.ThrowIfStopped();
  return joined;
}

void Shortening::CertifyDrops(const std::vector<size_t>& tried, std::vector<EdgeReport>* joined,
                              std::vector<char>* at_samples) const {
  for (;;) {
    // The drops a pass makes (left to right, never two neighbours) among the joins free or
    // valid at their samples; those at their samples are certified, and the choice is made
    // again without any that failed. It ends with the drops certifying every join first would
    // make, without the certificates of joins beside a drop (checked again in the next pass,
    // against the new neighbour).
    std::vector<size_t> to_certify;
    size_t last_drop = 0;
    for (size_t k = 0; k < tried.size(); ++k) {
      if (!(*at_samples)[k] && !MayTake((*joined)[k])) continue;
      if (last_drop > 0 && last_drop + 1 == tried[k]) continue;
      last_drop = tried[k];
      if ((*at_samples)[k]) to_certify.push_back(k);
    }
    if (to_certify.empty()) return;
    ParallelFor(threads_, to_certify.size(), [&](size_t i) {
      if (cancel_.stopped()) return;
      const size_t k = to_certify[i];
      const size_t j = tried[k];
      (*joined)[k] = Certify(checker_, q_[j - 1], q_[j + 1], (*joined)[k], threads_, cancel_);
    });
    cancel_.ThrowIfStopped();
    for (size_t k : to_certify) (*at_samples)[k] = 0;
  }
}

void Shortening::Drop(const std::vector<size_t>& drops, std::vector<EdgeReport>* reports,
                      std::vector<char>* settled) {
  for (size_t d = drops.size(); d-- > 0;) {
    const size_t j = drops[d];
    const auto at = static_cast<std::ptrdiff_t>(j);
    q_.erase(q_.begin() + at);
    ids_.erase(ids_.begin() + at);
    sources_.erase(sources_.begin() + at);
    edges_.erase(edges_.begin() + at);
    edges_[j - 1] = std::move((*reports)[d]);
    settled->erase(settled->begin() + at);
    (*settled)[j - 1] = 0;
    (*settled)[j] = 0;
    ++out_.accepted;
  }
}

void Shortening::TryRandomPairs() {
  const int attempts =
      request_.corners_only ? 0
      : request_.attempts > 0
          ? request_.attempts
          : std::max(kMinAttempts, kAttemptsPerWaypoint * static_cast<int>(q_.size()));
  for (int attempt = 0; attempt < attempts && q_.size() >= 2 && !OutOfTime();) {
    cancel_.ThrowIfStopped();
    if (PathLength(edges_) <= 0) break;
    std::vector<Candidate> batch = DrawBatch(attempts, &attempt);
    if (batch.empty()) continue;
    for (size_t k : TakeFromBatch(&batch)) Splice(batch[k]);
  }
}

void Shortening::Locate(double s, size_t* edge, double* t) const {
  double at = 0;
  for (size_t j = 0; j < edges_.size(); ++j) {
    if (s <= at + edges_[j].length || j + 1 == edges_.size()) {
      *edge = j;
      *t = edges_[j].length > 0 ? std::clamp((s - at) / edges_[j].length, 0.0, 1.0) : 0.0;
      return;
    }
    at += edges_[j].length;
  }
}

std::vector<Candidate> Shortening::DrawBatch(int attempts, int* attempt) {
  const std::vector<Space::Part> parts = space_.Parts();
  std::uniform_real_distribution<double> share(0.0, 1.0);
  std::uniform_real_distribution<double> position(0.0, PathLength(edges_));
  std::vector<Candidate> batch;
  for (int drawn = 0; drawn < kShortcutBatch && *attempt < attempts; ++drawn, ++*attempt) {
    const bool partial =
        request_.partial > 0 && parts.size() >= 2 && share(rng_) < request_.partial;
    double s0 = position(rng_);
    double s1 = position(rng_);
    if (s0 > s1) std::swap(s0, s1);
    Candidate c;
    Locate(s0, &c.e0, &c.t0);
    Locate(s1, &c.e1, &c.t1);
    if (c.e0 == c.e1) continue;  // one straight edge: nothing to gain
    c.a = space_.Interpolate(q_[c.e0], q_[c.e0 + 1], c.t0);
    c.b = space_.Interpolate(q_[c.e1], q_[c.e1 + 1], c.t1);
    // What the stretch from a to b costs now, along the path.
    double along = (1 - c.t0) * edges_[c.e0].length + c.t1 * edges_[c.e1].length;
    for (size_t j = c.e0 + 1; j < c.e1; ++j) along += edges_[j].length;
    double cost = 0;
    if (partial && along > 0) {
      const Space::Part part =
          parts[std::uniform_int_distribution<size_t>(0, parts.size() - 1)(rng_)];
      cost = Partial(part, along, &c);
    } else {
      cost = space_.Distance(c.a, c.b);
    }
    if (cost >= along * (1 - 1e-9)) continue;
    c.gain = along - cost;
    batch.push_back(std::move(c));
  }
  return batch;
}

double Shortening::Partial(const Space::Part& part, double along, Candidate* c) const {
  // The part moves straight from a to b, as far along at each waypoint as the path is.
  double at = (1 - c->t0) * edges_[c->e0].length;
  double cost = 0;
  const Config* previous = &c->a;
  c->points.reserve(c->e1 - c->e0);
  for (size_t j = c->e0 + 1; j <= c->e1; ++j) {
    Config m = q_[j];
    m.segment(part.offset, part.size) =
        space_.Interpolate(c->a, c->b, at / along).segment(part.offset, part.size);
    cost += space_.Distance(*previous, m);
    c->points.push_back(std::move(m));
    previous = &c->points.back();
    at += edges_[j].length;
  }
  return cost + space_.Distance(*previous, c->b);
}

void Shortening::CheckCandidates(std::vector<Candidate>* batch, const std::vector<size_t>& which) {
  // With certificates the samples come first: only the candidates the batch would take need a
  // certificate (TakeFromBatch).
  const bool samples_first = GivesUp();
  ParallelFor(threads_, which.size(), [&](size_t i) {
    Candidate& c = (*batch)[which[i]];
    for (size_t j = 0; j <= c.points.size(); ++j) {
      if (cancel_.stopped()) return;
      const Config& from = j == 0 ? c.a : c.points[j - 1];
      const Config& to = j < c.points.size() ? c.points[j] : c.b;
      c.reports.push_back(samples_first ? Check(checker_, from, to, 0, true, threads_, cancel_)
                                        : CheckMotion(from, to));
      if (samples_first ? c.reports.back().state != EdgeState::kValid
                        : !MayTake(c.reports.back())) {
        return;
      }
    }
    (samples_first ? c.at_samples : c.free) = true;
  });
  cancel_.ThrowIfStopped();
  for (size_t k : which) {
    out_.edges_checked += static_cast<int64_t>((*batch)[k].reports.size());
  }
}

std::vector<size_t> Shortening::TakeFromBatch(std::vector<Candidate>* batch) {
  std::vector<Candidate>& b = *batch;
  std::vector<size_t> order(b.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t x, size_t y) { return b[x].gain > b[y].gain; });
  std::vector<size_t> taken;
  for (;;) {
    // The best candidates not known to fail, no two overlapping. Those not checked yet are
    // checked (at their samples, with certificates), then those valid at their samples are
    // certified, and the choice is made again without any that failed. It ends with the choice
    // checking every candidate first would make, the best free ones first, but checks only
    // those that some choice on the way would take: a candidate that overlaps a better free one
    // is never checked.
    taken.clear();
    std::vector<size_t> to_check;
    std::vector<size_t> to_certify;
    for (size_t k : order) {
      if (b[k].checked && !b[k].free && !b[k].at_samples) continue;
      const bool overlaps = std::any_of(taken.begin(), taken.end(), [&](size_t o) {
        return !(b[k].e1 < b[o].e0 || b[o].e1 < b[k].e0);
      });
      if (overlaps) continue;
      taken.push_back(k);
      if (!b[k].checked) {
        to_check.push_back(k);
      } else if (b[k].at_samples) {
        to_certify.push_back(k);
      }
    }
    if (!to_check.empty()) {
      CheckCandidates(batch, to_check);
      for (size_t k : to_check) b[k].checked = true;
      continue;
    }
    if (to_certify.empty()) break;
    ParallelFor(threads_, to_certify.size(), [&](size_t i) {
      Candidate& c = b[to_certify[i]];
      for (size_t j = 0; j <= c.points.size(); ++j) {
        if (cancel_.stopped()) return;
        const Config& from = j == 0 ? c.a : c.points[j - 1];
        const Config& to = j < c.points.size() ? c.points[j] : c.b;
        c.reports[j] = Certify(checker_, from, to, c.reports[j], threads_, cancel_);
        if (!MayTake(c.reports[j])) break;
        if (j == c.points.size()) c.free = true;
      }
      c.at_samples = false;
    });
    cancel_.ThrowIfStopped();
  }
  std::sort(taken.begin(), taken.end(), [&](size_t x, size_t y) { return b[x].e0 > b[y].e0; });
  return taken;
}

void Shortening::Splice(Candidate& c) {
  // The cut edges' pieces up to a and from b.
  EdgeReport head = PieceOf(edges_[c.e0], q_[c.e0], c.a);
  EdgeReport tail = PieceOf(edges_[c.e1], c.b, q_[c.e1 + 1]);
  const auto keep = static_cast<std::ptrdiff_t>(c.e0 + 1);
  std::vector<Config> nq(q_.begin(), q_.begin() + keep);
  std::vector<int> ni(ids_.begin(), ids_.begin() + keep);
  std::vector<WaypointSource> ns(sources_.begin(), sources_.begin() + keep);
  std::vector<EdgeReport> ne(edges_.begin(), edges_.begin() + keep - 1);
  // Zero-length pieces (a point at a waypoint) are left out.
  if (head.length > 0) {
    nq.push_back(c.a);
    ni.push_back(-1);
    ns.push_back(SourceBetween(sources_[c.e0], sources_[c.e0 + 1], c.t0));
    ne.push_back(std::move(head));
  }
  for (size_t j = 0; j < c.points.size(); ++j) {
    nq.push_back(std::move(c.points[j]));
    ni.push_back(-1);
    ns.emplace_back();
    ne.push_back(std::move(c.reports[j]));
  }
  ne.push_back(std::move(c.reports.back()));
  if (tail.length > 0) {
    nq.push_back(c.b);
    ni.push_back(-1);
    ns.push_back(SourceBetween(sources_[c.e1], sources_[c.e1 + 1], c.t1));
    ne.push_back(std::move(tail));
  }
  const auto rest = static_cast<std::ptrdiff_t>(c.e1 + 1);
  nq.insert(nq.end(), q_.begin() + rest, q_.end());
  ni.insert(ni.end(), ids_.begin() + rest, ids_.end());
  ns.insert(ns.end(), sources_.begin() + rest, sources_.end());
  ne.insert(ne.end(), edges_.begin() + rest, edges_.end());
  q_ = std::move(nq);
  ids_ = std::move(ni);
  sources_ = std::move(ns);
  edges_ = std::move(ne);
  ++out_.accepted;
}

void Shortening::CutCorners() {
  // Corners cut (corners_only): each interior waypoint is replaced by two points on its edges, a
  // fraction f of each edge away from it (f = 1/2, 1/4, ..., the largest proven free), joined by
  // a straight motion. Near obstacles random pairs rarely land on both sides of one corner; this
  // is where a path tightens around them. f <= 1/2 keeps the cuts of neighbouring corners apart,
  // so every corner is tried at once.
  if (q_.size() < 3) return;
  cancel_.ThrowIfStopped();
  std::vector<Cut> cuts = FindCuts();
  ApplyCuts(cuts);
}

std::vector<Shortening::Cut> Shortening::FindCuts() const {
  std::vector<Cut> cuts(q_.size());
  const double least_gain = kMinCornerGain * PathLength(edges_);
  ParallelFor(threads_, q_.size() - 2, [&](size_t k) {
    const size_t j = k + 1;
    if (cancel_.stopped() || OutOfTime()) return;
    for (double f = 0.5; f >= kMinCornerCut; f /= 2) {
      Cut& cut = cuts[j];
      cut.f = f;
      cut.a = space_.Interpolate(q_[j], q_[j - 1], f);
      cut.b = space_.Interpolate(q_[j], q_[j + 1], f);
      if (space_.Distance(cut.a, cut.b) >=
          f * (edges_[j - 1].length + edges_[j].length) * (1 - 1e-9) - least_gain) {
        return;  // a straight corner, or a cut too small to matter
      }
      cut.report = CheckMotion(cut.a, cut.b);
      ++cut.checks;
      cut.free = MayTake(cut.report);
      if (cut.free) return;
    }
  });
  cancel_.ThrowIfStopped();
  return cuts;
}

void Shortening::ApplyCuts(std::vector<Cut>& cuts) {
  std::vector<Config> nq{q_.front()};
  std::vector<int> ni{ids_.front()};
  std::vector<WaypointSource> ns{sources_.front()};
  std::vector<EdgeReport> ne;
  // Edge j - 1 of the path, from the previous corner's cut (if any) to this one's (if any): the
  // edge itself, or a piece of it.
  const auto add_edge = [&](size_t j, const Config& to) {
    const bool whole = !cuts[j - 1].free && !cuts[j].free;
    ne.push_back(whole ? edges_[j - 1] : PieceOf(edges_[j - 1], nq.back(), to));
  };
  for (size_t j = 1; j + 1 < q_.size(); ++j) {
    out_.edges_checked += cuts[j].checks;
    if (!cuts[j].free) {
      add_edge(j, q_[j]);
      nq.push_back(q_[j]);
      ni.push_back(ids_[j]);
      ns.push_back(sources_[j]);
      continue;
    }
    // Two cuts at the middle of one edge meet there: the point is kept once.
    if (space_.Distance(nq.back(), cuts[j].a) > 0) {
      add_edge(j, cuts[j].a);
      nq.push_back(cuts[j].a);
      ni.push_back(-1);
      ns.push_back(SourceBetween(sources_[j], sources_[j - 1], cuts[j].f));
    }
    ne.push_back(std::move(cuts[j].report));
    nq.push_back(cuts[j].b);
    ni.push_back(-1);
    ns.push_back(SourceBetween(sources_[j], sources_[j + 1], cuts[j].f));
    ++out_.accepted;
  }
  add_edge(q_.size() - 1, q_.back());
  nq.push_back(q_.back());
  ni.push_back(ids_.back());
  ns.push_back(sources_.back());
  q_ = std::move(nq);
  ids_ = std::move(ni);
  sources_ = std::move(ns);
  edges_ = std::move(ne);
}

}  // namespace

WaypointSource SourceBetween(const WaypointSource& a, const WaypointSource& b, double t) {
  if (a.path < 0 || a.path != b.path) return {};
  // A waypoint at the start of input edge i (t = 0) is also the end of edge i - 1.
  int index = a.index;
  double from = a.t;
  double to = 0;
  if (b.index == a.index) {
    to = b.t;
  } else if (b.index == a.index + 1 && b.t == 0) {
    to = 1;
  } else if (a.index == b.index + 1 && a.t == 0) {
    index = b.index;
    from = 1;
    to = b.t;
  } else {
    return {};
  }
  const double at = from + t * (to - from);
  if (at >= 1) return WaypointSource{.path = a.path, .index = index + 1, .t = 0};
  return WaypointSource{.path = a.path, .index = index, .t = std::max(0.0, at)};
}

ShortcutResult ShortcutCertified(const MotionChecker& checker, const ShortcutRequest& request,
                                 const CancelToken& cancel) {
  Shortening shortening(checker, request, cancel);
  try {
    shortening.DropWaypoints();
    shortening.TryRandomPairs();
    if (request.corners_only) shortening.CutCorners();
  } catch (const Error& e) {
    // A token whose deadline is the request's `until` stopped a check in flight: the
    // shortcuts taken before it stand (a pass changes the path only once its checks are done).
    if (e.code() != ErrorCode::kDeadlineExceeded || !request.until ||
        std::chrono::steady_clock::now() < *request.until) {
      throw;
    }
  }
  return shortening.Finish();
}

}  // namespace hgraph
