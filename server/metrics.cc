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

void Metrics::DeclareCounter(const std::string& name, const std::string& help) {
  std::lock_guard lock(mutex_);
  order_.push_back(name);
  families_[name] = Family{.type = Type::kCounter, .help = help};
}

void Metrics::DeclareGauge(const std::string& name, const std::string& help) {
  std::lock_guard lock(mutex_);
  order_.push_back(name);
  families_[name] = Family{.type = Type::kGauge, .help = help};
}

void Metrics::DeclareHistogram(const std::string& name, const std::string& help,
                               std::vector<double> upper_bounds) {
  std::lock_guard lock(mutex_);
  order_.push_back(name);
  families_[name] = Family{.type = Type::kHistogram, .help = help, .bounds = std::move(upper_bounds)};
}

void Metrics::DeclareGaugeCallback(const std::string& name, const std::string& help,
                                   std::function<double()> read) {
  std::lock_guard lock(mutex_);
  order_.push_back(name);
  families_[name] = Family{.type = Type::kGauge, .help = help, .read = std::move(read)};
}

Metrics::Family& Metrics::Find(const std::string& name) {
  auto it = families_.find(name);
  // Using an undeclared metric is a bug in the server, not bad input.
  HGRAPH_CHECK(it != families_.end());
  return it->second;
}

void Metrics::Increment(const std::string& name, const Labels& labels, double by) {
  std::lock_guard lock(mutex_);
  Find(name).series[RenderLabels(labels)].value += by;
}

void Metrics::Set(const std::string& name, const Labels& labels, double value) {
  std::lock_guard lock(mutex_);
  Find(name).series[RenderLabels(labels)].value = value;
}

void Metrics::Observe(const std::string& name, const Labels& labels, double value) {
  std::lock_guard lock(mutex_);
  Family& family = Find(name);
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

double Metrics::Value(const std::string& name, const Labels& labels) const {
  std::lock_guard lock(mutex_);
  auto it = families_.find(name);
  if (it == families_.end()) return 0;
  if (it->second.read) return it->second.read();
  auto series = it->second.series.find(RenderLabels(labels));
  return series == it->second.series.end() ? 0 : series->second.value;
}

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
    const char* type = family.type == Type::kCounter   ? "counter"
                       : family.type == Type::kGauge   ? "gauge"
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
    throw Error(ErrorCode::kFailedPrecondition, "--metrics-address",
                "cannot listen on " + address);
  }
  mg_set_request_handler(context_, "/metrics", HandleMetrics,
                         const_cast<Metrics*>(&metrics_));
  mg_server_port ports[1] = {};
  if (mg_get_server_ports(context_, 1, ports) >= 1) port_ = ports[0].port;
}

MetricsHttpServer::~MetricsHttpServer() {
  mg_stop(context_);
  mg_exit_library();
}

}  // namespace hgraph::server
