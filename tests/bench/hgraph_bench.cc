// hgraph against the pipeline OMPL users run today, side by side in one run (issue 10, item 5).
// For every scene: fixed PRM inputs (planned once with a fixed seed and written to --out, or read
// back from there), fed identically to every method; the methods alternate run by run and the
// figures are medians over --runs. Every output is certified by our own CheckPaths. OMPL's
// pipeline runs twice: on our certified checker (the same motions a merge accepts) and as OMPL
// ships it (its DiscreteMotionValidator, no certificate), which is the time users compare with.
// Writes results.json, results.md and results.svg to --out. Never asserts: see README.md.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <iterator>
#include <map>
#include <memory>
#include <mutex>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "core/adapter/path_io.h"
#include "core/adapter/scene_proto.h"
#include "core/collision/collision_world.h"
#include "core/common/error.h"
#include "core/merge/merge.h"
#include "core/merge/path_check.h"
#include "core/motion/local_planner.h"
#include "core/plan/baselines.h"
#include "core/plan/plan.h"

namespace hgraph {
namespace {

namespace fs = std::filesystem;

// Counts the edge checks the methods ask for (OMPL's motion validator, the H-Graph's local
// planner runs) on top of the wrapped checker's query totals. Thread safe as the wrapped one.
class CountingChecker final : public ClearanceChecker {
 public:
  explicit CountingChecker(const ClearanceChecker& inner) : inner_(inner) {}
  const Space& space() const override { return inner_.space(); }
  EdgeReport CheckEdge(const EdgeCheckRequest& request) const override {
    edges_.fetch_add(1, std::memory_order_relaxed);
    return inner_.CheckEdge(request);
  }
  bool IsValid(const Config& q) const override { return inner_.IsValid(q); }
  double Clearance(const Config& q) const override { return inner_.Clearance(q); }
  double ClearanceAndWitness(const Config& q, ClearanceWitness* witness) const override {
    return inner_.ClearanceAndWitness(q, witness);
  }
  void LowerToWitnesses(const Config& from, const Config& to,
                        const std::vector<ClearanceWitness>& witnesses,
                        std::vector<ClearanceSample>* points) const override {
    inner_.LowerToWitnesses(from, to, witnesses, points);
  }
  double MotionBound(const Config& a, const Config& b) const override {
    return inner_.MotionBound(a, b);
  }
  std::vector<ClearanceSample> ProbeClearance(
      const Config& from, const Config& to, const std::vector<double>& fractions,
      const std::vector<ClearanceSample>& known, ProbeOrder order,
      std::vector<ClearanceWitness>* witnesses = nullptr) const override {
    return inner_.ProbeClearance(from, to, fractions, known, order, witnesses);
  }
  int ProfileStretches(double length) const override { return inner_.ProfileStretches(length); }
  int64_t total_collision_checks() const override { return inner_.total_collision_checks(); }
  int64_t total_distance_queries() const override { return inner_.total_distance_queries(); }
  int64_t edges() const { return edges_.load(); }

 private:
  const ClearanceChecker& inner_;
  mutable std::atomic<int64_t> edges_{0};
};

struct Problem {
  std::string name;
  std::string file;
  std::shared_ptr<const Scene> scene;
  std::shared_ptr<const CollisionWorld> world;
  // Exact clearances (the defaults), and with the scene's clearance bound where it gets one.
  std::unique_ptr<LocalPlanner> planner;
  std::unique_ptr<LocalPlanner> bound_planner;
  // Planners whose certificates take FCL's early-stopped distance (certificate_rel_err).
  std::map<double, std::unique_ptr<LocalPlanner>> rel_planners;
  // Certificates on unbounded exact distances (certificate_threshold off).
  std::unique_ptr<LocalPlanner> unbounded_planner;
  // Every distance query started afresh (warm_start off).
  std::unique_ptr<LocalPlanner> cold_planner;
  // Certificates by two-sided advancement on clearances alone (direction_bound off).
  std::unique_ptr<LocalPlanner> classic_planner;
  double resolution = 0.01;
  std::vector<InputPath> inputs;
  std::vector<double> input_lengths;
  int best_input = 0;
  // The whole engine budget of Method::equal_time, in ms: OMPL as shipped's median time on this
  // problem in the same run (set once the other methods have run).
  double equal_time_ms = 0;
};

// What one method returns: its path, and the engine's own figures where it has them.
struct Output {
  InputPath path;
  double objective = NAN;         // the method's own objective (hgraph), NaN otherwise
  double hgraph_objective = NAN;  // H-Graph optimum before post-optimization, when reported
  int64_t search_rounds = -1;
  int64_t engine_edges_checked = -1;
  // The post-optimization's shortcuts: motions checked, and accepted (hgraph; -1 otherwise).
  int64_t shortcut_checks = -1;
  int64_t shortcuts = -1;
};

// The relative errors of FCL's early-stopped distance the bench compares with exact certificates.
constexpr double kCertificateRelErrs[] = {0.1, 0.25, 0.5};

struct Method {
  std::string name;
  std::string label;             // for tables and the chart
  bool ompl = false;             // counts towards "best certified OMPL"
  bool clearance_bound = false;  // runs on Problem::bound_planner
  double rel_err = 0;            // > 0: runs on Problem::rel_planners[rel_err]
  bool unbounded = false;        // runs on Problem::unbounded_planner
  bool cold = false;             // runs on Problem::cold_planner
  bool classic = false;          // runs on Problem::classic_planner
  // Runs after the others, given Problem::equal_time_ms as its whole engine budget.
  bool equal_time = false;
  // OMPL's pipeline as OMPL ships it (its DiscreteMotionValidator): the name of the certified
  // OMPL method that runs the same pipeline on our checker; empty for every other method.
  std::string shipped_twin;
  std::function<Output(const ClearanceChecker&, const Problem&)> run;
};

struct Run {
  bool ok = false;
  std::string error;
  double ms = 0;
  double length = NAN;
  double objective = NAN;
  double hgraph_objective = NAN;
  double min_clearance = NAN;
  double inverse_clearance = NAN;
  bool valid = false;
  bool certified = false;
  int64_t collision_checks = 0;
  int64_t distance_queries = 0;
  int64_t edges_checked = -1;  // -1: not counted
  int64_t search_rounds = -1;  // -1: not a merge
  int64_t certify_checks = 0;  // collision checks + distance queries to certify the output alone
  double checks_per_shortcut = NAN;  // shortcut motions checked per shortcut accepted
};

// A count that was not taken (-1) is NaN: "-" in tables, null in JSON.
double Count(int64_t n) { return n < 0 ? NAN : static_cast<double>(n); }

double Median(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

struct Summary {
  std::string method;
  std::string label;
  bool ompl = false;
  std::string shipped_twin;
  int runs_ok = 0;
  std::string error;
  bool certified = false;     // every run certified
  int runs_in_collision = 0;  // runs whose output CheckPaths found in collision
  double ms = NAN, length = NAN, objective = NAN, hgraph_objective = NAN, min_clearance = NAN,
         inverse_clearance = NAN, collision_checks = NAN, distance_queries = NAN,
         edges_checked = NAN, search_rounds = NAN, certify_checks = NAN, limit_ratio = NAN,
         checks_per_shortcut = NAN;
};

// Each figure of a Summary: the median over the runs of what it reads from a run.
struct SummaryFigure {
  double Summary::*median;
  double (*of)(const Run&);
};
const SummaryFigure kSummaryFigures[] = {
    {&Summary::ms, [](const Run& r) { return r.ms; }},
    {&Summary::length, [](const Run& r) { return r.length; }},
    {&Summary::objective, [](const Run& r) { return r.objective; }},
    {&Summary::hgraph_objective, [](const Run& r) { return r.hgraph_objective; }},
    {&Summary::min_clearance, [](const Run& r) { return r.min_clearance; }},
    {&Summary::inverse_clearance, [](const Run& r) { return r.inverse_clearance; }},
    {&Summary::collision_checks,
     [](const Run& r) { return static_cast<double>(r.collision_checks); }},
    {&Summary::distance_queries,
     [](const Run& r) { return static_cast<double>(r.distance_queries); }},
    {&Summary::edges_checked, [](const Run& r) { return Count(r.edges_checked); }},
    {&Summary::search_rounds, [](const Run& r) { return Count(r.search_rounds); }},
    {&Summary::certify_checks, [](const Run& r) { return static_cast<double>(r.certify_checks); }},
    {&Summary::checks_per_shortcut, [](const Run& r) { return r.checks_per_shortcut; }},
    {&Summary::limit_ratio,
     [](const Run& r) {
       return static_cast<double>(r.collision_checks + r.distance_queries) /
              static_cast<double>(std::max<int64_t>(1, r.certify_checks));
     }},
};

Summary Summarize(const Method& m, const std::vector<Run>& runs) {
  Summary s{.method = m.name, .label = m.label, .ompl = m.ompl, .shipped_twin = m.shipped_twin};
  std::vector<std::vector<double>> values(std::size(kSummaryFigures));
  s.certified = !runs.empty();
  for (const Run& r : runs) {
    if (!r.ok) {
      s.error = r.error;
      s.certified = false;
      continue;
    }
    ++s.runs_ok;
    s.certified = s.certified && r.certified;
    if (!r.valid) ++s.runs_in_collision;
    for (size_t i = 0; i < values.size(); ++i) values[i].push_back(kSummaryFigures[i].of(r));
  }
  if (s.runs_ok == 0) return s;
  for (size_t i = 0; i < values.size(); ++i) s.*kSummaryFigures[i].median = Median(values[i]);
  return s;
}

Run RunOnce(const Method& m, const Problem& p, double k) {
  Run r;
  const LocalPlanner& planner = m.clearance_bound ? *p.bound_planner
                                : m.rel_err > 0   ? *p.rel_planners.at(m.rel_err)
                                : m.unbounded     ? *p.unbounded_planner
                                : m.cold          ? *p.cold_planner
                                : m.classic       ? *p.classic_planner
                                                  : *p.planner;
  CountingChecker counter(planner);
  const int64_t cc0 = planner.total_collision_checks();
  const int64_t dq0 = planner.total_distance_queries();
  Output out;
  const auto t0 = std::chrono::steady_clock::now();
  try {
    out = m.run(counter, p);
  } catch (const std::exception& e) {
    r.error = e.what();
    return r;
  }
  r.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  r.collision_checks = planner.total_collision_checks() - cc0;
  r.distance_queries = planner.total_distance_queries() - dq0;
  // The merge counts its own local-planner runs (MergeStats::edges_checked); the others are
  // counted at the checker, except OMPL's own motion validator, which never asks it for an edge.
  if (out.engine_edges_checked >= 0) {
    r.edges_checked = out.engine_edges_checked;
  } else if (m.shipped_twin.empty()) {
    r.edges_checked = counter.edges();
  }
  r.search_rounds = out.search_rounds;
  if (out.shortcuts > 0) {
    r.checks_per_shortcut =
        static_cast<double>(out.shortcut_checks) / static_cast<double>(out.shortcuts);
  }
  r.objective = out.objective;
  r.hgraph_objective = out.hgraph_objective;
  // Judged with exact clearances, whatever checker the method ran on.
  const PathCheckResult check =
      CheckPaths(*p.planner, PathCheckRequest{.paths = {out.path}, .k = k});
  const InputReport& rep = check.paths.at(0);
  r.ok = true;
  r.valid = rep.valid;
  r.certified = rep.valid && rep.certified;
  r.length = rep.quality.length;
  r.min_clearance = rep.quality.min_clearance;
  r.inverse_clearance = rep.quality.inverse_clearance;
  r.certify_checks = check.collision_checks + check.distance_queries;
  return r;
}

// hgraph_objective exists once the anytime post-optimization is merged.
template <typename R>
auto HgraphObjective(const R& result, int) -> decltype(result.hgraph_objective, double()) {
  return result.hgraph_objective;
}
template <typename R>
double HgraphObjective(const R&, long) {
  return NAN;
}

Output FromMerge(const MergeResult& result) {
  return Output{.path = result.path,
                .objective = result.objective,
                .hgraph_objective = HgraphObjective(result, 0),
                .search_rounds = result.stats.search_rounds,
                .engine_edges_checked = result.stats.edges_checked,
                .shortcut_checks = result.stats.shortcut_checks,
                .shortcuts = result.stats.shortcuts};
}

Method HgraphMethod(const std::string& name, const std::string& label, MeasureSpec measure,
                    MergeOptions options) {
  return Method{
      .name = name,
      .label = label,
      .run = [measure, options](const ClearanceChecker& checker, const Problem& p) {
        return FromMerge(Merge(
            checker, MergeRequest{.paths = p.inputs, .measure = measure, .options = options}));
      }};
}

// The defaults given a whole engine budget (build, search and post-optimization): the H-Graph is
// built and searched in full, and the post-optimization ends where the budget does (the
// server's optimize_to_deadline). Its output is the best certified path at that time.
Method EqualTimeMethod(const std::string& name = "hgraph-equal-time",
                       const std::string& label = "hgraph defaults in OMPL as shipped's time",
                       bool classic = false) {
  return Method{.name = name,
                .label = label,
                .classic = classic,
                .equal_time = true,
                .run = [](const ClearanceChecker& checker, const Problem& p) {
                  const auto until =
                      std::chrono::steady_clock::now() +
                      std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                          std::chrono::duration<double, std::milli>(p.equal_time_ms));
                  HybridizationSession session(checker, MergeRequest{.paths = p.inputs});
                  return FromMerge(session.Query({}, {}, {}, std::nullopt, until));
                }};
}

// The defaults' anytime curve: the certified length of the best path so far against the time
// since the merge started, from the post-optimization's progress (its first point is the
// H-Graph's optimum; each later one an improvement), and the end.
std::vector<std::pair<double, double>> AnytimeCurve(const Problem& p) {
  std::vector<std::pair<double, double>> curve;
  std::mutex mutex;
  const auto t0 = std::chrono::steady_clock::now();
  const auto since = [&] {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  };
  const ProgressCallback progress = [&](const Progress& e) {
    if (e.phase != "optimize" || std::isnan(e.objective)) return;
    const std::lock_guard lock(mutex);
    curve.emplace_back(since(), e.objective);
  };
  const MergeResult r = Merge(*p.planner, MergeRequest{.paths = p.inputs, .progress = progress});
  curve.emplace_back(since(), r.objective);
  return curve;
}

std::vector<Method> Methods(const Problem& p, bool inverse_clearance_pair, uint64_t seed) {
  std::vector<Method> m;
  m.push_back(HgraphMethod("hgraph-defaults", "hgraph defaults", {}, {}));
  // The defaults with every motion checked at its samples only (`--check sampled`), as OMPL as
  // shipped checks them: the comparison with it on equal footing. Its output is judged by
  // CheckPaths like every other (certified, not certified, or in collision).
  m.push_back(HgraphMethod("hgraph-sampled", "hgraph --check sampled", {},
                           MergeOptions{.check_mode = CheckMode::kSampled}));
  // The defaults with certificates on clearances alone (two-sided advancement,
  // LocalPlannerOptions::direction_bound off): what advancement along the separating directions
  // gains. The next four change what these certificates cost, and run with it off too.
  Method classic = HgraphMethod("hgraph-classic-advancement",
                                "hgraph defaults, certificates on clearances alone", {}, {});
  classic.classic = true;
  m.push_back(std::move(classic));
  // The same on a checker with the scene's clearance bound (`hgraph-server
  // --clearance-bound`): what the bound gains and costs.
  Method bounded = HgraphMethod("hgraph-clearance-bound",
                                "certificates on clearances + --clearance-bound", {}, {});
  bounded.clearance_bound = true;
  m.push_back(std::move(bounded));
  // The defaults with certificates on unbounded distances: what the threshold queries gain.
  Method unbounded = HgraphMethod("hgraph-unbounded-certificates",
                                  "certificates on clearances without threshold", {}, {});
  unbounded.unbounded = true;
  m.push_back(std::move(unbounded));
  // The defaults with every distance query started afresh: what warm starts gain.
  Method cold = HgraphMethod("hgraph-cold-queries",
                             "certificates on clearances, queries without warm start", {}, {});
  cold.cold = true;
  m.push_back(std::move(cold));
  // The defaults with the post-optimization's searches profiling motions whose certificate
  // stalls, as the first search does: what refusing them gains and costs.
  m.push_back(HgraphMethod("hgraph-profiled-stalls",
                           "hgraph defaults, post-optimization profiles stalled motions", {},
                           MergeOptions{.give_up_stalled = false}));
  // Certificates on clearances, FCL's early-stopped distance: what each error gains.
  for (double rel : kCertificateRelErrs) {
    std::ostringstream name;
    name << rel;
    Method early = HgraphMethod("hgraph-rel-err-" + name.str(),
                                "certificates on clearances, rel_err " + name.str(), {}, {});
    early.rel_err = rel;
    m.push_back(std::move(early));
  }
  m.push_back(HgraphMethod("hgraph-eager-all-pairs", "hgraph eager all-pairs", {},
                           MergeOptions{.candidates = {.variant = Variant::kAllPairs},
                                        .evaluation = Evaluation::kEager}));
  m.push_back(HgraphMethod("hgraph-lazy-all-pairs", "hgraph lazy all-pairs", {},
                           MergeOptions{.candidates = {.variant = Variant::kAllPairs}}));
  m.push_back(HgraphMethod("hgraph-partial-shortcuts", "hgraph --partial-shortcuts", {},
                           MergeOptions{.partial_shortcuts = true}));
  m.push_back(HgraphMethod("hgraph-restarts-2", "hgraph --restarts 2", {},
                           MergeOptions{.optimize_restarts = 2}));
  m.push_back(HgraphMethod("hgraph-report-clearance", "hgraph --report-clearance", {},
                           MergeOptions{.report_clearance = true}));
  const double res = p.resolution;
  // OMPL's PathHybridization (matching across gaps or not) and then simplifyMax, every motion
  // checked as `check` says.
  const auto hybridize_simplify = [res, seed](bool gaps, OmplMotionCheck check) {
    return [res, seed, gaps, check](const ClearanceChecker& c, const Problem& q) {
      const InputPath h = OmplHybridize(
          c, q.inputs, {.resolution = res, .match_across_gaps = gaps, .motion_check = check});
      return Output{
          .path = SimplifyMaxPath(c, h, {.seed = seed, .resolution = res, .motion_check = check})};
    };
  };
  m.push_back(Method{.name = "ompl-hybridize-gaps+simplifymax",
                     .label = "OMPL hybridize (gaps) + simplifyMax",
                     .ompl = true,
                     .run = hybridize_simplify(true, OmplMotionCheck::kCertified)});
  m.push_back(Method{.name = "ompl-hybridize-nogaps+simplifymax",
                     .label = "OMPL hybridize (no gaps) + simplifyMax",
                     .ompl = true,
                     .run = hybridize_simplify(false, OmplMotionCheck::kCertified)});
  // The same two pipelines as OMPL ships them: its DiscreteMotionValidator at the same
  // resolution, no certificate (what OMPL users run and time); CheckPaths judges the output
  // afterwards, outside the timed part, like every method's.
  m.push_back(Method{.name = "ompl-shipped-hybridize-gaps+simplifymax",
                     .label = "OMPL as shipped: hybridize (gaps) + simplifyMax",
                     .shipped_twin = "ompl-hybridize-gaps+simplifymax",
                     .run = hybridize_simplify(true, OmplMotionCheck::kDiscrete)});
  m.push_back(Method{.name = "ompl-shipped-hybridize-nogaps+simplifymax",
                     .label = "OMPL as shipped: hybridize (no gaps) + simplifyMax",
                     .shipped_twin = "ompl-hybridize-nogaps+simplifymax",
                     .run = hybridize_simplify(false, OmplMotionCheck::kDiscrete)});
  m.push_back(Method{.name = "ompl-simplifymax-best-input",
                     .label = "OMPL simplifyMax on best input",
                     .ompl = true,
                     .run = [res, seed](const ClearanceChecker& c, const Problem& q) {
                       return Output{.path = SimplifyMaxPath(c, q.inputs.at(q.best_input),
                                                             {.seed = seed, .resolution = res})};
                     }});
  m.push_back(EqualTimeMethod());
  m.push_back(EqualTimeMethod("hgraph-equal-time-classic-advancement",
                              "hgraph, certificates on clearances alone, in OMPL as shipped's time",
                              true));
  if (inverse_clearance_pair) {
    const MeasureSpec ic{.type = MeasureType::kInverseClearance, .k = 3};
    m.push_back(HgraphMethod(
        "hgraph-ic3-lazy-all-pairs-spacing1",
        "hgraph inv. clearance k=3, lazy, all-pairs, spacing 1", ic,
        MergeOptions{.candidates = {.variant = Variant::kAllPairs}, .max_node_spacing = 1}));
    m.push_back(HgraphMethod("hgraph-ic3-eager-all-pairs-spacing1",
                             "hgraph inv. clearance k=3, eager, all-pairs, spacing 1", ic,
                             MergeOptions{.candidates = {.variant = Variant::kAllPairs},
                                          .evaluation = Evaluation::kEager,
                                          .max_node_spacing = 1}));
  }
  return m;
}

// Loads the scene and its inputs: read back from <out>/inputs/<name>.json if present, else
// planned with PRM from the scene's start to goal and written there.
Problem LoadProblem(const std::string& name, const std::string& file, const fs::path& out_dir,
                    int count, double time_s, uint64_t seed) {
  Problem p{.name = name, .file = file};
  const v1::Scene proto = ReadSceneFile(file);
  p.resolution = SceneResolution(proto);
  p.scene = SceneFromProto(proto, fs::path(file).parent_path().string(), {});
  p.world = std::make_shared<const CollisionWorld>(p.scene);
  const auto b0 = std::chrono::steady_clock::now();
  const auto bound = BuildClearanceBound(p.world);
  std::cerr << name << ": clearance bound "
            << (bound ? std::to_string(ClearanceBoundBytes(*bound)) + " bytes, built in " +
                            std::to_string(std::chrono::duration<double, std::milli>(
                                               std::chrono::steady_clock::now() - b0)
                                               .count()) +
                            " ms"
                      : std::string("none"))
            << "\n";
  p.planner =
      std::make_unique<LocalPlanner>(p.world, LocalPlannerOptions{.resolution = p.resolution});
  p.bound_planner = std::make_unique<LocalPlanner>(
      p.world, LocalPlannerOptions{
                   .resolution = p.resolution, .clearance_bound = bound, .direction_bound = false});
  p.unbounded_planner =
      std::make_unique<LocalPlanner>(p.world, LocalPlannerOptions{.resolution = p.resolution,
                                                                  .certificate_threshold = false,
                                                                  .direction_bound = false});
  p.classic_planner = std::make_unique<LocalPlanner>(
      p.world, LocalPlannerOptions{.resolution = p.resolution, .direction_bound = false});
  p.cold_planner = std::make_unique<LocalPlanner>(
      p.world, LocalPlannerOptions{
                   .resolution = p.resolution, .warm_start = false, .direction_bound = false});
  for (double rel : kCertificateRelErrs) {
    p.rel_planners[rel] =
        std::make_unique<LocalPlanner>(p.world, LocalPlannerOptions{.resolution = p.resolution,
                                                                    .certificate_rel_err = rel,
                                                                    .direction_bound = false});
  }
  const fs::path inputs_file = out_dir / "inputs" / (name + ".json");
  if (fs::exists(inputs_file)) {
    p.inputs = LoadPathsFile(inputs_file.string(), p.scene->space);
    std::cerr << name << ": " << p.inputs.size() << " inputs read from " << inputs_file << "\n";
  } else {
    if (!p.scene->start || !p.scene->goal) {
      throw InputError("scene", name + " has no start and goal");
    }
    const PlanResult plan = PlanPaths(*p.planner, PlanRequest{.planner = PlannerType::kPRM,
                                                              .start = *p.scene->start,
                                                              .goal = *p.scene->goal,
                                                              .count = count,
                                                              .time_s = time_s,
                                                              .seed = seed,
                                                              .resolution = p.resolution});
    p.inputs = plan.paths;
    if (p.inputs.empty()) throw InputError("scene", name + ": PRM found no path");
    fs::create_directories(inputs_file.parent_path());
    WritePathsFile(inputs_file.string(), p.inputs, p.scene->space);
    std::cerr << name << ": planned " << p.inputs.size() << " of " << count
              << " inputs, written to " << inputs_file << "\n";
  }
  for (size_t i = 0; i < p.inputs.size(); ++i) {
    p.input_lengths.push_back(PathLength(p.scene->space, p.inputs[i]));
    if (p.input_lengths[i] < p.input_lengths[p.best_input]) p.best_input = static_cast<int>(i);
  }
  return p;
}

std::string Num(double v, int precision = 4) {
  if (std::isnan(v)) return "null";
  if (std::isinf(v)) return v > 0 ? "1e308" : "-1e308";
  std::ostringstream s;
  s.precision(precision);
  s << v;
  return s.str();
}

std::string Cell(double v, int precision = 4) {
  if (std::isnan(v)) return "-";
  std::ostringstream s;
  s.precision(precision);
  s << v;
  return s.str();
}

std::string Quote(const std::string& s) {
  std::string o = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') o += '\\';
    if (c == '\n') {
      o += "\\n";
      continue;
    }
    o += c;
  }
  return o + "\"";
}

struct SceneResult {
  std::string name;
  int inputs = 0;
  std::vector<double> input_lengths;
  std::vector<Summary> methods;
  int best_ompl = -1;  // index into methods
  double length_ratio = NAN, time_ratio = NAN;
  // "OMPL as shipped": the shipped pipeline whose certified twin gave the shorter certified
  // output (or, without certified twins, the shipped pipeline with the shorter output).
  int shipped = -1;
  double shipped_length_ratio = NAN, shipped_time_ratio = NAN;
  // hgraph --check sampled against OMPL as shipped: both check samples only.
  int sampled = -1;
  double sampled_length_ratio = NAN, sampled_time_ratio = NAN;
  // hgraph in OMPL as shipped's time against the best certified OMPL pipeline.
  int equal_time = -1;
  double equal_time_budget_ms = NAN, equal_time_length_ratio = NAN;
  // The defaults' anytime curve (AnytimeCurve): ms since the start, certified length.
  std::vector<std::pair<double, double>> anytime;
};

int FindMethod(const SceneResult& s, const std::string& name) {
  for (size_t i = 0; i < s.methods.size(); ++i) {
    if (s.methods[i].method == name) return static_cast<int>(i);
  }
  return -1;
}

void Compare(SceneResult* s) {
  for (size_t i = 0; i < s->methods.size(); ++i) {
    const Summary& m = s->methods[i];
    if (!m.ompl || !m.certified) continue;
    if (s->best_ompl < 0 || m.length < s->methods[s->best_ompl].length)
      s->best_ompl = static_cast<int>(i);
  }
  // The shipped pipeline whose certified twin is shortest; without one, the shortest shipped.
  for (const bool by_twin : {true, false}) {
    double shortest = INFINITY;
    for (size_t i = 0; i < s->methods.size(); ++i) {
      const Summary& m = s->methods[i];
      if (m.shipped_twin.empty() || m.runs_ok == 0) continue;
      const int twin = FindMethod(*s, m.shipped_twin);
      if (by_twin && (twin < 0 || !s->methods[twin].certified)) continue;
      const double length = by_twin ? s->methods[twin].length : m.length;
      if (length < shortest) {
        shortest = length;
        s->shipped = static_cast<int>(i);
      }
    }
    if (s->shipped >= 0) break;
  }
  const Summary& defaults = s->methods[0];
  if (defaults.runs_ok == 0) return;
  if (s->best_ompl >= 0) {
    s->length_ratio = defaults.length / s->methods[s->best_ompl].length;
    s->time_ratio = defaults.ms / s->methods[s->best_ompl].ms;
  }
  if (s->shipped >= 0) {
    s->shipped_length_ratio = defaults.length / s->methods[s->shipped].length;
    s->shipped_time_ratio = defaults.ms / s->methods[s->shipped].ms;
  }
  s->sampled = FindMethod(*s, "hgraph-sampled");
  if (s->sampled >= 0 && s->shipped >= 0 && s->methods[s->sampled].runs_ok > 0) {
    s->sampled_length_ratio = s->methods[s->sampled].length / s->methods[s->shipped].length;
    s->sampled_time_ratio = s->methods[s->sampled].ms / s->methods[s->shipped].ms;
  }
  s->equal_time = FindMethod(*s, "hgraph-equal-time");
  if (s->equal_time >= 0 && s->best_ompl >= 0 && s->methods[s->equal_time].runs_ok > 0) {
    s->equal_time_length_ratio = s->methods[s->equal_time].length / s->methods[s->best_ompl].length;
  }
}

std::string Json(const std::vector<SceneResult>& scenes, const std::string& command, int runs) {
  std::ostringstream o;
  o << "{\n  \"command\": " << Quote(command) << ",\n  \"runs\": " << runs << ",\n  \"scenes\": [";
  for (size_t si = 0; si < scenes.size(); ++si) {
    const SceneResult& s = scenes[si];
    o << (si ? "," : "") << "\n    {\"name\": " << Quote(s.name) << ", \"inputs\": " << s.inputs
      << ", \"input_lengths\": [";
    for (size_t i = 0; i < s.input_lengths.size(); ++i) {
      o << (i ? ", " : "") << Num(s.input_lengths[i], 8);
    }
    o << "],\n     \"best_certified_ompl\": "
      << (s.best_ompl >= 0 ? Quote(s.methods[s.best_ompl].method) : "null")
      << ", \"defaults_length_ratio\": " << Num(s.length_ratio, 6)
      << ", \"defaults_time_ratio\": " << Num(s.time_ratio, 6) << ",\n     \"ompl_as_shipped\": "
      << (s.shipped >= 0 ? Quote(s.methods[s.shipped].method) : "null")
      << ", \"defaults_vs_shipped_length_ratio\": " << Num(s.shipped_length_ratio, 6)
      << ", \"defaults_vs_shipped_time_ratio\": " << Num(s.shipped_time_ratio, 6)
      << ", \"sampled_vs_shipped_length_ratio\": " << Num(s.sampled_length_ratio, 6)
      << ", \"sampled_vs_shipped_time_ratio\": " << Num(s.sampled_time_ratio, 6)
      << ",\n     \"equal_time_budget_ms\": " << Num(s.equal_time_budget_ms, 6)
      << ", \"equal_time_vs_best_certified_length_ratio\": " << Num(s.equal_time_length_ratio, 6)
      << ", \"anytime\": [";
    for (size_t i = 0; i < s.anytime.size(); ++i) {
      o << (i ? ", " : "") << "[" << Num(s.anytime[i].first, 6) << ", "
        << Num(s.anytime[i].second, 8) << "]";
    }
    o << "]"
      << ",\n     \"methods\": [";
    for (size_t i = 0; i < s.methods.size(); ++i) {
      const Summary& m = s.methods[i];
      o << (i ? "," : "") << "\n       {\"method\": " << Quote(m.method)
        << ", \"runs_ok\": " << m.runs_ok << ", \"error\": " << Quote(m.error)
        << ", \"certified\": " << (m.certified ? "true" : "false")
        << ", \"runs_in_collision\": " << m.runs_in_collision
        << ", \"length\": " << Num(m.length, 8) << ", \"objective\": " << Num(m.objective, 8)
        << ", \"hgraph_objective\": " << Num(m.hgraph_objective, 8)
        << ", \"min_clearance\": " << Num(m.min_clearance, 6)
        << ", \"inverse_clearance_k3\": " << Num(m.inverse_clearance, 8)
        << ", \"ms\": " << Num(m.ms, 6) << ", \"collision_checks\": " << Num(m.collision_checks, 12)
        << ", \"distance_queries\": " << Num(m.distance_queries, 12)
        << ", \"edges_checked\": " << Num(m.edges_checked, 12)
        << ", \"search_rounds\": " << Num(m.search_rounds, 12)
        << ", \"certify_output_checks\": " << Num(m.certify_checks, 12)
        << ", \"physical_limit_ratio\": " << Num(m.limit_ratio, 6)
        << ", \"shortcut_checks_per_accepted\": " << Num(m.checks_per_shortcut, 6) << "}";
    }
    o << "]}";
  }
  o << "\n  ]\n}\n";
  return o.str();
}

// "yes", "no", or "no, in collision in k of n runs".
std::string Certified(const Summary& m) {
  if (m.certified) return "yes";
  if (m.runs_in_collision == 0) return "no";
  return "no, in collision in " + std::to_string(m.runs_in_collision) + " of " +
         std::to_string(m.runs_ok) + " runs";
}

// The headline: hgraph defaults against OMPL as shipped (the price users compare) and against
// the best certified OMPL pipeline (the same checker for both), per scene and at the median.
void Headline(const std::vector<SceneResult>& scenes, std::ostringstream& o) {
  o << "| scene | hgraph defaults ms | OMPL as shipped ms | **defaults / shipped time** | best "
       "certified OMPL ms | defaults / best cert. time | defaults length | shipped length "
       "(cert.) | best cert. OMPL length | **defaults / shipped length** | defaults / best "
       "cert. length |\n|---|---|---|---|---|---|---|---|---|---|---|\n";
  std::vector<double> shipped_time, shipped_length, best_time, best_length;
  for (const SceneResult& s : scenes) {
    const Summary& d = s.methods[0];
    const Summary* shipped = s.shipped >= 0 ? &s.methods[s.shipped] : nullptr;
    const Summary* best = s.best_ompl >= 0 ? &s.methods[s.best_ompl] : nullptr;
    o << "| " << s.name << " | " << Cell(d.ms, 4) << " | " << (shipped ? Cell(shipped->ms, 4) : "-")
      << " | **" << Cell(s.shipped_time_ratio, 3) << "** | " << (best ? Cell(best->ms, 4) : "-")
      << " | " << Cell(s.time_ratio, 3) << " | " << Cell(d.length, 5) << " | "
      << (shipped ? Cell(shipped->length, 5) + " (" + Certified(*shipped) + ")" : "-") << " | "
      << (best ? Cell(best->length, 5) : "-") << " | **" << Cell(s.shipped_length_ratio, 4)
      << "** | " << Cell(s.length_ratio, 4) << " |\n";
    for (auto [value, into] :
         {std::pair{s.shipped_time_ratio, &shipped_time},
          std::pair{s.shipped_length_ratio, &shipped_length}, std::pair{s.time_ratio, &best_time},
          std::pair{s.length_ratio, &best_length}}) {
      if (!std::isnan(value)) into->push_back(value);
    }
  }
  o << "| median | | | **" << Cell(Median(shipped_time), 3) << "** | | "
    << Cell(Median(best_time), 3) << " | | | | **" << Cell(Median(shipped_length), 4) << "** | "
    << Cell(Median(best_length), 4) << " |\n\n";
  // Like for like: hgraph with samples only (--check sampled) against OMPL as shipped.
  if (std::none_of(scenes.begin(), scenes.end(),
                   [](const SceneResult& s) { return s.sampled >= 0; })) {
    return;
  }
  o << "| scene | hgraph --check sampled ms | OMPL as shipped ms | **sampled / shipped time** | "
       "sampled length (cert.) | shipped length (cert.) | **sampled / shipped length** "
       "|\n|---|---|---|---|---|---|---|\n";
  std::vector<double> sampled_time, sampled_length;
  for (const SceneResult& s : scenes) {
    if (s.sampled < 0) continue;
    const Summary& m = s.methods[s.sampled];
    const Summary* shipped = s.shipped >= 0 ? &s.methods[s.shipped] : nullptr;
    o << "| " << s.name << " | " << Cell(m.ms, 4) << " | " << (shipped ? Cell(shipped->ms, 4) : "-")
      << " | **" << Cell(s.sampled_time_ratio, 3) << "** | " << Cell(m.length, 5) << " ("
      << Certified(m) << ") | "
      << (shipped ? Cell(shipped->length, 5) + " (" + Certified(*shipped) + ")" : "-") << " | **"
      << Cell(s.sampled_length_ratio, 4) << "** |\n";
    if (!std::isnan(s.sampled_time_ratio)) sampled_time.push_back(s.sampled_time_ratio);
    if (!std::isnan(s.sampled_length_ratio)) sampled_length.push_back(s.sampled_length_ratio);
  }
  o << "| median | | | **" << Cell(Median(sampled_time), 3) << "** | | | **"
    << Cell(Median(sampled_length), 4) << "** |\n\n";
}

// hgraph given OMPL as shipped's time as its whole engine budget, against the best certified OMPL
// pipeline's output (the paper's claim at equal time).
void EqualTime(const std::vector<SceneResult>& scenes, std::ostringstream& o) {
  if (std::none_of(scenes.begin(), scenes.end(),
                   [](const SceneResult& s) { return s.equal_time >= 0; })) {
    return;
  }
  o << "| scene | budget = OMPL as shipped ms | hgraph in that budget: ms | length (cert.) | best "
       "cert. OMPL length (ms) | **equal-time / best cert. length** | defaults length |\n"
       "|---|---|---|---|---|---|---|\n";
  std::vector<double> ratios;
  for (const SceneResult& s : scenes) {
    if (s.equal_time < 0) continue;
    const Summary& m = s.methods[s.equal_time];
    const Summary* best = s.best_ompl >= 0 ? &s.methods[s.best_ompl] : nullptr;
    o << "| " << s.name << " | " << Cell(s.equal_time_budget_ms, 4) << " | " << Cell(m.ms, 4)
      << " | " << Cell(m.length, 5) << " (" << Certified(m) << ") | "
      << (best ? Cell(best->length, 5) + " (" + Cell(best->ms, 4) + ")" : "-") << " | **"
      << Cell(s.equal_time_length_ratio, 4) << "** | " << Cell(s.methods[0].length, 5) << " |\n";
    if (!std::isnan(s.equal_time_length_ratio)) ratios.push_back(s.equal_time_length_ratio);
  }
  o << "| median | | | | | **" << Cell(Median(ratios), 4) << "** | |\n\n";
}

std::string Markdown(const std::vector<SceneResult>& scenes, const std::string& command, int runs) {
  std::ostringstream o;
  o << "Medians of " << runs << " interleaved runs. `" << command << "`\n\n"
    << "Length and clearance of each output are from our certified CheckPaths; *cert.* = every "
       "run's output certified. *checks* = collision checks + distance queries; *limit* = checks "
       "/ checks to certify the output path alone. hgraph runs on all cores, OMPL on one. *OMPL "
       "as shipped*: OMPL's hybridize + simplifyMax with its own DiscreteMotionValidator at the "
       "same resolution (states at the resolution's steps only), timed without any "
       "certification, its output judged by CheckPaths afterwards; of its two rows, the one whose "
       "certified twin is shorter (*headline*). Its edges are not counted (OMPL's validator "
       "never asks our checker for one).\n\n";
  Headline(scenes, o);
  EqualTime(scenes, o);
  for (const SceneResult& s : scenes) {
    o << "**" << s.name << "** (" << s.inputs << " PRM inputs, best input length "
      << Cell(*std::min_element(s.input_lengths.begin(), s.input_lengths.end())) << "): defaults / "
      << "OMPL as shipped = " << Cell(s.shipped_length_ratio, 4) << " in length, "
      << Cell(s.shipped_time_ratio, 3)
      << " in time; defaults / best certified OMPL = " << Cell(s.length_ratio, 4) << " in length, "
      << Cell(s.time_ratio, 3) << " in time\n\n"
      << "| method | length | objective | min cl. | cert. | ms | coll. checks | dist. queries | "
         "edges | rounds | limit | shortcut checks / accepted |\n"
         "|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (size_t i = 0; i < s.methods.size(); ++i) {
      const Summary& m = s.methods[i];
      if (m.runs_ok == 0) {
        o << "| " << m.label << " | failed: " << m.error << " ||||||||||\n";
        continue;
      }
      const int index = static_cast<int>(i);
      o << "| " << m.label << (index == s.best_ompl ? " (best OMPL)" : "")
        << (index == s.shipped ? " (headline)" : "") << " | " << Cell(m.length, 5) << " | "
        << Cell(m.objective, 5) << " | " << Cell(m.min_clearance, 3) << " | " << Certified(m)
        << " | " << Cell(m.ms, 4) << " | " << Cell(m.collision_checks, 8) << " | "
        << Cell(m.distance_queries, 8) << " | " << Cell(m.edges_checked, 8) << " | "
        << Cell(m.search_rounds, 8) << " | " << Cell(m.limit_ratio, 3) << " | "
        << Cell(m.checks_per_shortcut, 3) << " |\n";
    }
    o << "\n";
  }
  return o.str();
}

// The defaults' anytime curves, one plot per scene below its bars: certified length relative to
// the best certified OMPL pipeline against ms since the start (a step per improvement), with OMPL
// as shipped (hollow if not certified), the best certified OMPL pipeline and the equal-time
// method as points.
void AnytimePanel(const std::vector<SceneResult>& scenes, double left, double group_w, double y0,
                  double h, std::ostringstream& o) {
  o << "<text x=\"5\" y=\"" << y0 + 12
    << "\" font-size=\"12\">anytime: length / best cert. OMPL against ms (blue: hgraph "
       "defaults; orange: OMPL as shipped; black: best cert. OMPL; green: hgraph in shipped's "
       "time)</text>\n";
  for (size_t si = 0; si < scenes.size(); ++si) {
    const SceneResult& s = scenes[si];
    if (s.anytime.empty() || s.best_ompl < 0) continue;
    const Summary& ref = s.methods[s.best_ompl];
    const Summary* shipped = s.shipped >= 0 ? &s.methods[s.shipped] : nullptr;
    const Summary* equal = s.equal_time >= 0 ? &s.methods[s.equal_time] : nullptr;
    double x_max = std::max(s.anytime.back().first, ref.ms);
    double lo = 1, hi = 1;
    for (const auto& [ms, length] : s.anytime) {
      lo = std::min(lo, length / ref.length);
      hi = std::max(hi, length / ref.length);
    }
    for (const Summary* m : {shipped, equal}) {
      if (m == nullptr || m->runs_ok == 0) continue;
      x_max = std::max(x_max, m->ms);
      lo = std::min(lo, m->length / ref.length);
      hi = std::max(hi, m->length / ref.length);
    }
    x_max *= 1.05;
    lo -= 0.02;
    hi += 0.02;
    const double px = left + group_w * si + 20, pw = group_w - 40, py = y0 + 25, ph = h - 25;
    const auto X = [&](double ms) { return px + pw * ms / x_max; };
    const auto Y = [&](double ratio) { return py + ph * (hi - ratio) / (hi - lo); };
    o << "<rect x=\"" << px << "\" y=\"" << py << "\" width=\"" << pw << "\" height=\"" << ph
      << "\" fill=\"none\" stroke=\"#999\"/>\n<line x1=\"" << px << "\" x2=\"" << px + pw
      << "\" y1=\"" << Y(1) << "\" y2=\"" << Y(1) << "\" stroke=\"#ccc\"/>\n<text x=\"" << px
      << "\" y=\"" << py + ph + 14 << "\">0</text><text x=\"" << px + pw << "\" y=\""
      << py + ph + 14 << "\" text-anchor=\"end\">" << Cell(x_max, 3) << " ms</text>\n<text x=\""
      << px - 3 << "\" y=\"" << py + 8 << "\" text-anchor=\"end\">" << Cell(hi, 3)
      << "</text><text x=\"" << px - 3 << "\" y=\"" << py + ph << "\" text-anchor=\"end\">"
      << Cell(lo, 3) << "</text>\n<polyline fill=\"none\" stroke=\"#1f77b4\" points=\"";
    for (size_t i = 0; i < s.anytime.size(); ++i) {
      const double y = Y(s.anytime[i].second / ref.length);
      if (i > 0)
        o << X(s.anytime[i].first) << "," << Y(s.anytime[i - 1].second / ref.length) << " ";
      o << X(s.anytime[i].first) << "," << y << " ";
    }
    o << "\"/>\n";
    const auto point = [&](const Summary* m, const char* color, bool filled) {
      if (m == nullptr || m->runs_ok == 0) return;
      o << "<circle cx=\"" << X(m->ms) << "\" cy=\"" << Y(m->length / ref.length)
        << "\" r=\"4\" stroke=\"" << color << "\" fill=\"" << (filled ? color : "white")
        << "\"><title>" << m->label << ": " << Cell(m->ms, 4) << " ms, "
        << Cell(m->length / ref.length, 4) << "</title></circle>\n";
    };
    point(&ref, "black", true);
    point(shipped, "#ff7f0e", shipped != nullptr && shipped->certified);
    point(equal, "#2ca02c", equal != nullptr && equal->certified);
  }
}

// Two panels, one group of bars per scene: each length-method's length and time relative to the
// best certified OMPL pipeline (1 = equal), on a log2 scale around 1.
std::string Svg(const std::vector<SceneResult>& scenes) {
  const std::vector<std::string> colors = {"#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd",
                                           "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf",
                                           "#aec7e8", "#ffbb78", "#98df8a"};
  // The length methods; the inverse-clearance pair is not compared.
  const int kMethods = static_cast<int>(colors.size());
  const double bar_w = 20, group_w = bar_w * kMethods + 20, left = 60, panel_h = 220, top = 40,
               legend_h = 18 * kMethods + 30;
  const double width = left + group_w * scenes.size() + 20;
  const bool curves = std::any_of(scenes.begin(), scenes.end(),
                                  [](const SceneResult& s) { return !s.anytime.empty(); });
  const double curve_h = curves ? 200 : 0, curve_top = top + 2 * (panel_h + 40);
  const double height = top + 2 * (panel_h + 40) + (curves ? curve_h + 60 : 0) + legend_h;
  std::ostringstream o;
  o << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << width << "\" height=\"" << height
    << "\" font-family=\"sans-serif\" font-size=\"11\">\n<rect width=\"100%\" height=\"100%\" "
       "fill=\"white\"/>\n";
  o << "<text x=\"" << left
    << "\" y=\"20\" font-size=\"14\">Relative to the best certified OMPL "
       "pipeline per scene (log2 scale; below the line = better)</text>\n";
  for (int panel = 0; panel < 2; ++panel) {
    const double y0 = top + panel * (panel_h + 40);
    const double mid = y0 + panel_h / 2;
    const double range = panel == 0 ? 0.5 : 4.0;  // log2 half-range
    o << "<text x=\"5\" y=\"" << y0 + 12 << "\" font-size=\"12\">"
      << (panel == 0 ? "length ratio" : "time ratio") << "</text>\n";
    for (double e : {-range, -range / 2, 0.0, range / 2, range}) {
      const double y = mid - e / range * (panel_h / 2);
      o << "<line x1=\"" << left << "\" x2=\"" << width - 10 << "\" y1=\"" << y << "\" y2=\"" << y
        << "\" stroke=\"" << (e == 0 ? "black" : "#ddd") << "\"/>\n<text x=\"" << left - 5
        << "\" y=\"" << y + 4 << "\" text-anchor=\"end\">" << Cell(std::exp2(e), 3) << "</text>\n";
    }
    for (size_t si = 0; si < scenes.size(); ++si) {
      const SceneResult& s = scenes[si];
      const double gx = left + group_w * si + 10;
      if (panel == 1) {
        o << "<text x=\"" << gx + group_w / 2 - 10 << "\" y=\"" << y0 + panel_h + 15
          << "\" text-anchor=\"middle\">" << s.name << "</text>\n";
      }
      if (s.best_ompl < 0) continue;
      const Summary& ref = s.methods[s.best_ompl];
      for (int i = 0; i < kMethods && i < static_cast<int>(s.methods.size()); ++i) {
        const Summary& m = s.methods[i];
        if (m.runs_ok == 0) continue;
        const double ratio = panel == 0 ? m.length / ref.length : m.ms / ref.ms;
        const double e = std::clamp(std::log2(ratio), -range, range);
        const double y = mid - e / range * (panel_h / 2);
        o << "<rect x=\"" << gx + i * bar_w << "\" y=\"" << std::min(y, mid) << "\" width=\""
          << bar_w - 2 << "\" height=\"" << std::max(1.0, std::abs(y - mid)) << "\" fill=\""
          << colors[i] << "\"" << (m.certified ? "" : " fill-opacity=\"0.35\"") << "><title>"
          << m.label << ": " << Cell(ratio, 4) << "</title></rect>\n";
      }
    }
  }
  if (curves) AnytimePanel(scenes, left, group_w, curve_top, curve_h, o);
  if (!scenes.empty()) {
    const double ly = top + 2 * (panel_h + 40) + (curves ? curve_h + 60 : 0) + 10;
    for (int i = 0; i < kMethods && i < static_cast<int>(scenes[0].methods.size()); ++i) {
      o << "<rect x=\"" << left << "\" y=\"" << ly + 18 * i << "\" width=\"12\" height=\"12\" "
        << "fill=\"" << colors[i] << "\"/><text x=\"" << left + 18 << "\" y=\"" << ly + 18 * i + 10
        << "\">" << scenes[0].methods[i].label << "</text>\n";
    }
    o << "<text x=\"" << left << "\" y=\"" << ly + 18 * kMethods + 10
      << "\">pale bar: output not certified in every run</text>\n";
  }
  o << "</svg>\n";
  return o.str();
}

void WriteFile(const fs::path& path, const std::string& text) {
  std::ofstream f(path);
  f << text;
  if (!f) throw Error(ErrorCode::kNotFound, "out", "cannot write " + path.string());
}

int Main(int argc, char** argv) {
  CLI::App app{"hgraph against OMPL's hybridize + simplifyMax pipeline, side by side"};
  std::vector<std::string> scene_names = {"grid",          "maze",        "circles",   "wrench",
                                          "double_wrench", "wall_planar", "hole_wall", "two_slots"};
  std::vector<std::string> ic_scenes = {"wrench"};
  int runs = 5;
  int count = 4;
  double plan_time_s = 5;
  uint64_t seed = 1;
  std::string out = "bench-out";
  app.add_option("--scenes", scene_names,
                 "scene names (built-in, wall_planar, or a folder of tests/bench/scenes: "
                 "hole_wall, two_slots, home, office, twisty, car_maze) or scene files");
  app.add_option("--runs", runs, "repetitions per method (medians)")->check(CLI::PositiveNumber);
  app.add_option("--inputs", count, "PRM input paths per scene")->check(CLI::Range(1, 20));
  app.add_option("--plan-time", plan_time_s, "PRM budget per input path, seconds");
  app.add_option("--seed", seed, "PRM and simplifier seed");
  app.add_option("--out", out, "output folder (inputs are cached in <out>/inputs)");
  std::vector<std::string> only_methods;
  app.add_option("--methods", only_methods, "run only these methods (names as in results.json)");
  app.add_option("--inverse-clearance-scenes", ic_scenes,
                 "scenes that also run inverse clearance k=3, all-pairs, node spacing 1, lazy "
                 "and eager");
  CLI11_PARSE(app, argc, argv);

  std::string command = "build/hgraph-bench --runs " + std::to_string(runs) + " --seed " +
                        std::to_string(seed) + " --out " + out + " --scenes";
  for (const auto& s : scene_names) command += " " + s;
  command += " --inverse-clearance-scenes";
  for (const auto& s : ic_scenes) command += " " + s;
  if (!only_methods.empty()) command += " --methods";
  for (const auto& s : only_methods) command += " " + s;

  const fs::path source(HGRAPH_SOURCE_DIR);
  const fs::path out_dir(out);
  fs::create_directories(out_dir);
  std::vector<SceneResult> results;
  for (const std::string& name : scene_names) {
    fs::path file;
    if (fs::exists(name)) {
      file = name;
    } else if (name == "wall_planar") {
      file = source / "tests/data/ompl_app/wall_planar.cfg";
    } else if (fs::exists(source / "tests/bench/scenes" / name / "scene.json")) {
      file = source / "tests/bench/scenes" / name / "scene.json";
    } else {
      file = source / "scenes" / name / "scene.json";
    }
    const std::string short_name = fs::path(name).stem() == "scene"
                                       ? fs::path(name).parent_path().filename().string()
                                       : fs::path(name).stem().string();
    Problem p = LoadProblem(short_name, file.string(), out_dir, count, plan_time_s, seed);
    const bool ic = std::find(ic_scenes.begin(), ic_scenes.end(), short_name) != ic_scenes.end();
    std::vector<Method> methods = Methods(p, ic, seed);
    if (!only_methods.empty()) {
      std::erase_if(methods, [&](const Method& m) {
        return std::find(only_methods.begin(), only_methods.end(), m.name) == only_methods.end();
      });
    }
    // The equal-time methods last: their budget is what the others measured.
    std::stable_partition(methods.begin(), methods.end(),
                          [](const Method& m) { return !m.equal_time; });
    const size_t timed = static_cast<size_t>(std::count_if(
        methods.begin(), methods.end(), [](const Method& m) { return !m.equal_time; }));
    std::vector<std::vector<Run>> runs_by_method(methods.size());
    const auto run_interleaved = [&](size_t first, size_t end) {
      if (first == end) return;
      for (int r = 0; r < runs; ++r) {
        // Interleaved, and the order rotates each run so no method always runs first.
        for (size_t j = 0; j < end - first; ++j) {
          const size_t i = first + (j + r) % (end - first);
          runs_by_method[i].push_back(RunOnce(methods[i], p, 3.0));
        }
        std::cerr << p.name << ": run " << r + 1 << "/" << runs << " done\n";
      }
    };
    const auto summarize = [&](size_t end) {
      SceneResult s{.name = p.name,
                    .inputs = static_cast<int>(p.inputs.size()),
                    .input_lengths = p.input_lengths};
      for (size_t i = 0; i < end; ++i)
        s.methods.push_back(Summarize(methods[i], runs_by_method[i]));
      Compare(&s);
      return s;
    };
    run_interleaved(0, timed);
    SceneResult s = summarize(timed);
    // Without OMPL as shipped in the run there is no budget: the equal-time methods are left out.
    if (timed < methods.size() && s.shipped >= 0 && s.methods[s.shipped].runs_ok > 0) {
      p.equal_time_ms = s.methods[s.shipped].ms;
      run_interleaved(timed, methods.size());
      s = summarize(methods.size());
      s.equal_time_budget_ms = p.equal_time_ms;
    }
    if (!methods.empty() && methods[0].name == "hgraph-defaults") s.anytime = AnytimeCurve(p);
    results.push_back(std::move(s));
    // Rewritten after every scene, so a long run leaves its figures so far.
    WriteFile(out_dir / "results.json", Json(results, command, runs));
    WriteFile(out_dir / "results.md", Markdown(results, command, runs));
    WriteFile(out_dir / "results.svg", Svg(results));
  }
  std::cout << Markdown(results, command, runs);
  return 0;
}

}  // namespace
}  // namespace hgraph

int main(int argc, char** argv) {
  try {
    return hgraph::Main(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "hgraph-bench: " << e.what() << "\n";
    return 1;
  }
}
