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

// Thread safe. Not copyable.
class Metrics {
 public:
  Metrics() = default;
  Metrics(const Metrics&) = delete;
  Metrics& operator=(const Metrics&) = delete;

  // Declares a family; families are printed in declaration order.
  void DeclareCounter(const std::string& name, const std::string& help);
  void DeclareGauge(const std::string& name, const std::string& help);
  void DeclareHistogram(const std::string& name, const std::string& help,
                        std::vector<double> upper_bounds);
  // A gauge whose value is read when the metrics are rendered.
  void DeclareGaugeCallback(const std::string& name, const std::string& help,
                            std::function<double()> read);

  void Increment(const std::string& name, const Labels& labels, double by = 1);
  void Set(const std::string& name, const Labels& labels, double value);
  void Observe(const std::string& name, const Labels& labels, double value);

  // Runs before every Render (outside the registry's lock), to Set gauges read from elsewhere.
  void AddCollector(std::function<void()> collect);

  // Value of a counter or gauge series (0 if absent); for tests and logs.
  double Value(const std::string& name, const Labels& labels) const;

  std::string Render() const;

 private:
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
  Family& Find(const std::string& name);

  mutable std::mutex mutex_;
  std::vector<std::function<void()>> collectors_;
  std::vector<std::string> order_;
  std::map<std::string, Family> families_;
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
