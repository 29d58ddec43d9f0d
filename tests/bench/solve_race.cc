// Solve against single planners at equal wall time (issue 31): for every scene, budget and
// seed, Solve with several portfolios, and OMPL's optimizing planners alone (BIT*, RRT*, PRM*,
// given the whole budget), each output certified by our own CheckPaths (a path that fails it
// counts as none). The methods alternate (the order rotates with the seed). Prints and writes
// results.md, results.json and results.svg (certified length against time, with Solve's anytime
// curves) to --out after every scene. Never asserts: see README.md.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "core/adapter/scene_proto.h"
#include "core/collision/collision_world.h"
#include "core/common/error.h"
#include "core/merge/path_check.h"
#include "core/motion/local_planner.h"
#include "core/plan/plan.h"
#include "core/solve/solve.h"

namespace hgraph {
namespace {

namespace fs = std::filesystem;
constexpr double kInf = std::numeric_limits<double>::infinity();

struct Problem {
  std::string name;
  std::shared_ptr<const Scene> scene;
  std::unique_ptr<LocalPlanner> planner;
  double resolution = 0;
};

// One way to spend the budget: a Solve portfolio, or one planner run given all of it.
struct Method {
  std::string name;
  bool solve = true;
  std::vector<PortfolioEntry> portfolio;  // empty: the default
  double plan_fraction = -1;
  PlannerType planner = PlannerType::kBITStar;  // without solve
  // How the planners check their motions (Solve: SolveRequest::plan_check; alone: PlanRequest's).
  OmplMotionCheck plan_check = OmplMotionCheck::kDiscrete;
  OmplMotionCheck alone_check = OmplMotionCheck::kCertified;
};

struct Run {
  double length = kInf;  // certified length, or inf
  double ms = 0;
  bool found = false;      // a path came back
  bool certified = false;  // and CheckPaths certified it
  int inputs = 0;          // Solve: paths merged
  // Solve: the best certified path so far against the time (ms, length), from its updates.
  std::vector<std::pair<double, double>> curve;
};

std::vector<Method> AllMethods() {
  using P = PlannerType;
  return {
      {.name = "solve"},
      {.name = "solve-prm", .portfolio = {{P::kPRM, 4}}},
      {.name = "solve-prm8", .portfolio = {{P::kPRM, 8}}},
      {.name = "solve-bitstar", .portfolio = {{P::kBITStar, 2}}},
      {.name = "solve-bitstar-rrtstar", .portfolio = {{P::kBITStar, 2}, {P::kRRTStar, 1}}},
      {.name = "solve-prm-bitstar", .portfolio = {{P::kPRM, 4}, {P::kBITStar, 2}}},
      {.name = "solve-mixed", .portfolio = {{P::kPRM, 2}, {P::kBITStar, 1}, {P::kRRTStar, 1}}},
      {.name = "solve-prm4-mixed", .portfolio = {{P::kPRM, 4}, {P::kBITStar, 1}, {P::kRRTStar, 1}}},
      // One optimizing run beside PRM's: it starts first and keeps a slot (RunOrder).
      {.name = "solve-bitstar-prm", .portfolio = {{P::kBITStar, 1}, {P::kPRM, 3}}},
      {.name = "solve-rrtstar-prm", .portfolio = {{P::kRRTStar, 1}, {P::kPRM, 3}}},
      {.name = "solve-bitstar-prm-cert",
       .portfolio = {{P::kBITStar, 1}, {P::kPRM, 3}},
       .plan_check = OmplMotionCheck::kCertified},
      {.name = "solve-f50", .plan_fraction = 0.5},
      {.name = "solve-f90", .plan_fraction = 0.9},
      {.name = "bitstar", .solve = false, .planner = P::kBITStar},
      {.name = "bitstar-sampled",
       .solve = false,
       .planner = P::kBITStar,
       .alone_check = OmplMotionCheck::kDiscrete},
      {.name = "rrtstar", .solve = false, .planner = P::kRRTStar},
      {.name = "prmstar", .solve = false, .planner = P::kPRMStar},
      {.name = "informed-rrtstar", .solve = false, .planner = P::kInformedRRTStar},
      {.name = "aitstar", .solve = false, .planner = P::kAITStar},
  };
}

Problem LoadProblem(const std::string& name) {
  const fs::path source(HGRAPH_SOURCE_DIR);
  fs::path file = name;
  if (!fs::exists(file)) {
    file = fs::exists(source / "tests/bench/scenes" / name / "scene.json")
               ? source / "tests/bench/scenes" / name / "scene.json"
               : source / "scenes" / name / "scene.json";
  }
  const v1::Scene proto = ReadSceneFile(file.string());
  Problem p{.name = name};
  p.resolution = SceneResolution(proto);
  p.scene = SceneFromProto(proto, file.parent_path().string(), {});
  if (!p.scene->start || !p.scene->goal) throw InputError("scene", name + " has no start and goal");
  p.planner = std::make_unique<LocalPlanner>(std::make_shared<const CollisionWorld>(p.scene),
                                             LocalPlannerOptions{.resolution = p.resolution});
  return p;
}

double Certified(const Problem& p, const InputPath& path) {
  const PathCheckResult check = CheckPaths(*p.planner, {.paths = {path}});
  const InputReport& r = check.paths[0];
  return r.valid && r.certified ? r.quality.length : kInf;
}

Run RunOnce(const Method& m, const Problem& p, double budget_s, uint64_t seed, int parallel) {
  Run run;
  const auto t0 = std::chrono::steady_clock::now();
  if (m.solve) {
    const SolveResult r =
        Solve(*p.planner, SolveRequest{.start = *p.scene->start,
                                       .goal = *p.scene->goal,
                                       .merge = {.threads = parallel},
                                       .budget_s = budget_s,
                                       .portfolio = m.portfolio,
                                       .plan_fraction = m.plan_fraction,
                                       .parallel = parallel,
                                       .seed = seed,
                                       .resolution = p.resolution,
                                       .plan_check = m.plan_check,
                                       .on_update = [&](const SolveUpdate& u) {
                                         run.curve.emplace_back(u.elapsed_ms, u.objective);
                                       }});
    run.ms = MsSince(t0);
    run.found = r.found;
    run.inputs = static_cast<int>(r.inputs.size());
    if (r.found) run.length = Certified(p, r.result.path);
  } else {
    const PlanResult r = PlanPaths(*p.planner, PlanRequest{.planner = m.planner,
                                                           .start = *p.scene->start,
                                                           .goal = *p.scene->goal,
                                                           .time_s = budget_s,
                                                           .seed = seed,
                                                           .resolution = p.resolution,
                                                           .motion_check = m.alone_check,
                                                           .keep_uncertified = true});
    run.ms = MsSince(t0);
    run.found = !r.paths.empty();
    if (run.found) run.length = Certified(p, r.paths[0]);
  }
  run.certified = std::isfinite(run.length);
  return run;
}

double Median(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : (v[n / 2 - 1] + v[n / 2]) / 2;
}

std::string Num(double v, int precision = 4) {
  if (std::isnan(v)) return "-";
  if (std::isinf(v)) return "none";
  std::ostringstream o;
  o.precision(precision);
  o << v;
  return o.str();
}

struct Cell {
  std::vector<Run> runs;
  double median_length() const {
    std::vector<double> v;
    for (const Run& r : runs) v.push_back(r.length);  // inf (none) sorts last
    return Median(v);
  }
  double median_ms() const {
    std::vector<double> v;
    for (const Run& r : runs) v.push_back(r.ms);
    return Median(v);
  }
  int certified() const {
    int n = 0;
    for (const Run& r : runs) n += r.certified ? 1 : 0;
    return n;
  }
  int uncertified() const {
    int n = 0;
    for (const Run& r : runs) n += r.found && !r.certified ? 1 : 0;
    return n;
  }
};

// results[scene][budget][method]
using Results = std::map<std::string, std::map<double, std::map<std::string, Cell>>>;

std::string Markdown(const Results& results, const std::vector<Method>& methods,
                     const std::string& command) {
  std::ostringstream o;
  o << "`" << command << "`\n\n"
    << "Median certified length over the seeds (*none*: no certified path in at least half the "
       "runs); in brackets the runs with a certified path / all, and `u` the runs whose path "
       "failed the certified check. Then the median wall time in seconds.\n\n| scene | budget |";
  for (const Method& m : methods) o << " " << m.name << " |";
  o << "\n|---|---|";
  for (size_t i = 0; i < methods.size(); ++i) o << "---|";
  o << "\n";
  for (const auto& [scene, budgets] : results) {
    for (const auto& [budget, cells] : budgets) {
      o << "| " << scene << " | " << budget << " s |";
      for (const Method& m : methods) {
        const auto it = cells.find(m.name);
        if (it == cells.end()) {
          o << " - |";
          continue;
        }
        const Cell& c = it->second;
        o << " " << Num(c.median_length()) << " (" << c.certified() << "/" << c.runs.size();
        if (c.uncertified() > 0) o << ", " << c.uncertified() << "u";
        o << ") " << Num(c.median_ms() / 1e3, 3) << " s |";
      }
      o << "\n";
    }
  }
  return o.str();
}

std::string Json(const Results& results) {
  std::ostringstream o;
  o << "{\"scenes\": [";
  bool first_scene = true;
  for (const auto& [scene, budgets] : results) {
    o << (first_scene ? "" : ",") << "\n {\"name\": \"" << scene << "\", \"budgets\": [";
    first_scene = false;
    bool first_budget = true;
    for (const auto& [budget, cells] : budgets) {
      o << (first_budget ? "" : ",") << "\n  {\"budget_s\": " << budget << ", \"methods\": {";
      first_budget = false;
      bool first_method = true;
      for (const auto& [name, c] : cells) {
        o << (first_method ? "" : ",") << "\n   \"" << name << "\": {\"lengths\": [";
        first_method = false;
        for (size_t i = 0; i < c.runs.size(); ++i) {
          const double l = c.runs[i].length;
          o << (i ? ", " : "") << (std::isfinite(l) ? Num(l, 8) : "null");
        }
        o << "], \"ms\": [";
        for (size_t i = 0; i < c.runs.size(); ++i) o << (i ? ", " : "") << Num(c.runs[i].ms, 6);
        o << "], \"inputs\": [";
        for (size_t i = 0; i < c.runs.size(); ++i) o << (i ? ", " : "") << c.runs[i].inputs;
        o << "], \"curves\": [";
        for (size_t i = 0; i < c.runs.size(); ++i) {
          o << (i ? ", " : "") << "[";
          for (size_t k = 0; k < c.runs[i].curve.size(); ++k) {
            o << (k ? ", " : "") << "[" << Num(c.runs[i].curve[k].first, 6) << ", "
              << Num(c.runs[i].curve[k].second, 8) << "]";
          }
          o << "]";
        }
        o << "], \"uncertified\": " << c.uncertified() << "}";
      }
      o << "}}";
    }
    o << "]}";
  }
  o << "\n]}\n";
  return o.str();
}

// One panel per scene: certified length against wall time (log scale). Every run's result is a
// dot at its wall time (a path that failed CheckPaths, or none, is left out); Solve's runs also
// draw their anytime curve, the best certified path so far from its updates (the last point is
// the result CheckPaths judged). The single planners return one path at the end of their time.
std::string Svg(const Results& results, const std::vector<Method>& methods) {
  const std::vector<std::string> colors = {"#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd",
                                           "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf",
                                           "#aec7e8", "#ffbb78", "#98df8a"};
  const double panel_w = 420, panel_h = 260, left = 60, top = 40, gap = 70;
  const int columns = 2;
  const int panels = static_cast<int>(results.size());
  const int rows = (panels + columns - 1) / columns;
  const double legend_h = 18 * static_cast<double>(methods.size()) + 20;
  const double width = left + columns * (panel_w + gap);
  const double height = top + rows * (panel_h + gap) + legend_h;
  std::ostringstream o;
  o << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << width << "\" height=\"" << height
    << "\" font-family=\"sans-serif\" font-size=\"11\">\n<rect width=\"100%\" height=\"100%\" "
       "fill=\"white\"/>\n<text x=\""
    << left
    << "\" y=\"20\" font-size=\"14\">Certified length against wall time (every seed and "
       "budget; lines: Solve's best path so far)</text>\n";
  const auto color_of = [&](const std::string& name) {
    for (size_t i = 0; i < methods.size(); ++i) {
      if (methods[i].name == name) return colors[i % colors.size()];
    }
    return std::string("black");
  };
  int index = 0;
  for (const auto& [scene, budgets] : results) {
    const double x0 = left + (index % columns) * (panel_w + gap);
    const double y0 = top + (index / columns) * (panel_h + gap);
    ++index;
    double lo = kInf, hi = 0, t_hi = 0;
    for (const auto& [budget, cells] : budgets) {
      t_hi = std::max(t_hi, budget * 1.15);
      for (const auto& [name, c] : cells) {
        for (const Run& r : c.runs) {
          if (r.certified) {
            lo = std::min(lo, r.length);
            hi = std::max(hi, r.length);
          }
          for (const auto& point : r.curve) {
            lo = std::min(lo, point.second);
            hi = std::max(hi, point.second);
          }
        }
      }
    }
    o << "<text x=\"" << x0 << "\" y=\"" << y0 - 6 << "\" font-size=\"12\">" << scene
      << "</text>\n<rect x=\"" << x0 << "\" y=\"" << y0 << "\" width=\"" << panel_w
      << "\" height=\"" << panel_h << "\" fill=\"none\" stroke=\"#999\"/>\n";
    if (!(hi > 0)) continue;
    const double t_lo = 0.05;
    hi = std::min(hi, lo * 4);  // a far outlier would flatten the rest (drawn at the top)
    const double pad = (hi - lo) * 0.08 + 1e-9;
    const double y_lo = lo - pad, y_hi = hi + pad;
    const auto X = [&](double ms) {
      const double t = std::clamp(ms / 1e3, t_lo, t_hi);
      return x0 + panel_w * std::log(t / t_lo) / std::log(t_hi / t_lo);
    };
    const auto Y = [&](double len) {
      return y0 + panel_h * (1 - (std::min(len, y_hi) - y_lo) / (y_hi - y_lo));
    };
    for (double t : {0.1, 0.3, 1.0, 3.0, 10.0, 30.0, 100.0}) {
      if (t > t_hi) break;
      o << "<line x1=\"" << X(t * 1e3) << "\" x2=\"" << X(t * 1e3) << "\" y1=\"" << y0 << "\" y2=\""
        << y0 + panel_h << "\" stroke=\"#eee\"/><text x=\"" << X(t * 1e3) << "\" y=\""
        << y0 + panel_h + 14 << "\" text-anchor=\"middle\">" << Num(t) << " s</text>\n";
    }
    for (int k = 0; k <= 4; ++k) {
      const double len = y_lo + (y_hi - y_lo) * k / 4;
      o << "<text x=\"" << x0 - 4 << "\" y=\"" << Y(len) + 4 << "\" text-anchor=\"end\">"
        << Num(len, 4) << "</text>\n";
    }
    for (const auto& [budget, cells] : budgets) {
      for (const auto& [name, c] : cells) {
        const std::string color = color_of(name);
        for (const Run& r : c.runs) {
          if (!r.curve.empty()) {
            o << "<polyline fill=\"none\" stroke=\"" << color
              << "\" stroke-opacity=\"0.6\" points=\"";
            for (size_t k = 0; k < r.curve.size(); ++k) {
              const double end_ms = k + 1 < r.curve.size() ? r.curve[k + 1].first : r.ms;
              o << X(r.curve[k].first) << "," << Y(r.curve[k].second) << " " << X(end_ms) << ","
                << Y(r.curve[k].second) << " ";
            }
            o << "\"/>\n";
          }
          if (r.certified) {
            o << "<circle cx=\"" << X(r.ms) << "\" cy=\"" << Y(r.length) << "\" r=\"3.5\" fill=\""
              << color << "\"><title>" << name << ", " << Num(budget) << " s: " << Num(r.length)
              << " in " << Num(r.ms / 1e3, 3) << " s</title></circle>\n";
          }
        }
      }
    }
  }
  const double ly = top + rows * (panel_h + gap);
  for (size_t i = 0; i < methods.size(); ++i) {
    o << "<rect x=\"" << left << "\" y=\"" << ly + 18 * i << "\" width=\"12\" height=\"12\" fill=\""
      << colors[i % colors.size()] << "\"/><text x=\"" << left + 18 << "\" y=\"" << ly + 18 * i + 10
      << "\">" << methods[i].name << "</text>\n";
  }
  o << "</svg>\n";
  return o.str();
}

void WriteFile(const fs::path& path, const std::string& text) {
  std::ofstream f(path);
  f << text;
}

int Main(int argc, char** argv) {
  CLI::App app{"Solve against OMPL's optimizing planners alone at equal wall time"};
  std::vector<std::string> scene_names = {"home", "office", "twisty", "car_maze", "flat"};
  std::vector<double> budgets = {1, 3, 10};
  std::vector<std::string> only;
  int seeds = 3;
  uint64_t first_seed = 1;
  int parallel = 2;
  std::string out = "solve-bench-out";
  app.add_option("--scenes", scene_names, "scene names (tests/bench/scenes, scenes/) or files");
  app.add_option("--budgets", budgets, "budgets in seconds");
  app.add_option("--seeds", seeds, "runs per method, seeds first-seed, first-seed + 1, ...")
      ->check(CLI::PositiveNumber);
  app.add_option("--first-seed", first_seed, "the first seed");
  app.add_option("--parallel", parallel, "Solve's planner runs at once and merge threads");
  app.add_option("--methods", only, "only these methods");
  app.add_option("--out", out, "output folder");
  CLI11_PARSE(app, argc, argv);
  std::vector<Method> methods = AllMethods();
  if (!only.empty()) {
    std::erase_if(methods, [&](const Method& m) {
      return std::find(only.begin(), only.end(), m.name) == only.end();
    });
  }
  std::string command = "build/hgraph-solve-bench --seeds " + std::to_string(seeds) +
                        " --first-seed " + std::to_string(first_seed) + " --parallel " +
                        std::to_string(parallel) + " --scenes";
  for (const auto& s : scene_names) command += " " + s;
  command += " --budgets";
  for (double b : budgets) command += " " + Num(b);
  if (!only.empty()) {
    command += " --methods";
    for (const auto& m : only) command += " " + m;
  }
  fs::create_directories(out);
  Results results;
  for (const std::string& name : scene_names) {
    const Problem p = LoadProblem(name);
    for (double budget : budgets) {
      for (int s = 0; s < seeds; ++s) {
        for (size_t j = 0; j < methods.size(); ++j) {
          const Method& m = methods[(j + s) % methods.size()];
          const Run run = RunOnce(m, p, budget, first_seed + s, parallel);
          results[name][budget][m.name].runs.push_back(run);
          std::cerr << name << " " << budget << " s seed " << first_seed + s << " " << m.name
                    << ": " << Num(run.length)
                    << (run.found && !run.certified ? " (uncertified)" : "") << " in "
                    << Num(run.ms / 1e3, 3) << " s, " << run.inputs << " inputs\n";
        }
      }
      WriteFile(fs::path(out) / "results.md", Markdown(results, methods, command));
      WriteFile(fs::path(out) / "results.json", Json(results));
      WriteFile(fs::path(out) / "results.svg", Svg(results, methods));
    }
  }
  std::cout << Markdown(results, methods, command);
  return 0;
}

}  // namespace
}  // namespace hgraph

int main(int argc, char** argv) {
  try {
    return hgraph::Main(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "hgraph-solve-bench: " << e.what() << "\n";
    return 1;
  }
}
