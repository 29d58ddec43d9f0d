#include "server/metrics.h"

#include <civetweb.h>

#include <cmath>
#include <cstdio>
#include <sstream>

#include "core/common/error.h"

namespace hgraph::server {
namespace {

std::string Number(double v) {
  if (std::isinf(v)) return v > 0 ? "+Inf" : "-Inf";
  if (std::isnan(v)) return "NaN";
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.17g", v);
  return buffer;
}

std::string EscapeLabel(const std::string& value) {
  std::string out;
  for (char c : value) {
    if (c == '\\' || c == '"') out += '\\';
    if (c == '\n') {
      out += "\\n";
      continue;
    }
    out += c;
  }
  return out;
}

// Joins a rendered label set "{a="x"}" with one more label (the histogram's "le").
std::string WithLabel(const std::string& rendered, const std::string& extra) {
  if (rendered.empty()) return "{" + extra + "}";
  return rendered.substr(0, rendered.size() - 1) + "," + extra + "}";
}

}  // namespace

std::string Metrics::RenderLabels(const Labels& labels) {
  if (labels.empty()) return "";
  std::string out = "{";
  for (size_t i = 0; i < labels.size(); ++i) {
    if (i) out += ",";
    out += labels[i].first + "=\"" + EscapeLabel(labels[i].second) + "\"";
  }
  return out + "}";
}

Metrics::Family* Metrics::Declare(const std::string& name, Family family) {
  std::lock_guard lock(mutex_);
  const auto [it, inserted] = families_.emplace(name, std::move(family));
  // Declaring a family twice is a bug in the server, not bad input.
  HGRAPH_CHECK(inserted);
  order_.push_back(name);
  return &it->second;
}

Counter Metrics::DeclareCounter(const std::string& name, const std::string& help) {
  return Counter(this, Declare(name, Family{.type = Type::kCounter, .help = help}));
}

Gauge Metrics::DeclareGauge(const std::string& name, const std::string& help) {
  return Gauge(this, Declare(name, Family{.type = Type::kGauge, .help = help}));
}

Histogram Metrics::DeclareHistogram(const std::string& name, const std::string& help,
                                    std::vector<double> upper_bounds) {
  return Histogram(this, Declare(name, Family{.type = Type::kHistogram,
                                              .help = help,
                                              .bounds = std::move(upper_bounds)}));
}

void Metrics::DeclareGaugeCallback(const std::string& name, const std::string& help,
                                   std::function<double()> read) {
  Declare(name, Family{.type = Type::kGauge, .help = help, .read = std::move(read)});
}

void Metrics::Add(Family* family, const Labels& labels, double by) {
  std::lock_guard lock(mutex_);
  family->series[RenderLabels(labels)].value += by;
}

void Metrics::Assign(Family* family, const Labels& labels, double value) {
  std::lock_guard lock(mutex_);
  family->series[RenderLabels(labels)].value = value;
}

void Metrics::Observe(Family* family_ptr, const Labels& labels, double value) {
  std::lock_guard lock(mutex_);
  Family& family = *family_ptr;
  Series& series = family.series[RenderLabels(labels)];
  if (series.buckets.empty()) series.buckets.assign(family.bounds.size(), 0);
  for (size_t i = 0; i < family.bounds.size(); ++i) {
    if (value <= family.bounds[i]) {
      ++series.buckets[i];
      break;
    }
  }
  series.sum += value;
  ++series.count;
}

double Metrics::Read(const Family* family_ptr, const Labels& labels, bool count) const {
  std::lock_guard lock(mutex_);
  const Family& family = *family_ptr;
  auto series = family.series.find(RenderLabels(labels));
  if (series == family.series.end()) return 0;
  return count ? series->second.count : series->second.value;
}

void Counter::Increment(const Labels& labels, double by) const {
  metrics_->Add(family_, labels, by);
}
void Counter::Set(const Labels& labels, double total) const {
  metrics_->Assign(family_, labels, total);
}
double Counter::Value(const Labels& labels) const { return metrics_->Read(family_, labels, false); }
void Gauge::Set(const Labels& labels, double value) const {
  metrics_->Assign(family_, labels, value);
}
double Gauge::Value(const Labels& labels) const { return metrics_->Read(family_, labels, false); }
void Histogram::Observe(const Labels& labels, double value) const {
  metrics_->Observe(family_, labels, value);
}
double Histogram::Count(const Labels& labels) const {
  return metrics_->Read(family_, labels, true);
}

ServiceMetrics::ServiceMetrics(Metrics& registry)
    : rpc_started(
          registry.DeclareCounter("grpc_server_started_total", "RPCs started on the server.")),
      rpc_handled(registry.DeclareCounter(
          "grpc_server_handled_total",
          "RPCs completed on the server, regardless of success or failure.")),
      rpc_handling_seconds(registry.DeclareHistogram(
          "grpc_server_handling_seconds",
          "Response latency of RPCs handled by the server, in seconds.",
          {0.001, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1, 2.5, 5, 10, 30, 60, 300})),
      merges(registry.DeclareCounter("hgraph_merges_total",
                                     "Merges and re-queries that returned a result.")),
      collision_checks(registry.DeclareCounter(
          "hgraph_merge_collision_checks_total",
          "Collision checks run by merges, re-queries and path checks (by method).")),
      distance_queries(registry.DeclareCounter(
          "hgraph_merge_distance_queries_total",
          "Distance (clearance) queries run by merges, re-queries and path checks.")),
      edges_checked(registry.DeclareCounter(
          "hgraph_merge_edges_checked_total",
          "Local-planner runs (input edges, bridges, clearance re-checks, checked paths).")),
      edges_reused(registry.DeclareCounter(
          "hgraph_merge_edges_reused_total",
          "Stored edge reports that served a re-query without a new check.")),
      merge_phase_seconds(registry.DeclareHistogram("hgraph_merge_phase_seconds",
                                                    "Wall time of each merge phase.",
                                                    {0.001, 0.01, 0.1, 0.5, 1, 5, 10, 60, 300})),
      scene_cache_hits(
          registry.DeclareCounter("hgraph_scene_cache_hits_total",
                                  "Scene lookups served by an already loaded collision world.")),
      scene_cache_misses(
          registry.DeclareCounter("hgraph_scene_cache_misses_total",
                                  "Scene lookups that had to load meshes and build BVHs.")),
      scene_loads(
          registry.DeclareCounter("hgraph_scene_loads_total", "Scenes loaded and BVH-built.")),
      cache_bytes(registry.DeclareGauge(
          "hgraph_cache_bytes",
          "Bytes held in the cache, by kind (upload: reserved by unfinished uploads).")),
      cache_budget_bytes(registry.DeclareGauge("hgraph_cache_budget_bytes",
                                               "The cache's budget (--cache-bytes).")),
      cache_evictions(registry.DeclareCounter("hgraph_cache_evictions_total",
                                              "Cache entries evicted, by kind.")),
      sessions(registry.DeclareGauge("hgraph_sessions", "Live sessions.")),
      admitted_calls(registry.DeclareGauge("hgraph_admitted_calls",
                                           "Calls queued or running on the worker pool.")),
      store_errors(registry.DeclareCounter(
          "hgraph_store_errors_total",
          "Operations on the shared store (--store) that failed or timed out, by op; the "
          "server serves from memory meanwhile.")),
      store_loads(registry.DeclareCounter(
          "hgraph_store_loads_total",
          "Entries this replica did not hold and loaded from the shared store, by kind.")),
      store_refused(registry.DeclareCounter(
          "hgraph_store_refused_total",
          "Entries of the shared store refused as corrupt, truncated or foreign, by kind.")) {}

void Metrics::AddCollector(std::function<void()> collect) {
  std::lock_guard lock(mutex_);
  collectors_.push_back(std::move(collect));
}

std::string Metrics::Render() const {
  std::vector<std::function<void()>> collectors;
  {
    std::lock_guard lock(mutex_);
    collectors = collectors_;
  }
  for (const auto& collect : collectors) collect();
  std::ostringstream out;
  std::lock_guard lock(mutex_);
  for (const std::string& name : order_) {
    const Family& family = families_.at(name);
    const char* type = family.type == Type::kCounter ? "counter"
                       : family.type == Type::kGauge ? "gauge"
                                                     : "histogram";
    out << "# HELP " << name << " " << family.help << "\n# TYPE " << name << " " << type << "\n";
    if (family.read) {
      out << name << " " << Number(family.read()) << "\n";
      continue;
    }
    for (const auto& [labels, series] : family.series) {
      if (family.type != Type::kHistogram) {
        out << name << labels << " " << Number(series.value) << "\n";
        continue;
      }
      double cumulative = 0;
      for (size_t i = 0; i < family.bounds.size(); ++i) {
        cumulative += series.buckets[i];
        out << name << "_bucket" << WithLabel(labels, "le=\"" + Number(family.bounds[i]) + "\"")
            << " " << Number(cumulative) << "\n";
      }
      out << name << "_bucket" << WithLabel(labels, "le=\"+Inf\"") << " " << Number(series.count)
          << "\n";
      out << name << "_sum" << labels << " " << Number(series.sum) << "\n";
      out << name << "_count" << labels << " " << Number(series.count) << "\n";
    }
  }
  return out.str();
}

namespace {

int HandleMetrics(mg_connection* connection, void* data) {
  const auto* metrics = static_cast<const Metrics*>(data);
  const std::string body = metrics->Render();
  mg_printf(connection,
            "HTTP/1.1 200 OK\r\nContent-Type: text/plain; version=0.0.4; charset=utf-8\r\n"
            "Content-Length: %zu\r\nConnection: close\r\n\r\n",
            body.size());
  mg_write(connection, body.data(), body.size());
  return 200;
}

}  // namespace

MetricsHttpServer::MetricsHttpServer(const Metrics& metrics, const std::string& address)
    : metrics_(metrics) {
  mg_init_library(0);
  // Two threads: scrapes are rare and rendering is cheap.
  const char* options[] = {"listening_ports", address.c_str(), "num_threads", "2", nullptr};
  context_ = mg_start(nullptr, nullptr, options);
  if (context_ == nullptr) {
    mg_exit_library();
    throw Error(ErrorCode::kFailedPrecondition, "--metrics-listen", "cannot listen on " + address);
  }
  mg_set_request_handler(context_, "/metrics", HandleMetrics, const_cast<Metrics*>(&metrics_));
  mg_server_port ports[1] = {};
  if (mg_get_server_ports(context_, 1, ports) >= 1) port_ = ports[0].port;
}

MetricsHttpServer::~MetricsHttpServer() {
  mg_stop(context_);
  mg_exit_library();
}

}  // namespace hgraph::server
