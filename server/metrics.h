// Prometheus metrics in the text exposition format (version 0.0.4), served over HTTP by
// MetricsHttpServer. prometheus-cpp is not packaged in Debian bookworm, and the server needs
// only counters, gauges and histograms, so the registry is this small class.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

struct mg_context;

namespace hgraph::server {

// Label name/value pairs, in the order they are printed.
using Labels = std::vector<std::pair<std::string, std::string>>;

class Counter;
class Gauge;
class Histogram;

// The registry. Thread safe. Not copyable.
class Metrics {
 public:
  Metrics() = default;
  Metrics(const Metrics&) = delete;
  Metrics& operator=(const Metrics&) = delete;

  // Declares a family; families are printed in declaration order. A name is declared once.
  Counter DeclareCounter(const std::string& name, const std::string& help);
  Gauge DeclareGauge(const std::string& name, const std::string& help);
  Histogram DeclareHistogram(const std::string& name, const std::string& help,
                             std::vector<double> upper_bounds);
  // A gauge whose value is read when the metrics are rendered.
  void DeclareGaugeCallback(const std::string& name, const std::string& help,
                            std::function<double()> read);

  // Runs before every Render (outside the registry's lock), to Set gauges read from elsewhere.
  void AddCollector(std::function<void()> collect);

  std::string Render() const;

 private:
  friend class Counter;
  friend class Gauge;
  friend class Histogram;
  enum class Type { kCounter, kGauge, kHistogram };
  struct Series {
    double value = 0;             // counter, gauge
    std::vector<double> buckets;  // histogram: count per bound (not cumulative)
    double sum = 0;
    double count = 0;
  };
  struct Family {
    Type type = Type::kCounter;
    std::string help;
    std::vector<double> bounds;
    std::function<double()> read;
    std::map<std::string, Series> series;  // by rendered label set
  };
  static std::string RenderLabels(const Labels& labels);
  // Declares the family (a name declared twice is a bug) and returns it; std::map keeps it at
  // one address, which the handles hold.
  Family* Declare(const std::string& name, Family family);
  void Add(Family* family, const Labels& labels, double by);
  void Assign(Family* family, const Labels& labels, double value);
  void Observe(Family* family, const Labels& labels, double value);
  double Read(const Family* family, const Labels& labels, bool count) const;

  mutable std::mutex mutex_;
  std::vector<std::function<void()>> collectors_;
  std::vector<std::string> order_;
  std::map<std::string, Family> families_;
};

// Handles of one metric family, returned when the family is declared: call sites name a family
// by its handle, never by its string name. Copyable (a handle is two pointers); valid as long as
// the Metrics that declared it. Thread safe.
class Counter {
 public:
  void Increment(const Labels& labels = {}, double by = 1) const;
  // For a total kept elsewhere (a collector copies it in before each render).
  void Set(const Labels& labels, double total) const;
  double Value(const Labels& labels = {}) const;

 private:
  friend class Metrics;
  Counter(Metrics* metrics, Metrics::Family* family) : metrics_(metrics), family_(family) {}
  Metrics* metrics_;
  Metrics::Family* family_;
};

class Gauge {
 public:
  void Set(const Labels& labels, double value) const;
  double Value(const Labels& labels = {}) const;

 private:
  friend class Metrics;
  Gauge(Metrics* metrics, Metrics::Family* family) : metrics_(metrics), family_(family) {}
  Metrics* metrics_;
  Metrics::Family* family_;
};

class Histogram {
 public:
  void Observe(const Labels& labels, double value) const;
  // Observations of one series (0 if absent).
  double Count(const Labels& labels = {}) const;

 private:
  friend class Metrics;
  Histogram(Metrics* metrics, Metrics::Family* family) : metrics_(metrics), family_(family) {}
  Metrics* metrics_;
  Metrics::Family* family_;
};

// The service's metric families, declared once, here; members are in render order.
struct ServiceMetrics {
  explicit ServiceMetrics(Metrics& registry);

  // The grpc-ecosystem server metrics (go-grpc-prometheus names and labels).
  Counter rpc_started;
  Counter rpc_handled;
  Histogram rpc_handling_seconds;
  // Engine work, by method (MergePaths, Requery, CheckPaths).
  Counter merges;
  Counter collision_checks;
  Counter distance_queries;
  Counter edges_checked;
  Counter edges_reused;
  Histogram merge_phase_seconds;
  // Scenes and the cache.
  Counter scene_cache_hits;
  Counter scene_cache_misses;
  Counter scene_loads;
  Gauge cache_bytes;
  Gauge cache_budget_bytes;
  Counter cache_evictions;
  Gauge sessions;
  Gauge admitted_calls;
  // The shared store (--store redis://...): failed operations by op, and entries a replica
  // loaded from it (a session or H-Graph it did not hold) or refused (corrupt, foreign), by kind.
  Counter store_errors;
  Counter store_loads;
  Counter store_refused;
};

// Serves GET /metrics on a civetweb listener. Not copyable.
class MetricsHttpServer {
 public:
  // `address` is "host:port"; port 0 picks a free port. Throws Error(kFailedPrecondition) if the
  // listener cannot start.
  MetricsHttpServer(const Metrics& metrics, const std::string& address);
  ~MetricsHttpServer();
  MetricsHttpServer(const MetricsHttpServer&) = delete;
  MetricsHttpServer& operator=(const MetricsHttpServer&) = delete;

  int port() const { return port_; }

 private:
  const Metrics& metrics_;
  mg_context* context_ = nullptr;
  int port_ = 0;
};

}  // namespace hgraph::server
