#include "core/merge/snapshot.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <limits>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/common/error.h"
#include "core/merge/ceiling.h"

namespace hgraph {
namespace {

constexpr char kMagic[8] = {'H', 'G', 'S', 'E', 'S', 'S', 'N', '\0'};

// Fixed-width little-endian fields (every machine we build for is little-endian; the format
// says so, and a big-endian reader would have to swap), and counts as variable-length integers
// (LEB128: seven bits a byte, low bits first; one byte up to 127). Without a buffer it only counts
// the bytes (the first pass); with one it writes them there (the second, into a buffer of exactly
// that size: no growth and no copy of what is written).
class Writer {
 public:
  Writer() = default;
  explicit Writer(char* out) : out_(out) {}

  template <typename T>
  void Pod(T value) {
    static_assert(std::is_trivially_copyable_v<T>);
    if (out_ != nullptr) std::memcpy(out_ + at_, &value, sizeof(T));
    at_ += sizeof(T);
  }
  void Size(size_t n) { Varint(n); }
  void Varint(uint64_t n) {
    for (; n >= 0x80; n >>= 7) Pod<uint8_t>(static_cast<uint8_t>(n | 0x80));
    Pod<uint8_t>(static_cast<uint8_t>(n));
  }
  void Str(const std::string& s) {
    Size(s.size());
    Bytes(s.data(), s.size());
  }
  void Vector(const Config& q) {
    Size(static_cast<size_t>(q.size()));
    Bytes(q.data(), static_cast<size_t>(q.size()) * sizeof(double));
  }
  // The items one after the other, as Pod<T> on each would write them.
  template <typename T>
  void PodVector(const std::vector<T>& v) {
    static_assert(std::is_arithmetic_v<T>);
    Size(v.size());
    Bytes(v.data(), v.size() * sizeof(T));
  }
  template <typename T>
  void PodRange(const T& ids) {
    Size(ids.size());
    for (const auto id : ids) Pod<int32_t>(static_cast<int32_t>(id));
  }
  void Samples(const std::vector<ClearanceSample>& v) {
    Size(v.size());
    for (const ClearanceSample& s : v) SampleItem(s);
  }
  void Witness(const ClearanceWitness& w) {
    Pod<int32_t>(w.body);
    Bytes(w.point.data(), 3 * sizeof(double));
    Pod<int32_t>(w.other_body);
    Bytes(w.other_point.data(), 3 * sizeof(double));
  }
  void SampleItem(const ClearanceSample& s) {
    Pod<double>(s.t);
    Pod<double>(s.clearance);
  }
  void WitnessItem(const ClearanceWitness& w) { Witness(w); }
  size_t size() const { return at_; }

 private:
  void Bytes(const void* data, size_t n) {
    if (out_ != nullptr && n > 0) std::memcpy(out_ + at_, data, n);
    at_ += n;
  }
  char* out_ = nullptr;
  size_t at_ = 0;
};

class Reader {
 public:
  explicit Reader(std::string_view bytes) : in_(bytes) {}

  template <typename T>
  T Pod() {
    static_assert(std::is_trivially_copyable_v<T>);
    Need(sizeof(T));
    T value;
    std::memcpy(&value, in_.data() + at_, sizeof(T));
    at_ += sizeof(T);
    return value;
  }
  // A count of items of at least `item_bytes` bytes each: never more than the bytes left hold,
  // so that a forged count cannot make the reader allocate what the bytes do not back.
  size_t Size(size_t item_bytes = 1) {
    const uint64_t n = Varint();
    if (item_bytes > 0 && n > (in_.size() - at_) / item_bytes) Fail("a count past the end");
    return static_cast<size_t>(n);
  }
  // What Writer::Varint wrote: at most ten bytes, the last not zero unless it is the only one
  // (one encoding per value), and no bit past the 64th.
  uint64_t Varint() {
    uint64_t n = 0;
    for (int shift = 0;; shift += 7) {
      const auto byte = Pod<uint8_t>();
      if (shift == 63 && byte > 1) Fail("a count past 64 bits");
      n |= static_cast<uint64_t>(byte & 0x7f) << shift;
      if ((byte & 0x80) == 0) {
        if (byte == 0 && shift > 0) Fail("a count of more bytes than it needs");
        return n;
      }
      if (shift == 63) Fail("a count past 64 bits");
    }
  }
  int Index(int end, const char* what) {
    const auto i = Pod<int32_t>();
    if (i < 0 || i >= end) Fail(what);
    return i;
  }
  std::string Str() {
    const size_t n = Size();
    std::string s(in_.substr(at_, n));
    at_ += n;
    return s;
  }
  Config Vector() {
    const size_t n = Size(sizeof(double));
    Config q(static_cast<Eigen::Index>(n));
    Bytes(q.data(), n * sizeof(double));
    return q;
  }
  // What Writer::PodVector wrote (the items' bytes, one after the other).
  template <typename T>
  std::vector<T> PodVector() {
    static_assert(std::is_arithmetic_v<T>);
    std::vector<T> v(Size(sizeof(T)));
    Bytes(v.data(), v.size() * sizeof(T));
    return v;
  }
  // What Writer::Samples wrote, each sample's t checked.
  std::vector<ClearanceSample> Samples() {
    std::vector<ClearanceSample> v;
    SamplesInto(&v);
    return v;
  }
  void SamplesInto(std::vector<ClearanceSample>* v) {
    // The samples' bytes are their two doubles, t first (as Writer::SampleItem writes them).
    static_assert(sizeof(ClearanceSample) == 2 * sizeof(double) &&
                  offsetof(ClearanceSample, t) == 0 &&
                  offsetof(ClearanceSample, clearance) == sizeof(double));
    v->resize(Size(sizeof(ClearanceSample)));
    Bytes(v->data(), v->size() * sizeof(ClearanceSample));
    for (const ClearanceSample& s : *v) {
      if (!(s.t >= 0 && s.t <= 1)) Fail("a clearance sample outside [0, 1]");
    }
  }
  ClearanceWitness Witness() {
    ClearanceWitness w;
    w.body = Pod<int32_t>();
    for (int i = 0; i < 3; ++i) w.point[i] = Pod<double>();
    w.other_body = Pod<int32_t>();
    for (int i = 0; i < 3; ++i) w.other_point[i] = Pod<double>();
    if (w.body < -1 || w.other_body < -1) Fail("a witness of a negative body");
    return w;
  }
  // The next n bytes, skipped.
  std::string_view Take(size_t n) {
    Need(n);
    const std::string_view bytes = in_.substr(at_, n);
    at_ += n;
    return bytes;
  }
  void Bytes(void* out, size_t n) {
    Need(n);
    if (n > 0) std::memcpy(out, in_.data() + at_, n);
    at_ += n;
  }
  bool AtEnd() const { return at_ == in_.size(); }
  size_t left() const { return in_.size() - at_; }
  [[noreturn]] void Fail(const std::string& what) const {
    throw SnapshotError("H-Graph snapshot at byte " + std::to_string(at_) + ": " + what);
  }

 private:
  void Need(size_t n) const {
    if (n > in_.size() - at_) Fail("truncated");
  }
  std::string_view in_;
  size_t at_ = 0;
};

void WriteReport(Writer& w, const EdgeReport& r) {
  w.Pod<int8_t>(static_cast<int8_t>(r.state));
  w.Pod<double>(r.length);
  w.Pod<uint8_t>(r.has_clearance ? 1 : 0);
  w.Samples(r.profile);
  w.Pod<double>(r.invalid_at);
  w.Pod<uint8_t>(r.certified ? 1 : 0);
  HGRAPH_CHECK(r.collision_checks >= 0 && r.distance_queries >= 0);
  w.Varint(static_cast<uint64_t>(r.collision_checks));
  w.Varint(static_cast<uint64_t>(r.distance_queries));
}

EdgeReport ReadReport(Reader& r) {
  EdgeReport report;
  const auto state = r.Pod<int8_t>();
  if (state < 0 || state > static_cast<int8_t>(EdgeState::kInvalid)) r.Fail("an edge state");
  report.state = static_cast<EdgeState>(state);
  report.length = r.Pod<double>();
  report.has_clearance = r.Pod<uint8_t>() != 0;
  report.profile = r.Samples();
  for (size_t i = 1; i < report.profile.size(); ++i) {
    if (report.profile[i].t < report.profile[i - 1].t) r.Fail("a profile out of order");
  }
  report.invalid_at = r.Pod<double>();
  report.certified = r.Pod<uint8_t>() != 0;
  for (int64_t* count : {&report.collision_checks, &report.distance_queries}) {
    const uint64_t n = r.Varint();
    if (n > static_cast<uint64_t>(std::numeric_limits<int64_t>::max())) r.Fail("a check count");
    *count = static_cast<int64_t>(n);
  }
  return report;
}

void WriteCandidates(Writer& w, const CandidateOptions& c) {
  w.Pod<int32_t>(static_cast<int32_t>(c.variant));
  w.Pod<double>(c.radius);
  w.Pod<int32_t>(c.phi);
  w.Pod<double>(c.gap_init);
  w.Pod<double>(c.gap_extend);
}

CandidateOptions ReadCandidates(Reader& r) {
  CandidateOptions c;
  const auto variant = r.Pod<int32_t>();
  if (variant < 0 || variant > static_cast<int32_t>(Variant::kEditDistanceNeighborhood)) {
    r.Fail("a candidate variant");
  }
  c.variant = static_cast<Variant>(variant);
  c.radius = r.Pod<double>();
  c.phi = r.Pod<int32_t>();
  if (c.phi < 1) r.Fail("phi < 1");
  c.gap_init = r.Pod<double>();
  c.gap_extend = r.Pod<double>();
  return c;
}

template <typename T>
void WriteNested(Writer& w, const std::vector<std::vector<T>>& v, void (Writer::*item)(const T&)) {
  w.Size(v.size());
  for (const auto& inner : v) {
    w.Size(inner.size());
    for (const T& x : inner) (w.*item)(x);
  }
}

}  // namespace

// Reaches the private members of HybridizationSession and HGraph (their friend).
class SessionSnapshot {
 public:
  static void Save(const HybridizationSession& s, const std::vector<int32_t>& grids, Writer& w) {
    for (char c : kMagic) w.Pod<char>(c);
    w.Pod<uint32_t>(kSnapshotFormat);
    SaveOptions(w, s.options_);
    WriteCandidates(w, s.candidates_);
    w.Pod<int32_t>(s.alignments_);
    SaveGraph(w, s.graph_);
    w.Pod<MergeTiming>(s.build_timing_);
    w.Pod<uint8_t>(s.first_query_ ? 1 : 0);
    w.Pod<int64_t>(s.unreported_.edges_checked);
    w.Pod<int64_t>(s.unreported_.collision_checks);
    w.Pod<int64_t>(s.unreported_.distance_queries);
    w.PodRange(s.unprofiled_result_);
    SaveEvidence(w, s.graph_, s.evidence_, grids);
  }

  // Per edge, the stretches of the profile grid its ceiling lies on (ForEachCeilingPoint, as the
  // evaluator built it), or 0 when it does not or is empty.
  static std::vector<int32_t> CeilingGrids(const HybridizationSession& s) {
    const EdgeEvidence& v = s.evidence_;
    std::vector<int32_t> grids(v.ceiling.size(), 0);
    for (size_t e = 0; e < v.ceiling.size(); ++e) {
      const std::vector<ClearanceSample>& ceiling = v.ceiling[e];
      if (ceiling.empty()) continue;
      const int stretches = s.checker_->ProfileStretches(v.edge_length[e]);
      size_t at = 0;
      bool grid = true;
      ForEachCeilingPoint(stretches, [&](double t) {
        grid = grid && at < ceiling.size() && ceiling[at].t == t;
        ++at;
      });
      if (grid && at == ceiling.size()) grids[e] = stretches;
    }
    return grids;
  }

  static HybridizationSession Load(const ClearanceChecker& checker, std::string_view bytes) {
    Reader r(bytes);
    for (char c : kMagic) {
      if (r.Pod<char>() != c) r.Fail("not an H-Graph snapshot");
    }
    const auto format = r.Pod<uint32_t>();
    if (format != kSnapshotFormat) {
      r.Fail("format " + std::to_string(format) + ", this server reads format " +
             std::to_string(kSnapshotFormat));
    }
    MergeOptions options = LoadOptions(r);
    CandidateOptions candidates = ReadCandidates(r);
    const auto alignments = r.Pod<int32_t>();
    HGraph graph = LoadGraph(r, checker.space());
    HybridizationSession s(checker, std::move(graph));
    s.options_ = options;
    s.candidates_ = candidates;
    s.alignments_ = alignments;
    s.build_timing_ = r.Pod<MergeTiming>();
    s.first_query_ = r.Pod<uint8_t>() != 0;
    s.unreported_.edges_checked = r.Pod<int64_t>();
    s.unreported_.collision_checks = r.Pod<int64_t>();
    s.unreported_.distance_queries = r.Pod<int64_t>();
    const int edges = s.graph_.num_edges();
    for (int32_t e : r.PodVector<int32_t>()) {
      if (e < 0 || e >= edges) r.Fail("an unprofiled edge out of range");
      s.unprofiled_result_.push_back(e);
    }
    s.evidence_ = LoadEvidence(r, s.graph_);
    if (!r.AtEnd()) r.Fail("bytes after the end");
    return s;
  }

 private:
  static void SaveOptions(Writer& w, const MergeOptions& o) {
    WriteCandidates(w, o.candidates);
    w.Pod<int32_t>(static_cast<int32_t>(o.evaluation));
    w.Pod<int32_t>(static_cast<int32_t>(o.check_mode));
    w.Pod<uint8_t>(o.report_inputs ? 1 : 0);
    w.Pod<uint8_t>(o.report_clearance ? 1 : 0);
    w.Pod<double>(o.optimize_ms);
    w.Pod<uint8_t>(o.partial_shortcuts ? 1 : 0);
    w.Pod<int32_t>(o.optimize_restarts);
    w.Pod<uint8_t>(o.progress_paths ? 1 : 0);
    w.Pod<double>(o.endpoint_tolerance);
    w.Pod<int32_t>(o.threads);
    w.Pod<double>(o.max_node_spacing);
  }

  static MergeOptions LoadOptions(Reader& r) {
    MergeOptions o;
    o.candidates = ReadCandidates(r);
    const auto evaluation = r.Pod<int32_t>();
    if (evaluation < 0 || evaluation > static_cast<int32_t>(Evaluation::kEager)) {
      r.Fail("an evaluation");
    }
    o.evaluation = static_cast<Evaluation>(evaluation);
    const auto mode = r.Pod<int32_t>();
    if (mode < 0 || mode > static_cast<int32_t>(CheckMode::kSampled)) r.Fail("a check mode");
    o.check_mode = static_cast<CheckMode>(mode);
    o.report_inputs = r.Pod<uint8_t>() != 0;
    o.report_clearance = r.Pod<uint8_t>() != 0;
    o.optimize_ms = r.Pod<double>();
    o.partial_shortcuts = r.Pod<uint8_t>() != 0;
    o.optimize_restarts = r.Pod<int32_t>();
    o.progress_paths = r.Pod<uint8_t>() != 0;
    o.endpoint_tolerance = r.Pod<double>();
    o.threads = r.Pod<int32_t>();
    o.max_node_spacing = r.Pod<double>();
    return o;
  }

  static void SaveGraph(Writer& w, const HGraph& g) {
    w.Size(g.paths_.size());
    for (const InputPath& p : g.paths_) {
      w.Str(p.name);
      w.Size(p.waypoints.size());
      for (const Config& q : p.waypoints) w.Vector(q);
    }
    w.Size(g.nodes_.size());
    for (const HNode& n : g.nodes_) {
      w.Vector(n.q);
      w.Pod<int32_t>(n.path);
      w.Pod<int32_t>(n.index);
      w.Pod<double>(n.t);
    }
    w.Size(g.edges_.size());
    for (const HEdge& e : g.edges_) {
      w.Pod<int32_t>(e.u);
      w.Pod<int32_t>(e.v);
      w.Pod<uint8_t>(e.input ? 1 : 0);
      WriteReport(w, e.report);
    }
    for (size_t p = 0; p < g.paths_.size(); ++p) {
      w.PodRange(g.path_nodes_[p]);
      w.PodRange(g.path_edges_[p]);
    }
  }

  static Config CheckedConfig(Reader& r, const Space& space) {
    Config q = r.Vector();
    try {
      space.Validate(q, "q");
    } catch (const Error& e) {
      r.Fail(std::string("a configuration the scene's space refuses (") + e.what() + ")");
    }
    return q;
  }

  static HGraph LoadGraph(Reader& r, const Space& space) {
    HGraph g;
    const size_t paths = r.Size(16);
    if (paths == 0) r.Fail("no input path");
    g.paths_.resize(paths);
    for (InputPath& p : g.paths_) {
      p.name = r.Str();
      p.waypoints.resize(r.Size(8));
      if (p.waypoints.size() < 2) r.Fail("an input of fewer than two waypoints");
      for (Config& q : p.waypoints) q = CheckedConfig(r, space);
    }
    const size_t nodes = r.Size(24);
    if (nodes < 2 || nodes > static_cast<size_t>(std::numeric_limits<int32_t>::max())) {
      r.Fail("a node count out of range");
    }
    g.nodes_.resize(nodes);
    const int num_paths = static_cast<int>(paths);
    for (HNode& n : g.nodes_) {
      n.q = CheckedConfig(r, space);
      n.path = r.Pod<int32_t>();
      n.index = r.Pod<int32_t>();
      n.t = r.Pod<double>();
      if (n.path < -1 || n.path >= num_paths) r.Fail("a node on an unknown input");
      if (n.path >= 0 &&
          (n.index < 0 || static_cast<size_t>(n.index) >=
                              g.paths_[static_cast<size_t>(n.path)].waypoints.size())) {
        r.Fail("a node at an unknown waypoint");
      }
    }
    g.adjacency_.resize(nodes);
    const size_t edges = r.Size(9);
    if (edges > static_cast<size_t>(std::numeric_limits<int32_t>::max())) r.Fail("too many edges");
    g.edges_.reserve(edges);
    const int num_nodes = static_cast<int>(nodes);
    for (size_t e = 0; e < edges; ++e) {
      HEdge edge;
      edge.u = r.Index(num_nodes, "an edge's end out of range");
      edge.v = r.Index(num_nodes, "an edge's end out of range");
      if (edge.u == edge.v) r.Fail("an edge from a node to itself");
      edge.input = r.Pod<uint8_t>() != 0;
      edge.report = ReadReport(r);
      const int id = static_cast<int>(e);
      g.adjacency_[static_cast<size_t>(edge.u)].emplace_back(edge.v, id);
      g.adjacency_[static_cast<size_t>(edge.v)].emplace_back(edge.u, id);
      g.edges_.push_back(std::move(edge));
    }
    const int num_edges = static_cast<int>(edges);
    g.path_nodes_.resize(paths);
    g.path_edges_.resize(paths);
    for (size_t p = 0; p < paths; ++p) {
      for (int32_t id : r.PodVector<int32_t>()) {
        if (id < 0 || id >= num_nodes) r.Fail("an input's node out of range");
        g.path_nodes_[p].push_back(id);
      }
      for (int32_t id : r.PodVector<int32_t>()) {
        if (id < 0 || id >= num_edges) r.Fail("an input's edge out of range");
        g.path_edges_[p].push_back(id);
      }
      const auto& ids = g.path_nodes_[p];
      if (ids.size() < 2 || ids.front() != HGraph::start_id() || ids.back() != HGraph::goal_id() ||
          g.path_edges_[p].size() + 1 != ids.size()) {
        r.Fail("an input that does not run from the start to the goal");
      }
    }
    return g;
  }

  // Whether a search may still read edge e's ceiling: not on an edge found invalid or profiled
  // (its value is then exact), whose ceiling is not stored.
  static bool MayUseCeiling(const HGraph& g, size_t e) {
    const EdgeReport& r = g.edges_[e].report;
    return r.state != EdgeState::kInvalid && !r.has_clearance;
  }

  // Each edge's ceiling: its size (0 on an edge that cannot use it, MayUseCeiling), then, on a
  // grid (CeilingGrids), the grid's stretches, the width of its clearances (4: floats, as the
  // evaluator keeps them; 8: doubles) and its clearances only; else 0 and its samples.
  static void WriteCeilings(Writer& w, const HGraph& g, const EdgeEvidence& v,
                            const std::vector<int32_t>& grids) {
    w.Size(v.ceiling.size());
    for (size_t e = 0; e < v.ceiling.size(); ++e) {
      const std::vector<ClearanceSample>& ceiling = v.ceiling[e];
      if (!MayUseCeiling(g, e)) {
        w.Size(0);
        continue;
      }
      w.Size(ceiling.size());
      if (ceiling.empty()) continue;
      w.Pod<int32_t>(grids[e]);
      if (grids[e] > 0) {
        // Floats when every value is one (as the evaluator rounds them, CeilingValue).
        const bool floats = std::all_of(ceiling.begin(), ceiling.end(), [](const auto& c) {
          return CeilingValue(c.clearance) == c.clearance;
        });
        w.Pod<uint8_t>(floats ? sizeof(float) : sizeof(double));
        for (const ClearanceSample& c : ceiling) {
          if (floats) {
            w.Pod<float>(static_cast<float>(c.clearance));
          } else {
            w.Pod<double>(c.clearance);
          }
        }
      } else {
        for (const ClearanceSample& c : ceiling) w.SampleItem(c);
      }
    }
  }

  static std::vector<std::vector<ClearanceSample>> ReadCeilings(Reader& r, const HGraph& g) {
    std::vector<std::vector<ClearanceSample>> v(Count(r, static_cast<size_t>(g.num_edges())));
    for (size_t e = 0; e < v.size(); ++e) {
      std::vector<ClearanceSample>& ceiling = v[e];
      const size_t n = r.Size(sizeof(float));
      if (n == 0) continue;
      if (!MayUseCeiling(g, e)) r.Fail("a ceiling of an edge found invalid or profiled");
      const auto stretches = r.Pod<int32_t>();
      if (stretches < 0) r.Fail("a ceiling of a negative grid");
      if (stretches == 0) {
        if (n > (r.left() / 16)) r.Fail("a count past the end");
        ceiling.resize(n);
        for (ClearanceSample& s : ceiling) {
          s.t = r.Pod<double>();
          s.clearance = r.Pod<double>();
          if (!(s.t >= 0 && s.t <= 1)) r.Fail("a clearance sample outside [0, 1]");
        }
        continue;
      }
      ceiling.resize(n);
      size_t at = 0;
      ForEachCeilingPoint(stretches, [&](double t) {
        if (at < n) ceiling[at].t = t;
        ++at;
      });
      if (at != n) r.Fail("a ceiling of another size than its grid");
      const auto width = r.Pod<uint8_t>();
      if (width == sizeof(float)) {
        const std::string_view clearances = r.Take(n * sizeof(float));
        for (size_t i = 0; i < n; ++i) {
          float c = 0;
          std::memcpy(&c, clearances.data() + i * sizeof(float), sizeof(float));
          ceiling[i].clearance = c;
        }
      } else if (width == sizeof(double)) {
        const std::string_view clearances = r.Take(n * sizeof(double));
        for (size_t i = 0; i < n; ++i) {
          std::memcpy(&ceiling[i].clearance, clearances.data() + i * sizeof(double),
                      sizeof(double));
        }
      } else {
        r.Fail("a ceiling of values neither floats nor doubles");
      }
    }
    return v;
  }

  static void SaveEvidence(Writer& w, const HGraph& g, const EdgeEvidence& v,
                           const std::vector<int32_t>& grids) {
    w.PodVector<double>(v.goal_distance);
    w.PodVector<double>(v.node_clearance);
    w.PodVector<char>(v.node_valid);
    w.Size(v.node_witness.size());
    for (const ClearanceWitness& x : v.node_witness) w.Witness(x);
    w.PodVector<double>(v.edge_length);
    w.PodVector<double>(v.motion_bound);
    WriteNested(w, v.probes, &Writer::SampleItem);
    w.PodVector<int8_t>(v.probe_rounds);
    w.PodVector<int8_t>(v.scanned);
    WriteCeilings(w, g, v, grids);
    w.PodVector<int8_t>(v.ceiling_done);
    // The witnesses the ceilings do not hold yet, of the edges that may use them.
    w.Size(v.probe_witness.size());
    for (size_t e = 0; e < v.probe_witness.size(); ++e) {
      const bool kept = MayUseCeiling(g, e);
      w.Size(kept ? v.probe_witness[e].size() : 0);
      if (kept) {
        for (const ClearanceWitness& x : v.probe_witness[e]) w.Witness(x);
      }
    }
  }

  template <typename T, typename F>
  static std::vector<std::vector<T>> ReadNested(Reader& r, size_t expected, F item) {
    std::vector<std::vector<T>> v(Count(r, expected));
    for (auto& inner : v) {
      inner.resize(r.Size(8));
      for (T& x : inner) x = item(r);
    }
    return v;
  }

  static size_t Count(Reader& r, size_t expected) {
    const size_t n = r.Size(0);
    if (n != expected) r.Fail("evidence of another size than the H-Graph");
    return n;
  }

  template <typename T>
  static std::vector<T> Sized(Reader& r, size_t expected) {
    std::vector<T> v = r.PodVector<T>();
    if (v.size() != expected) r.Fail("evidence of another size than the H-Graph");
    return v;
  }

  static EdgeEvidence LoadEvidence(Reader& r, const HGraph& g) {
    const auto nodes = static_cast<size_t>(g.num_nodes());
    const auto edges = static_cast<size_t>(g.num_edges());
    EdgeEvidence v;
    v.goal_distance = Sized<double>(r, nodes);
    v.node_clearance = Sized<double>(r, nodes);
    v.node_valid = Sized<char>(r, nodes);
    v.node_witness.resize(Count(r, nodes));
    for (ClearanceWitness& x : v.node_witness) x = r.Witness();
    v.edge_length = Sized<double>(r, edges);
    v.motion_bound = Sized<double>(r, edges);
    v.probes.resize(Count(r, edges));
    for (std::vector<ClearanceSample>& p : v.probes) r.SamplesInto(&p);
    v.probe_rounds = Sized<int8_t>(r, edges);
    v.scanned = Sized<int8_t>(r, edges);
    v.ceiling = ReadCeilings(r, g);
    v.ceiling_done = Sized<int8_t>(r, edges);
    for (const int8_t state : v.ceiling_done) {
      if (state < kCeilingNone || state > kCeilingStale) {
        r.Fail("a ceiling's state out of range");
      }
    }
    v.probe_witness =
        ReadNested<ClearanceWitness>(r, edges, [](Reader& in) { return in.Witness(); });
    for (size_t e = 0; e < edges; ++e) {
      if (!v.probe_witness[e].empty() && !MayUseCeiling(g, e)) {
        r.Fail("witnesses of an edge found invalid or profiled");
      }
    }
    return v;
  }
};

void AppendSession(const HybridizationSession& session, std::string* out) {
  Writer count;
  const std::vector<int32_t> grids = SessionSnapshot::CeilingGrids(session);
  SessionSnapshot::Save(session, grids, count);
  const size_t at = out->size();
  out->resize(at + count.size());
  Writer write(out->data() + at);
  SessionSnapshot::Save(session, grids, write);
  HGRAPH_CHECK(write.size() == count.size());
}

std::string SaveSession(const HybridizationSession& session) {
  std::string out;
  AppendSession(session, &out);
  return out;
}

HybridizationSession LoadSession(const ClearanceChecker& checker, std::string_view bytes) {
  return SessionSnapshot::Load(checker, bytes);
}

}  // namespace hgraph
